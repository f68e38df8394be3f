"""Motion loaders → `Clip` on the Pleat body: DeepMimic (JSON .txt), BVH, Acclaim ASF/AMC, AMASS-style npz, and
Pleat clip npz (what `pleat-motion convert` writes).

Clips are found in $PLEAT_MOTION_DIR, then ../shared/motion beside the repository, then data/motion in it (where
scripts/fetch-motion.sh writes). See docs/motion.md.

Loading is parse → check → retarget → check. Every reader checks what it read before anything uses it (structure,
then meaning: at least two frames, a positive frame time, finite numbers, no zero quaternions, the joints that
retargeting needs) and raises `MotionFileError(path, what is wrong)`; anything else a malformed file makes a reader
raise is turned into a MotionFileError too. So a bad file costs one clear line in the CLIs (pleat.cli), never a
traceback and never a clip of NaNs.
"""
import json
import math
import zipfile
from pathlib import Path

import numpy as np

from pleat.body.model import BodyModel, SMPL_JOINT_NAMES, SMPL_PARENTS
from pleat.cli import InputError
from pleat.motion.clip import Clip
from pleat.motion.joint_map import (REQUIRED_JOINTS, JointMatch, guess_joint_map, match_joints,  # noqa: F401
                                    read_joint_map_file, strip_namespace)
from pleat.motion.readers import (  # noqa: F401  (the readers' names: loaders is where importers find them)
    MAX_BVH_DEPTH, MAX_DURATION_S, MAX_FRAME_TIME_S, MAX_JOINTS, MAX_POSITION, MIN_FRAMES, MIN_FRAME_TIME_S,
    MotionFileError, QUAT_MIN_NORM, _BVH_CHANNELS, _SPACE, _SUFFIXES, _Tokens, _bvh_hierarchy, _channel_at,
    _clip_name, _euler, _first_bad, _is_number, _read_text, check_source, find_motion_dir, read_bvh,
    strict_from_environment)
from pleat.motion.retarget import SourceMotion, retarget
from pleat.paths import REPO_ROOT, motion_dirs  # noqa: F401  (REPO_ROOT: kept for importers)
from pleat.rotations import axis_angle_to_matrix, quat_normalize, quat_to_matrix


# ---- finding clips -------------------------------------------------------------------------------------------------
def list_clips(motion_dir=None):
    """Clip names (paths relative to the motion folder, without suffix) → file paths."""
    root = Path(motion_dir) if motion_dir else find_motion_dir()
    if not root.is_dir():
        raise InputError(root, "no such motion folder")
    out = {}
    for p in sorted(root.rglob("*")):
        if p.suffix not in _SUFFIXES or not p.is_file() or p.name.upper().startswith(("LICENSE", "PROVENANCE")):
            continue
        out[str(p.relative_to(root).with_suffix(""))] = p
    return out


def resolve_clip(name_or_path, motion_dir=None):
    """A motion file path, or a clip name from the motion folder (`humanoid3d_walk`, `deepmimic_pybullet/...`)."""
    p = Path(name_or_path)
    if p.is_file():
        return p
    if p.is_dir():
        raise MotionFileError(p, "is a folder, not a motion file")
    try:
        clips = list_clips(motion_dir)
    except FileNotFoundError as exc:
        raise MotionFileError(name_or_path, f"no such file, and no motion folder to look the name up in ({exc})") \
            from None
    key = str(p.with_suffix("")) if p.suffix in _SUFFIXES else str(name_or_path)
    if key in clips:
        return clips[key]
    hits = [v for k, v in clips.items() if k.endswith("/" + key) or Path(k).name == key]
    if len(hits) == 1:
        return hits[0]
    if hits:
        raise MotionFileError(name_or_path, f"names {len(hits)} clips ({', '.join(sorted(str(h) for h in hits))}); "
                                            "give more of the path")
    raise MotionFileError(name_or_path, "no such file or clip name (pleat-motion list shows the clips)")


