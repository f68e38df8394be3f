"""pleat-motion: list the motion clips, convert one onto the Pleat body, show how a skeleton's joints match the
body's, measure every clip with the retargeting check, print the training/validation split (docs/motion.md)."""
import argparse
import json
import sys

from pleat.body.model import default_body_path
from pleat.cli import add_quiet, command, positive_float

DIR_HELP = "motion folder (default: $PLEAT_MOTION_DIR, ../shared/motion, data/motion)"
JOINT_MAP_HELP = ("JSON file {\"source joint\": \"body joint\" or null} for a BVH or ASF/AMC skeleton whose names "
                  "are not recognised (merged over the Mixamo table and the name guesses)")

ANIMATION_HELP = "glTF / GLB: the animation to read, by name or index (default: the first)"

STRICT_HELP = ("refuse a clip whose retargeting check goes beyond what the training clips do (bone directions more "
               "than 10° off the source's, forearms and hands inside the body), instead of warning; PLEAT_MOTION_STRICT=1 "
               "does this in every tool")


def build_parser():
    ap = argparse.ArgumentParser(prog="pleat-motion", description=__doc__)
    sub = ap.add_subparsers(dest="cmd", required=True, metavar="COMMAND")
    ls = sub.add_parser("list", help="clips found in the motion folder, with frames, fps and split, then the split's "
                                     "clips that are missing")
    ls.add_argument("--dir", default=None, help=DIR_HELP)
    add_quiet(ls)
    cv = sub.add_parser("convert", help="retarget one clip onto the body and write a clip npz")
    cv.add_argument("clip", help="clip name (as `list` prints it) or a .txt/.json/.bvh/.amc/.gltf/.glb/.npz file")
    cv.add_argument("--out", required=True, help="output file: the clip npz (Clip.save)")
    cv.add_argument("--fps", type=positive_float, default=30.0, help="frame rate the clip is resampled to")
    cv.add_argument("--body", default=None, help="body npz (default assets/body.npz)")
    cv.add_argument("--dir", default=None, help=DIR_HELP)
    cv.add_argument("--joint-map", default=None, metavar="FILE", help=JOINT_MAP_HELP)
    cv.add_argument("--animation", default=None, metavar="NAME", help=ANIMATION_HELP)
    cv.add_argument("--mirror", action="store_true", help="left-right mirror")
    cv.add_argument("--speed", type=positive_float, default=1.0, help="time scale (2 = twice as fast)")
    cv.add_argument("--strict", action="store_true", help=STRICT_HELP)
    add_quiet(cv)
    jt = sub.add_parser("joints", help="which source joint drives each body joint (matched, unmatched, unused); "
                                       "writes nothing")
    jt.add_argument("clip", help="clip name or motion file")
    jt.add_argument("--joint-map", default=None, metavar="FILE", help=JOINT_MAP_HELP)
    jt.add_argument("--animation", default=None, metavar="NAME", help=ANIMATION_HELP)
    jt.add_argument("--body", default=None, help="body npz (default assets/body.npz)")
    jt.add_argument("--dir", default=None, help=DIR_HELP)
    jt.add_argument("--json", action="store_true", help="print the match as JSON instead of a table")
    jt.add_argument("--out", default=None, metavar="PNG",
                    help="output file: a preview PNG of the body at the frames the check names")
    jt.add_argument("--strict", action="store_true", help=STRICT_HELP)
    add_quiet(jt)
    lm = sub.add_parser("limits", help="the retargeting check's two measures on every clip in the motion folder "
                                       "(the shipped clips set its limits: pleat.motion.check)")
    lm.add_argument("--dir", default=None, help=DIR_HELP)
    lm.add_argument("--body", default=None, help="body npz (default assets/body.npz)")
    add_quiet(lm)
    sp = sub.add_parser("split", help="the training / validation split (pleat.motion.split)")
    sp.add_argument("--dir", default=None, help=DIR_HELP)
    add_quiet(sp)
    return ap


