"""pleat-motion: list the motion clips, convert one onto the Pleat body, print the training/validation split."""
import argparse
import json
import sys

from pleat.body.model import BodyModel, default_body_path


def main(argv=None):
    ap = argparse.ArgumentParser(prog="pleat-motion", description=__doc__)
    sub = ap.add_subparsers(dest="cmd", required=True)
    ls = sub.add_parser("list", help="clips found in the motion folder, with frames, fps and split")
    ls.add_argument("--dir", default=None, help="motion folder (default: $PLEAT_MOTION_DIR, ../shared/motion, "
                                                "data/motion)")
    cv = sub.add_parser("convert", help="retarget one clip onto the body and write a clip npz")
    cv.add_argument("clip", help="clip name (as `list` prints it) or a .txt/.json/.bvh/.amc/.npz file")
    cv.add_argument("--fps", type=float, default=30.0)
    cv.add_argument("--out", required=True)
    cv.add_argument("--body", default=str(default_body_path()))
    cv.add_argument("--dir", default=None)
    cv.add_argument("--mirror", action="store_true", help="left-right mirror")
    cv.add_argument("--speed", type=float, default=1.0, help="time scale (2 = twice as fast)")
    sp = sub.add_parser("split", help="the training / validation split (pleat.motion.split)")
    sp.add_argument("--dir", default=None)
    args = ap.parse_args(argv)

    from pleat.motion import split as split_mod
    from pleat.motion.loaders import list_clips, load_clip

    if args.cmd == "list":
        import json as _json
        import numpy as np
        for name, path in list_clips(args.dir).items():
            info = ""
            if path.suffix in (".txt", ".json"):
                with open(path) as fh:
                    frames = np.asarray(_json.load(fh)["Frames"])
                info = f"{len(frames):6d} frames  {1 / np.median(frames[:-1, 0]):6.1f} fps  " \
                       f"{frames[:-1, 0].sum():7.2f} s"
            print(f"{name:50s} {info}  {split_mod.split_of(name) or '-'}")
    elif args.cmd == "convert":
        body = BodyModel.load(args.body)
        clip = load_clip(args.clip, body, motion_dir=args.dir)
        if args.speed != 1.0:
            clip = clip.time_scaled(args.speed)
        if args.mirror:
            clip = clip.mirrored()
        clip = clip.resample(args.fps)
        clip.save(args.out)
        print(json.dumps(dict(out=args.out, name=clip.name, frames=clip.num_frames, fps=clip.fps,
                              duration_s=round(clip.duration, 4), source=clip.source)))
    else:
        from pleat.motion.loaders import list_clips as lc
        found = set(lc(args.dir))
        out = dict(training=[n for n in split_mod.TRAINING if n in found],
                   validation=[n for n in split_mod.VALIDATION if n in found],
                   missing=[n for n in split_mod.TRAINING + split_mod.VALIDATION if n not in found],
                   unassigned=sorted(n for n in found if split_mod.split_of(n) is None))
        print(json.dumps(out, indent=1))
        return 0 if not out["missing"] else 1


if __name__ == "__main__":
    sys.exit(main())