# ---- loading, checked ----------------------------------------------------------------------------------------------
def load_clip(name_or_path, body=None, motion_dir=None, joint_map=None, joint_map_file=None, with_match=False,
              check=True, strict=None, with_check=False, warn=None, **kw):
    """Any supported file or clip name → Clip retargeted onto `body` (default: assets/body.npz).

    joint_map: {body joint: source joint}, the whole map (replaces the matching); joint_map_file: a JSON file
    {source joint: body joint or null} (`--joint-map`), whose entries win over the structure and the names.
    with_match: also return the JointMatch (what `pleat-motion joints` reports). check: measure the result
    (pleat.motion.check) and warn in one line (`warn`, default stderr) when it goes beyond what the training clips
    do; strict (default: $PLEAT_MOTION_STRICT): a MotionFileError instead. with_check: return (clip, match, check).
    kw go to `retarget`."""
    path = resolve_clip(name_or_path, motion_dir)
    body = body or BodyModel.load()
    strict = strict_from_environment() if strict is None else strict
    user_map = read_joint_map_file(joint_map_file, body.joint_names) if joint_map_file else None
    fmt = _format_of(path)

    def done(clip, match, src=None, mapping=None, spread=None, rest_offsets="limbs"):
        result = None
        if check or with_check:
            from pleat.motion.check import check_retarget, report
            result = check_retarget(src, mapping, clip, body, spread, rest_offsets)
            if check:
                report(result, path, strict, warn)
        if with_check:
            return clip, match, result
        return (clip, match) if with_match else clip

    if fmt == "clip":
        clip = _reading(path, "Pleat clip npz", read_clip_file, path, body)
        match = JointMatch({n: n for n in clip.joint_names}, {n: "clip file" for n in clip.joint_names},
                           list(clip.joint_names), tuple(body.joint_names))
        if joint_map_file:
            raise InputError(joint_map_file, f"--joint-map applies to BVH and ASF/AMC skeletons; {path.name} is a "
                                             "Pleat clip already on the body")
        return done(clip, match)
    fps, animation = kw.pop("fps", None), kw.pop("animation", None)
    if fmt == "bvh":
        src = _reading(path, "BVH", read_bvh, path)
    elif fmt == "gltf":     # glTF / GLB: pleat.motion.gltf (animation: name or index, default the first)
        from pleat.motion.gltf import read_gltf
        src = _reading(path, "glTF", read_gltf, path, fps, animation)
    elif fmt == "amc":
        src = _reading(path, "ASF/AMC", read_amc, path)
        src.fps = float(fps or 120.0)
    elif fmt == "amass":
        src = _reading(path, "AMASS npz", read_amass, path, body)
        kw.setdefault("root_scale", 1.0)   # AMASS is in metres on human-sized SMPL bodies
    else:
        src = _reading(path, "DeepMimic JSON", read_deepmimic, path)
    check_source(src, path)
    if fmt == "bvh" and joint_map is None and not joint_map_file:
        # the body's own skeleton (pleat-garment scene's motion.bvh): the clip exactly, no retargeting or grounding
        from pleat.motion.bvh_export import clip_from_pleat_skeleton, pleat_skeleton_scale
        scale = pleat_skeleton_scale(src, body)
        if scale is not None:
            clip = clip_from_pleat_skeleton(src, body, scale)
            check_clip(clip, path)
            match = JointMatch({n: n for n in body.joint_names}, {n: "Pleat skeleton" for n in body.joint_names},
                               list(src.names), tuple(body.joint_names),
                               [n for n, has in zip(src.names, src.animated) if has])
            return done(clip, match)
    spread = None
    rest_offsets = "limbs"        # the fixed skeletons: the training clips were made this way
    if fmt in ("bvh", "amc", "gltf"):
        from pleat.motion.upright import up_rotation, uprighted
        src = uprighted(src, *up_rotation(src.parents, src.rest_positions, getattr(src, "tips", None)))
        src = _at_hips(src, joint_map, user_map, joint_map_file or path)
        dropped = {strip_namespace(n) for n in getattr(src, "dropped_above_hips", ())}
        if user_map and dropped:    # a map that leaves out the root bone ({"root": null}) still applies
            user_map = {k: v for k, v in user_map.items() if not (v is None and strip_namespace(k) in dropped)}
        animated = [n for n, has in zip(src.names, getattr(src, "animated", [True] * len(src.names))) if has]
        if joint_map is not None:
            match = JointMatch(dict(joint_map), {k: "joint_map argument" for k in joint_map}, list(src.names),
                               tuple(body.joint_names), animated)
        else:
            match = match_joints(src.names, user_map, joint_map_file, body.joint_names, animated,
                                 parents=src.parents, rest=src.rest_positions, body=body,
                                 tips=getattr(src, "tips", None), candidate=getattr(src, "animated", None))
        rest_offsets = "all"
    else:
        if joint_map_file:
            raise InputError(joint_map_file, f"--joint-map applies to BVH and ASF/AMC skeletons; {path.name} has "
                                             "a fixed skeleton")
        if fmt == "amass":
            mapping, animated = {n: n for n in SMPL_JOINT_NAMES}, list(SMPL_JOINT_NAMES[:22])
        else:
            mapping, spread = dict(DEEPMIMIC_MAP), DEEPMIMIC_SPREAD
            animated = [j[0] for j in DEEPMIMIC_JOINTS]
        shared = {n: mapping[k] for k, chain in (spread or {}).items() for n in chain if n != k}
        match = JointMatch(mapping, {k: "fixed" for k in mapping}, list(src.names), tuple(body.joint_names),
                           animated, shared)
    check_skeleton(src, match, path)
    try:
        clip = retarget(src, match.mapping, body, spread=spread, rest_offsets=rest_offsets, **kw)
    except InputError:
        raise
    except (ValueError, FloatingPointError, np.linalg.LinAlgError) as exc:
        raise MotionFileError(path, f"cannot be retargeted onto the body: {exc}") from None
    check_clip(clip, path)
    return done(clip, match, src, match.mapping, spread, rest_offsets)