def _info(path):
    """frames / fps / duration column of `list` (DeepMimic files), or why the file cannot be read."""
    from pleat.motion.loaders import _deepmimic_frames
    if path.suffix not in (".txt", ".json"):
        return ""
    try:
        frames = _deepmimic_frames(path)
    except (ValueError, OSError) as exc:
        return f"unreadable: {getattr(exc, 'problem', exc)}"
    dt = frames[:-1, 0]
    return f"{len(frames):6d} frames  {1 / float(sorted(dt)[len(dt) // 2]):6.1f} fps  {dt.sum():7.2f} s"


@command("pleat-motion", build_parser)
def main(args):

    from pleat.body.model import BodyModel
    from pleat.motion import split as split_mod
    from pleat.motion.loaders import list_clips, load_clip

    if args.cmd == "list":
        for name, path in list_clips(args.dir).items():
            print(f"{name:50s} {_info(path)}  {split_mod.split_of(name) or '-'}")
        # the split's clips that are not there (a fetch that could not reach a source): training leaves them out
        for name in split_mod.missing(args.dir):
            print(f"{name:50s} {'MISSING (scripts/fetch-motion.sh fetches it)':38s}  {split_mod.split_of(name)}")
    elif args.cmd == "joints":
        body = BodyModel.load(args.body or default_body_path())
        # the report shows the check whatever it says; --strict still refuses (after the report is printed)
        clip, match, check = load_clip(args.clip, body, motion_dir=args.dir, joint_map_file=args.joint_map,
                                       with_check=True, check=False, animation=args.animation)
        if args.json:
            print(json.dumps(dict(match.as_dict(), check=check.as_dict()), indent=1))
        else:
            print("\n".join(match.lines() + check.lines()))
        if check.problems:
            from pleat.motion.check import report
            report(check, args.clip, strict=args.strict or None)
        if args.out:
            from pleat.motion.check import write_preview
            write_preview(args.out, clip, body, check)
            if not args.quiet:
                print(f"pleat-motion: wrote {args.out}", file=sys.stderr)
    elif args.cmd == "limits":
        body = BodyModel.load(args.body or default_body_path())
        worst_inside, worst_bone = 0.0, 0.0
        for name in list_clips(args.dir):
            _, _, check = load_clip(name, body, motion_dir=args.dir, with_check=True, check=False)
            bone, deg = check.worst_bone
            worst_inside, worst_bone = max(worst_inside, check.inside_fraction), max(worst_bone, deg)
            print(f"{name:50s} worst bone {bone or '-':24s} {deg:5.1f}°  inside {100 * check.inside_fraction:5.2f} % "
                  f"(frame {check.inside_frame})")
        print(f"largest: bone {worst_bone:.1f}°, inside {100 * worst_inside:.2f} %")
    elif args.cmd == "convert":
        body = BodyModel.load(args.body or default_body_path())
        clip, match = load_clip(args.clip, body, motion_dir=args.dir, joint_map_file=args.joint_map,
                                with_match=True, animation=args.animation, strict=args.strict or None)
        if args.speed != 1.0:
            clip = clip.time_scaled(args.speed)
        if args.mirror:
            clip = clip.mirrored()
        duration = clip.duration
        clip = clip.resample(args.fps)
        if clip.num_frames < 2:
            from pleat.motion.loaders import MotionFileError
            raise MotionFileError(args.clip, f"lasts {duration:.4g} s: one frame at {args.fps:g} fps; a clip "
                                             "needs at least 2")
        out = clip.save(args.out)
        if not args.quiet:
            print("\n".join(["pleat-motion: joints:"] + match.lines()), file=sys.stderr)
        joints = match.as_dict()
        print(json.dumps(dict(out=str(out), name=clip.name, frames=clip.num_frames, fps=clip.fps,
                              duration_s=round(clip.duration, 4), source=clip.source,
                              joints=dict(matched=len(joints["matched"]), unmatched=joints["unmatched"],
                                          unused=joints["unused"]))))
    else:
        found = set(list_clips(args.dir))
        out = dict(training=[n for n in split_mod.TRAINING if n in found],
                   validation=[n for n in split_mod.VALIDATION if n in found],
                   missing=[n for n in split_mod.TRAINING + split_mod.VALIDATION if n not in found],
                   unassigned=sorted(n for n in found if split_mod.split_of(n) is None))
        print(json.dumps(out, indent=1))
        return 0 if not out["missing"] else 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