def _at_hips(src, joint_map, user_map, map_path):
    """src re-rooted at its hips when a root above them is not part of the body (pleat.motion.reroot): the joint a
    joint map names for the pelvis, else the hips the legs show (pleat.motion.structure.hips_joint). A named pelvis
    must be the root or a joint both legs hang from."""
    from pleat.motion.reroot import rerooted
    from pleat.motion.structure import hips_joint, leg_fork
    named = (joint_map or {}).get("pelvis") or next((s for s, d in (user_map or {}).items() if d == "pelvis"), None)
    if named is None:
        return rerooted(src, hips_joint(src.parents, src.rest_positions, getattr(src, "tips", None)) or 0)
    hips = src.names.index(named) if named in src.names else next(
        (i for i, n in enumerate(src.names) if strip_namespace(n) == strip_namespace(named)), None)
    if hips is None or hips == 0:
        return src          # an unknown name is reported with the rest of the map (match_joints)
    fork = leg_fork(src.parents, src.rest_positions, getattr(src, "tips", None))
    above = fork
    while above is not None and above >= 0 and above != hips:
        above = int(src.parents[above])
    if fork is None or above != hips:
        raise InputError(map_path, f"the body's pelvis must be the skeleton's root {src.names[0]!r} or a joint both "
                                   f"legs hang from (the joint map pairs {named!r} with 'pelvis')")
    return rerooted(src, hips)


def load_clip_at(name_or_path, body=None, fps=30.0, max_frames=None, **kw):
    """load_clip, resampled to `fps` and cut to `max_frames`; still at least MIN_FRAMES frames (a clip shorter than a
    frame at `fps` is reported, not passed on as one frame)."""
    clip = load_clip(name_or_path, body, **kw)
    duration = clip.duration
    if abs(clip.fps - fps) > 1e-9:
        clip = clip.resample(fps)
    if max_frames and clip.num_frames > max_frames:
        clip = clip.frames_at(slice(0, max_frames))
    if clip.num_frames < MIN_FRAMES:
        raise MotionFileError(name_or_path, f"lasts {duration:.4g} s: {clip.num_frames} frame at {fps:g} fps; "
                                            f"a clip needs at least {MIN_FRAMES}")
    return clip


def _format_of(path):
    suffix = path.suffix.lower()
    if suffix not in _SUFFIXES:
        raise MotionFileError(path, f"unknown motion format {path.suffix or '(no suffix)'!r}: use DeepMimic .txt/"
                                    ".json, .bvh, .amc (+ .asf), .gltf/.glb, AMASS .npz or a Pleat clip .npz")
    if suffix == ".bvh":
        return "bvh"
    if suffix in (".gltf", ".glb"):
        return "gltf"
    if suffix == ".amc":
        return "amc"
    if suffix == ".npz":
        try:
            with zipfile.ZipFile(path) as z:
                names = set(z.namelist())
        except (zipfile.BadZipFile, EOFError, ValueError):
            raise MotionFileError(path, "is not an npz file (not a zip archive)") from None
        return "clip" if "local_rotations.npy" in names else "amass"
    return "deepmimic"


def _reading(path, fmt, reader, *args):
    """reader(*args), with whatever a malformed file makes it raise turned into one MotionFileError line."""
    try:
        return reader(*args)
    except (InputError, OSError, MemoryError):
        raise
    except UnicodeDecodeError:
        raise MotionFileError(path, f"is not a text file (not UTF-8): not a {fmt} file") from None
    except RecursionError:
        raise MotionFileError(path, f"nests too deeply to be read as {fmt}") from None
    except (ValueError, IndexError, KeyError, TypeError, OverflowError, ZeroDivisionError, AttributeError,
            zipfile.BadZipFile, EOFError) as exc:
        raise MotionFileError(path, f"malformed {fmt} file ({type(exc).__name__}: {exc})") from None


def check_skeleton(src, match, path):
    """The joints retargeting needs are there, and the rest skeleton tells facing and leg length."""
    missing = match.missing_required
    if missing:
        shown = ", ".join(src.names[:12]) + (", ..." if len(src.names) > 12 else "")
        raise MotionFileError(path, f"no source joint for {', '.join(missing)} (the skeleton has {shown}); name "
                                    "them in a --joint-map FILE (JSON {\"source joint\": \"body joint\"})")
    idx = {n: i for i, n in enumerate(src.names)}
    rest = np.asarray(src.rest_positions, np.float64)
    m = match.mapping
    hips = rest[idx[m["left_hip"]]] - rest[idx[m["right_hip"]]]
    if np.hypot(hips[0], hips[2]) < 1e-9:
        raise MotionFileError(path, f"the left and right hips ({m['left_hip']}, {m['right_hip']}) are not apart "
                                    "sideways in the rest skeleton: cannot tell which way it faces")
    for side in ("left", "right"):
        a, b, c = (rest[idx[m[f"{side}_{j}"]]] for j in ("hip", "knee", "ankle"))
        if np.linalg.norm(b - a) + np.linalg.norm(c - b) < 1e-9:
            raise MotionFileError(path, f"the {side} leg ({m[f'{side}_hip']} → {m[f'{side}_ankle']}) has zero "
                                        "length in the rest skeleton: no scale for the root path")


def check_clip(clip, path):
    """The retargeted clip: finite, unit quaternions."""
    for what, arr in (("joint rotations", clip.local_rotations), ("root path", clip.root_translation),
                      ("root rotations", clip.root_rotation)):
        if not np.isfinite(arr).all():
            raise MotionFileError(path, f"retargeting gives non-finite {what} (values out of range?)")


# ---- Pleat clip npz (pleat-motion convert) -------------------------------------------------------------------------
def read_clip_file(path, body=None):
    """A Clip npz (Clip.save), checked: keys, shapes, joint names of the body, ≥ 2 frames, fps, finite values and
    non-zero quaternions."""
    need = ("fps", "joint_names", "local_rotations", "root_translation", "root_rotation")
    with np.load(path, allow_pickle=False) as z:
        missing = [k for k in need if k not in z.files]
        if missing:
            raise MotionFileError(path, f"Pleat clip npz without {', '.join(missing)}")
        arrays = {k: z[k] for k in z.files}
    names = [str(n) for n in np.atleast_1d(arrays["joint_names"])]
    expected = list(body.joint_names if body is not None else SMPL_JOINT_NAMES)
    if names != expected:
        raise MotionFileError(path, f"clip joints {names[:4]}... are not the body's {len(expected)} joints")
    q, t, r = (np.asarray(arrays[k], np.float64) for k in ("local_rotations", "root_translation", "root_rotation"))
    T = q.shape[0] if q.ndim else 0
    if q.shape != (T, len(names), 4) or t.shape != (T, 3) or r.shape != (T, 4):
        raise MotionFileError(path, f"clip arrays have shapes {q.shape}, {t.shape}, {r.shape}; expected [T, "
                                    f"{len(names)}, 4], [T, 3], [T, 4]")
    if T < MIN_FRAMES:
        raise MotionFileError(path, f"has {T} frame{'s' if T != 1 else ''}; a clip needs at least {MIN_FRAMES}")
    fps = float(np.asarray(arrays["fps"]).reshape(-1)[0]) if np.asarray(arrays["fps"]).size else float("nan")
    if not math.isfinite(fps) or not 1.0 / MAX_FRAME_TIME_S <= fps <= 1.0 / MIN_FRAME_TIME_S:
        raise MotionFileError(path, f"frame rate {fps:g} fps is outside {1 / MAX_FRAME_TIME_S:g}..."
                                    f"{1 / MIN_FRAME_TIME_S:g} fps")
    for what, arr in (("joint rotation", q), ("root translation", t), ("root rotation", r)):
        if not np.isfinite(arr).all():
            raise MotionFileError(path, f"frame {_first_bad(~np.isfinite(arr))[0]}: a {what} is not finite")
    for what, arr in (("joint rotation", q), ("root rotation", r)):
        small = np.linalg.norm(arr, axis=-1) < QUAT_MIN_NORM
        if small.any():
            raise MotionFileError(path, f"frame {_first_bad(small)[0]}: a {what} quaternion is zero")
    return Clip(name=str(arrays.get("name", Path(path).stem)), fps=fps, local_rotations=quat_normalize(q),
                root_translation=t, root_rotation=quat_normalize(r), source=str(arrays.get("source", "")),
                joint_names=names)


def _uniform(times, local, root_pos):
    """Frames at irregular times → uniform frames at the median rate (slerp / lerp)."""
    dt = np.diff(times)
    step = float(np.median(dt))
    fps = 1.0 / step
    if np.allclose(dt, step, rtol=1e-3, atol=1e-6):
        return fps, local, root_pos
    from pleat.rotations import matrix_to_quat, quat_slerp
    n = int(round((times[-1] - times[0]) * fps)) + 1
    t = times[0] + np.arange(n) / fps
    i1 = np.clip(np.searchsorted(times, t, side="right"), 1, len(times) - 1)
    i0 = i1 - 1
    a = np.clip((t - times[i0]) / np.maximum(times[i1] - times[i0], 1e-12), 0, 1)
    q = matrix_to_quat(local)
    qs = quat_slerp(q[i0], q[i1], np.broadcast_to(a[:, None], (n, q.shape[1])))
    pos = root_pos[i0] * (1 - a[:, None]) + root_pos[i1] * a[:, None]
    return fps, quat_to_matrix(qs), pos


# ---- DeepMimic ---------------------------------------------------------------------------------------------------
# humanoid3d: 13 bodies. Frame = [dt, root pos (3), root quat (w,x,y,z), then per joint below a quaternion (w,x,y,z)
# or, for knees and elbows, one angle (rad) about the joint's z axis]. The rest pose (all rotations identity) stands
# facing +X with the arms hanging down, right side at +Z; offsets (m) from DeepMimic's data/characters/humanoid3d.txt.
DEEPMIMIC_JOINTS = [  # name, parent, offset from parent, dofs (4 = quaternion, 1 = revolute about z)
    ("root", -1, (0.0, 0.0, 0.0), 4),
    ("chest", 0, (0.0, 0.236151, 0.0), 4),
    ("neck", 1, (0.0, 0.223894, 0.0), 4),
    ("right_hip", 0, (0.0, 0.0, 0.084887), 4),
    ("right_knee", 3, (0.0, -0.421546, 0.0), 1),
    ("right_ankle", 4, (0.0, -0.40987, 0.0), 4),
    ("right_shoulder", 1, (-0.02405, 0.24350, 0.18311), 4),
    ("right_elbow", 6, (0.0, -0.274788, 0.0), 1),
    ("left_hip", 0, (0.0, 0.0, -0.084887), 4),
    ("left_knee", 8, (0.0, -0.421546, 0.0), 1),
    ("left_ankle", 9, (0.0, -0.40987, 0.0), 4),
    ("left_shoulder", 1, (-0.02405, 0.24350, -0.18311), 4),
    ("left_elbow", 11, (0.0, -0.274788, 0.0), 1),
]
DEEPMIMIC_FRAME_VALUES = 4 + sum(d for *_, d in DEEPMIMIC_JOINTS)      # dt, root position, then the rotations: 44
# end sites (no data): give the forearms their rest direction
DEEPMIMIC_ENDS = [("right_wrist", 7, (0.0, -0.258947, 0.0)), ("left_wrist", 12, (0.0, -0.258947, 0.0))]
DEEPMIMIC_MAP = {"pelvis": "root", "spine3": "chest", "head": "neck",
                 **{f"{s}_{j}": f"{s}_{j}" for s in ("left", "right") for j in ("hip", "knee", "ankle")},
                 **{f"{s}_{b}": f"{s}_{d}" for s in ("left", "right")
                    for b, d in (("shoulder", "shoulder"), ("elbow", "elbow"))}}
DEEPMIMIC_SPREAD = {"spine3": ["spine1", "spine2", "spine3"], "head": ["neck", "head"]}


def _wxyz_to_matrix(q):
    q = np.asarray(q, dtype=np.float64)
    return quat_to_matrix(np.concatenate([q[..., 1:4], q[..., 0:1]], axis=-1))


def _skeleton_rest(joints):
    pos = np.zeros((len(joints), 3))
    for i, (_, p, off, *_rest) in enumerate(joints):
        pos[i] = (pos[p] if p >= 0 else 0.0) + np.asarray(off)
    return pos


def _deepmimic_frames(path):
    """The "Frames" table of a DeepMimic JSON file, checked: [T ≥ 2, 44] finite numbers, positive durations."""
    text = _read_text(path)
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise MotionFileError(path, f"is not JSON ({exc.msg} at line {exc.lineno}, column {exc.colno})") from None
    if not isinstance(data, dict) or not isinstance(data.get("Frames"), list):
        raise MotionFileError(path, 'has no "Frames" list: a DeepMimic motion is {"Loop": ..., "Frames": '
                                    '[[duration, root position, rotations...], ...]}')
    rows = data["Frames"]
    for i, row in enumerate(rows):
        if not isinstance(row, list):
            raise MotionFileError(path, f"frame {i} is not a list of numbers")
        if len(row) != DEEPMIMIC_FRAME_VALUES:
            raise MotionFileError(path, f"frame {i} has {len(row)} values; humanoid3d frames have "
                                        f"{DEEPMIMIC_FRAME_VALUES}")
        for j, v in enumerate(row):
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise MotionFileError(path, f"frame {i}, value {j} is {json.dumps(v)[:20]}, not a number")
    if len(rows) < MIN_FRAMES:
        raise MotionFileError(path, f"has {len(rows)} frame{'s' if len(rows) != 1 else ''}; a clip needs at least "
                                    f"{MIN_FRAMES}")
    frames = np.asarray(rows, dtype=np.float64)
    if not np.isfinite(frames).all():
        i, j = _first_bad(~np.isfinite(frames))
        raise MotionFileError(path, f"frame {i}, value {j} is {frames[i, j]}: values must be finite")
    dt = frames[:-1, 0]                   # the last frame's duration is unused (DeepMimic writes 0 there)
    if np.all(dt == 0):
        raise MotionFileError(path, "every frame duration is 0 (the first value of a frame is its duration in s)")
    if np.any(dt <= 0):
        i = int(np.argmax(dt <= 0))
        raise MotionFileError(path, f"frame {i} has duration {dt[i]:g} s: durations must be positive")
    if dt.min() < MIN_FRAME_TIME_S or dt.max() > MAX_FRAME_TIME_S:
        bad = dt.min() if dt.min() < MIN_FRAME_TIME_S else dt.max()
        raise MotionFileError(path, f"a frame duration of {bad:g} s is outside {MIN_FRAME_TIME_S:g}..."
                                    f"{MAX_FRAME_TIME_S:g} s")
    col = 4
    for name, _, _, dof in DEEPMIMIC_JOINTS:
        if dof == 4:
            small = np.linalg.norm(frames[:, col:col + 4], axis=1) < QUAT_MIN_NORM
            if small.any():
                raise MotionFileError(path, f"frame {int(np.argmax(small))}: the {name} rotation quaternion is "
                                            "zero (w, x, y, z all 0)")
        col += dof
    return frames


def read_deepmimic(path):
    """DeepMimic JSON → SourceMotion (source units: metres, +Y up)."""
    frames = _deepmimic_frames(path)
    dt = frames[:, 0]
    times = np.concatenate([[0.0], np.cumsum(dt[:-1])])
    T = len(frames)
    joints = DEEPMIMIC_JOINTS + [(n, p, off, 0) for n, p, off in DEEPMIMIC_ENDS]
    local = np.broadcast_to(np.eye(3), (T, len(joints), 3, 3)).copy()
    col = 4
    for i, (_, _, _, dof) in enumerate(DEEPMIMIC_JOINTS):
        if dof == 4:
            local[:, i] = _wxyz_to_matrix(frames[:, col:col + 4])
        else:
            aa = np.zeros((T, 3))
            aa[:, 2] = frames[:, col]
            local[:, i] = axis_angle_to_matrix(aa)
        col += dof
    fps, local, root = _uniform(times, local, frames[:, 1:4])
    return SourceMotion(name=_clip_name(path), source=f"DeepMimic humanoid3d {Path(path).name}", fps=fps,
                        names=[j[0] for j in joints], parents=np.array([j[1] for j in joints]),
                        rest_positions=_skeleton_rest(joints), local_rotations=local, root_positions=root)


def load_deepmimic(path, body=None, **kw):
    return load_clip(Path(path), body, **kw)


def load_bvh(path, body=None, joint_map=None, **kw):
    return load_clip(Path(path), body, joint_map=joint_map, **kw)


# ---- Acclaim ASF/AMC ---------------------------------------------------------------------------------------------
def _floats(path, parts, what, count=None):
    try:
        values = [float(x) for x in parts]
    except ValueError:
        raise MotionFileError(path, f"{what}: {' '.join(parts)[:40]!r} are not numbers") from None
    if count is not None and len(values) != count:
        raise MotionFileError(path, f"{what} needs {count} numbers, has {len(values)}")
    if not all(math.isfinite(v) for v in values):
        raise MotionFileError(path, f"{what} has a non-finite value")
    return np.array(values)


def read_asf(path):
    lines = [ln.split("#")[0].strip() for ln in _read_text(path).splitlines()]
    lines = [ln for ln in lines if ln]
    bones = {"root": dict(direction=np.zeros(3), length=0.0, axis=np.zeros(3), axis_order="XYZ", dof=[])}
    order_root, axis_root = ["TX", "TY", "TZ", "RX", "RY", "RZ"], "XYZ"
    hierarchy = {}
    section, cur = None, None
    for ln in lines:
        if ln.startswith(":"):
            section = ln.split()[0][1:]
            continue
        parts = ln.split()
        if section == "root":
            if parts[0] == "order":
                order_root = [p.upper() for p in parts[1:]]
                if any(o not in ("TX", "TY", "TZ", "RX", "RY", "RZ") for o in order_root):
                    raise MotionFileError(path, f"root order {' '.join(parts[1:])!r}: use TX TY TZ RX RY RZ")
            elif parts[0] == "axis":
                axis_root = parts[1].upper()
                bones["root"]["axis_order"] = axis_root
            elif parts[0] == "orientation":
                bones["root"]["axis"] = _floats(path, parts[1:4], "root orientation", 3)
        elif section == "bonedata":
            if parts[0] == "begin":
                cur = dict(direction=np.zeros(3), length=0.0, axis=np.zeros(3), axis_order="XYZ", dof=[])
            elif cur is None:
                raise MotionFileError(path, f"bone data {ln[:40]!r} outside begin ... end")
            elif parts[0] == "end":
                if "name" not in cur:
                    raise MotionFileError(path, "a bone without a name")
                bones[cur["name"]] = cur
                cur = None
            elif parts[0] == "name":
                cur["name"] = parts[1]
            elif parts[0] == "direction":
                cur["direction"] = _floats(path, parts[1:4], f"bone {cur.get('name')} direction", 3)
            elif parts[0] == "length":
                cur["length"] = float(_floats(path, parts[1:2], f"bone {cur.get('name')} length", 1)[0])
            elif parts[0] == "axis":
                cur["axis"] = _floats(path, parts[1:4], f"bone {cur.get('name')} axis", 3)
                cur["axis_order"] = parts[4].upper() if len(parts) > 4 else "XYZ"
            elif parts[0] == "dof":
                cur["dof"] = [p.lower() for p in parts[1:]]
                if any(d not in ("rx", "ry", "rz", "tx", "ty", "tz", "l") for d in cur["dof"]):
                    raise MotionFileError(path, f"bone {cur.get('name')}: unknown dof in {ln[:40]!r}")
        elif section == "hierarchy":
            if parts[0] in ("begin", "end"):
                continue
            for child in parts[1:]:
                hierarchy[child] = parts[0]
    for child, parent in hierarchy.items():
        for n in (child, parent):
            if n not in bones:
                raise MotionFileError(path, f"the hierarchy names bone {n!r}, which :bonedata does not define")
    if len(bones) < 2 or not hierarchy:
        raise MotionFileError(path, "has no bones (:bonedata) or no :hierarchy")
    # Parents first, and only the bones that hang from the root: what read_amc indexes joints by.
    order = _asf_parents_first(path, hierarchy)
    return bones, {child: hierarchy[child] for child in order[1:]}, order_root


def _asf_parents_first(path, hierarchy):
    """The root, then the bones of `hierarchy` (child → parent) that hang from it, parents first: by depth, and within
    a depth in the order the file lists them (the order of a level-by-level walk). Linear in the bones: each bone's
    depth is found once, by walking up to the first bone whose depth is known. Bones on a cycle or under a parent that
    is not the root's descendant are left out. Nesting deeper than a BVH may (MAX_BVH_DEPTH joints, the root included)
    is refused: no skeleton is that deep, and a file that claims it is malformed."""
    depth = {"root": 0}
    for bone in hierarchy:
        chain, n = [], bone
        while n not in depth and n in hierarchy:
            depth[n] = None  # on this walk: meeting it again means a cycle
            chain.append(n)
            n = hierarchy[n]
        d = depth.get(n)  # None: a cycle, or a top bone other than the root
        d = -1 if d is None else d
        for c in reversed(chain):
            d = d + 1 if d >= 0 else -1
            if d >= MAX_BVH_DEPTH:
                raise MotionFileError(path, f"bones nest more than {MAX_BVH_DEPTH} deep (at {c!r}); a skeleton is "
                                            "not this deep: the file is malformed")
            depth[c] = d
    return ["root"] + sorted((b for b in hierarchy if b != "root" and depth[b] > 0), key=depth.__getitem__)


def read_amc(path, asf_path=None):
    path = Path(path)
    asf_path = Path(asf_path) if asf_path else path.with_suffix(".asf")
    if not asf_path.is_file():
        raise MotionFileError(path, f"no ASF skeleton {asf_path.name} beside it")
    bones, hierarchy, order_root = read_asf(asf_path)
    names = ["root"] + list(hierarchy)  # read_asf lists the bones parents first
    idx = {n: i for i, n in enumerate(names)}
    parents = np.array([-1] + [idx[hierarchy[n]] for n in names[1:]])
    # a bone rotates about its start (= the end of its parent): rest position of "joint" b is its start
    ends = np.zeros((len(names), 3))
    rest = np.zeros((len(names), 3))
    for i, n in enumerate(names):
        if i:
            rest[i] = ends[parents[i]]
            b = bones[n]
            ends[i] = rest[i] + b["direction"] / max(np.linalg.norm(b["direction"]), 1e-12) * b["length"]
    frames = []
    for ln in _read_text(path).splitlines():
        ln = ln.strip()
        if not ln or ln.startswith(("#", ":")):
            continue
        parts = ln.split()
        if len(parts) == 1 and parts[0].isdigit():
            frames.append({})
        elif frames:
            bone = parts[0]
            if bone not in bones:
                raise MotionFileError(path, f"frame {len(frames) - 1}: bone {bone!r} is not in {asf_path.name}")
            want = len(order_root) if bone == "root" else len(bones[bone]["dof"])
            frames[-1][bone] = _floats(path, parts[1:], f"frame {len(frames) - 1}, bone {bone}", want)
        else:
            raise MotionFileError(path, f"{ln[:40]!r} before the first frame number")
    T = len(frames)
    if T < MIN_FRAMES:
        raise MotionFileError(path, f"has {T} frame{'s' if T != 1 else ''}; a clip needs at least {MIN_FRAMES}")
    local = np.broadcast_to(np.eye(3), (T, len(names), 3, 3)).copy()
    root = np.zeros((T, 3))
    for i, n in enumerate(names):
        b = bones[n]
        C = _euler(b["axis_order"], b["axis"], intrinsic=False)
        if n == "root":
            vals = np.stack([f.get("root", np.zeros(len(order_root))) for f in frames])
            rot_axes = "".join(o[1] for o in order_root if o.startswith("R"))
            rot_cols = [j for j, o in enumerate(order_root) if o.startswith("R")]
            for j, o in enumerate(order_root):
                if o.startswith("T"):
                    root[:, "XYZ".index(o[1])] = vals[:, j]
            M = _euler(rot_axes, vals[:, rot_cols], intrinsic=False)
        else:
            dofs = [d for d in b["dof"] if d.startswith("r")]
            if not dofs:
                continue
            vals = np.stack([f.get(n, np.zeros(len(b["dof"])))[[b["dof"].index(d) for d in dofs]] for f in frames])
            M = _euler("".join(d[1] for d in dofs), vals, intrinsic=False)
        local[:, i] = C @ M @ C.T
    src = SourceMotion(name=_clip_name(path), source=f"ASF/AMC {asf_path.name} + {path.name}", fps=120.0,
                       names=names, parents=parents, rest_positions=rest, local_rotations=local, root_positions=root)
    src.animated = [n == "root" or any(d.startswith("r") for d in bones[n]["dof"]) for n in names]
    # a childless bone still has a length and a direction: where it ends tells which way a foot or a head points
    src.tips = {i: ends[i] for i in range(1, len(names)) if i not in set(parents.tolist())}
    return src


def load_asf_amc(path, body=None, fps=120.0, joint_map=None, **kw):
    """An .amc file with the .asf of the same stem beside it. Acclaim files carry no frame rate: `fps` (CMU: 120)."""
    return load_clip(Path(path), body, joint_map=joint_map, fps=fps, **kw)


# ---- AMASS (SMPL-H npz) ------------------------------------------------------------------------------------------
Z_UP_TO_Y_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def read_amass(path, body):
    """SMPL-H `poses` [T,156] axis-angle (root, 21 body joints, 2×15 hand joints), `trans` [T,3] (Z up),
    `mocap_framerate` → SourceMotion on the SMPL joint layout. SMPL's rest is a T-pose: the source rest skeleton
    is the Pleat body's own J(0) with the arms made horizontal, so only the arms get a rest offset."""
    with np.load(path, allow_pickle=False) as z:
        missing = [k for k in ("poses", "trans") if k not in z.files]
        rate_key = next((k for k in ("mocap_framerate", "mocap_frame_rate") if k in z.files), None)
        if missing or rate_key is None:
            missing += [] if rate_key else ["mocap_framerate"]
            raise MotionFileError(path, f"AMASS npz without {', '.join(missing)}")
        poses = np.asarray(z["poses"], dtype=np.float64)
        trans = np.asarray(z["trans"], dtype=np.float64)
        rate = np.asarray(z[rate_key], dtype=np.float64)
    if poses.ndim != 2 or poses.shape[1] < 66:
        raise MotionFileError(path, f"poses has shape {poses.shape}; it must be [T, 156] (or at least 66) "
                                    "axis-angle values")
    T = poses.shape[0]
    if trans.shape != (T, 3):
        raise MotionFileError(path, f"trans has shape {trans.shape}; with {T} poses it must be [{T}, 3]")
    if rate.size != 1:
        raise MotionFileError(path, f"{rate_key} must be one number")
    fps = float(rate.reshape(-1)[0])
    if not fps > 0 or not math.isfinite(fps):
        raise MotionFileError(path, f"{rate_key} is {fps:g}: it must be a positive frame rate")
    for what, arr in (("poses", poses[:, :66]), ("trans", trans)):
        if not np.isfinite(arr).all():
            raise MotionFileError(path, f"frame {_first_bad(~np.isfinite(arr))[0]}: {what} has a non-finite value")
    local = np.broadcast_to(np.eye(3), (T, 24, 3, 3)).copy()
    local[:, :22] = axis_angle_to_matrix(poses[:, :66].reshape(T, 22, 3))    # hands (22, 23) stay identity
    local[:, 0] = Z_UP_TO_Y_UP @ local[:, 0]
    names = list(SMPL_JOINT_NAMES)
    rest = body.joints().copy()
    for side, sx in (("left", 1.0), ("right", -1.0)):
        chain = [names.index(f"{side}_{j}") for j in ("shoulder", "elbow", "wrist", "hand")]
        for a, b in zip(chain[:-1], chain[1:]):
            length = np.linalg.norm(body.joints()[b] - body.joints()[a])
            rest[b] = rest[a] + np.array([sx * length, 0.0, 0.0])
    return SourceMotion(name=_clip_name(path), source=f"AMASS {Path(path).name}", fps=fps, names=names,
                        parents=np.array(SMPL_PARENTS), rest_positions=rest, local_rotations=local,
                        root_positions=trans @ Z_UP_TO_Y_UP.T)


def load_amass(path, body=None, **kw):
    return load_clip(Path(path), body, **kw)
