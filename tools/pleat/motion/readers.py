"""The motion file readers below `load_clip` (pleat.motion.loaders): the limits every reader checks, MotionFileError,
the motion folder, the source checks, PLEAT_MOTION_STRICT and the BVH reader. The glTF reader, the BVH export and the
retargeting check (pleat.motion.check) read and write through these, and loaders dispatches to all of them and calls
the check, so they sit here, below loaders, instead of in it.
"""
import math
import os
from pathlib import Path

import numpy as np

from pleat.cli import InputError
from pleat.motion.retarget import SourceMotion
from pleat.paths import motion_dirs
from pleat.rotations import axis_angle_to_matrix


MIN_FRAMES = 2                   # a clip needs a start and an end: (T − 1)/fps is its duration
MIN_FRAME_TIME_S = 1e-4          # 10 kHz: faster is not mocap, it is a units mistake
MAX_FRAME_TIME_S = 10.0
MAX_DURATION_S = 3600.0
MAX_POSITION = 1e6               # |root / offset coordinates| in source units (cm: 10 km)
MAX_BVH_DEPTH = 256              # joints nested, root included (BVH and ASF); real skeletons are < 40 deep
MAX_JOINTS = 1024
QUAT_MIN_NORM = 1e-6
_SUFFIXES = (".txt", ".json", ".bvh", ".amc", ".npz", ".gltf", ".glb")


class MotionFileError(InputError):
    """A motion file that cannot be turned into a clip, and why (one line)."""


def find_motion_dir():
    for d in motion_dirs():
        if d.is_dir():
            return d
    raise FileNotFoundError("no motion folder: set PLEAT_MOTION_DIR or run scripts/fetch-motion.sh "
                            f"(looked in {', '.join(str(d) for d in motion_dirs())})")


def strict_from_environment():
    """PLEAT_MOTION_STRICT=1: every tool refuses a clip that the retargeting check flags (as --strict does)."""
    return os.environ.get("PLEAT_MOTION_STRICT", "") not in ("", "0")


def _clip_name(path):
    path = Path(path)
    try:
        root = find_motion_dir()
        return str(path.resolve().relative_to(root.resolve()).with_suffix(""))
    except (ValueError, FileNotFoundError):
        return path.stem


def _first_bad(mask):
    """Index tuple of the first True in `mask`."""
    return tuple(int(i) for i in np.argwhere(mask)[0])


def check_source(src, path):
    """A SourceMotion that retargeting can use: ≥ 2 frames, a sane frame rate, finite numbers."""
    T = src.local_rotations.shape[0]
    if T < MIN_FRAMES:
        raise MotionFileError(path, f"has {T} frame{'s' if T != 1 else ''}; a clip needs at least {MIN_FRAMES}")
    fps = float(src.fps)
    if not math.isfinite(fps) or not 1.0 / MAX_FRAME_TIME_S <= fps <= 1.0 / MIN_FRAME_TIME_S:
        raise MotionFileError(path, f"frame rate {fps:g} fps is outside {1 / MAX_FRAME_TIME_S:g}..."
                                    f"{1 / MIN_FRAME_TIME_S:g} fps")
    if (T - 1) / fps > MAX_DURATION_S:
        raise MotionFileError(path, f"lasts {(T - 1) / fps:.0f} s; clips longer than {MAX_DURATION_S:.0f} s are "
                                    "not supported: cut it")
    for what, arr in (("rest skeleton offset", src.rest_positions), ("root position", src.root_positions)):
        arr = np.asarray(arr, np.float64)
        if not np.isfinite(arr).all():
            raise MotionFileError(path, f"a {what} is not finite ({arr[_first_bad(~np.isfinite(arr))]})")
        if np.abs(arr).max(initial=0.0) > MAX_POSITION:
            raise MotionFileError(path, f"a {what} of {np.abs(arr).max():g} is out of range (|x| ≤ {MAX_POSITION:g})")
    R = np.asarray(src.local_rotations)
    bad = ~np.isfinite(R).all(axis=(-2, -1))
    if bad.any():
        t, s = _first_bad(bad)
        raise MotionFileError(path, f"frame {t}: joint {src.names[s]!r} has a non-finite rotation")


def _read_text(path):
    text = Path(path).read_text(encoding="utf-8")
    if not text.strip():
        raise MotionFileError(path, "is empty")
    return text


def _euler(order, angles_deg, intrinsic):
    """Rotation from Euler angles (degrees) about the axes in `order` (e.g. "ZXY"). intrinsic (BVH): R = R1·R2·R3;
    otherwise (Acclaim: the first listed axis is applied first): R = R3·R2·R1."""
    angles = np.deg2rad(np.asarray(angles_deg, dtype=np.float64))
    R = np.broadcast_to(np.eye(3), angles.shape[:-1] + (3, 3)).copy()
    for i, ax in enumerate(order.upper()):
        aa = np.zeros(angles.shape[:-1] + (3,))
        aa[..., "XYZ".index(ax)] = angles[..., i]
        Ri = axis_angle_to_matrix(aa)
        R = R @ Ri if intrinsic else Ri @ R
    return R


# ---- BVH -----------------------------------------------------------------------------------------------------------
_SPACE = "\x00"                 # stands for a space inside a joint name while the file is split into words
_BVH_CHANNELS = {f"{a}{k}": (a, k) for a in "XYZ" for k in ("position", "rotation")}


class _Tokens:
    """The whitespace-separated words of a BVH file, read front to back, with errors that say what was expected."""

    def __init__(self, path, words):
        self.path, self.words, self.pos = path, words, 0

    def next(self, expected):
        if self.pos >= len(self.words):
            raise MotionFileError(self.path, f"ends early: expected {expected}")
        self.pos += 1
        return self.words[self.pos - 1]

    def expect(self, word, where=""):
        got = self.next(repr(word) + where)
        if got != word:
            raise MotionFileError(self.path, f"expected {word!r}{where}, found {got[:40]!r}")

    def number(self, what, integer=False):
        word = self.next(what)
        try:
            value = int(word) if integer else float(word)
        except ValueError:
            kind = "an integer" if integer else "a number"
            raise MotionFileError(self.path, f"{what} is {word[:40]!r}, not {kind}") from None
        if not integer and not math.isfinite(value):
            raise MotionFileError(self.path, f"{what} is {word}: it must be finite")
        return value


def _bvh_hierarchy(path, tok):
    """HIERARCHY → names, parents, offsets, channels; iterative (a stack of open joints), at most MAX_BVH_DEPTH
    deep."""
    names, parents, offsets, channels, is_end = [], [], [], [], []
    tok.expect("HIERARCHY")
    tok.expect("ROOT", " after HIERARCHY")
    stack = []

    def open_joint(name, parent, end=False):
        if len(names) >= MAX_JOINTS:
            raise MotionFileError(path, f"has more than {MAX_JOINTS} joints")
        if len(stack) >= MAX_BVH_DEPTH:
            raise MotionFileError(path, f"joints nest more than {MAX_BVH_DEPTH} deep (at {name!r}); a skeleton is "
                                        "not this deep: the file is malformed")
        tok.expect("{", f" after {'End Site' if end else 'joint ' + repr(name)}")
        names.append(name)
        parents.append(parent)
        offsets.append(None)
        channels.append([])
        is_end.append(end)
        stack.append(len(names) - 1)

    open_joint(tok.next("the root joint's name"), -1)
    while stack:
        j = stack[-1]
        where = f" in joint {names[j]!r}"
        word = tok.next(f"'}}' closing joint {names[j]!r}")
        if word == "OFFSET":
            offsets[j] = [tok.number(f"OFFSET{where}") for _ in range(3)]
        elif word == "CHANNELS":
            if is_end[j]:
                raise MotionFileError(path, f"End Site of {names[parents[j]]!r} has CHANNELS")
            n = tok.number(f"the CHANNELS count{where}", integer=True)
            if not 0 <= n <= 6:
                raise MotionFileError(path, f"CHANNELS count {n}{where}: a joint has 0 to 6 channels")
            chans = [tok.next(f"{n} channel names{where}") for _ in range(n)]
            for c in chans:
                if c.capitalize() not in _BVH_CHANNELS:
                    raise MotionFileError(path, f"unknown channel {c[:40]!r}{where} (Xposition ... Zrotation)")
            if len({c.lower() for c in chans}) != len(chans):
                raise MotionFileError(path, f"a channel is listed twice{where}")
            channels[j] = [c.capitalize() for c in chans]
        elif word == "JOINT":
            if is_end[j]:
                raise MotionFileError(path, f"End Site of {names[parents[j]]!r} has a child joint")
            open_joint(tok.next(f"a joint name{where}"), j)
        elif word == "End":
            tok.expect("Site", " after 'End'")
            open_joint(f"{names[j]}_end", j, end=True)
        elif word == "}":
            if offsets[j] is None:
                raise MotionFileError(path, f"joint {names[j]!r} has no OFFSET")
            stack.pop()
        else:
            raise MotionFileError(path, f"unexpected {word[:40]!r}{where}")
    seen = set()
    for n, end in zip(names, is_end):
        if not end and n in seen:
            raise MotionFileError(path, f"joint name {n!r} appears twice")
        seen.add(n)
    return names, parents, offsets, channels


def read_bvh(path):
    path = Path(path)
    # a joint name may have spaces (3ds Max Biped: `JOINT Bip01 L Thigh`): kept as one word while parsing
    lines = []
    for line in _read_text(path).splitlines():
        words = line.split()
        if len(words) > 2 and words[0] in ("ROOT", "JOINT"):
            line = f"{words[0]} {_SPACE.join(words[1:])}"
        lines.append(line)
    tok = _Tokens(path, "\n".join(lines).split())
    names, parents, offsets, channels = _bvh_hierarchy(path, tok)
    names = [n.replace(_SPACE, " ") for n in names]
    tok.expect("MOTION", " after the HIERARCHY")
    tok.expect("Frames:", " after MOTION")
    n_frames = tok.number("the Frames: count", integer=True)
    tok.expect("Frame", " after the Frames: count")
    tok.expect("Time:", " after 'Frame'")
    frame_time = tok.number("Frame Time")
    if not frame_time > 0:
        raise MotionFileError(path, f"Frame Time is {frame_time:g}: it must be a positive number of seconds per "
                                    "frame")
    if n_frames < MIN_FRAMES:
        raise MotionFileError(path, f"has {max(n_frames, 0)} frame{'s' if n_frames != 1 else ''} (Frames: "
                                    f"{n_frames}); a clip needs at least {MIN_FRAMES}")
    n_ch = sum(len(c) for c in channels)
    if n_ch == 0:
        raise MotionFileError(path, "has no CHANNELS: nothing moves")
    words = tok.words[tok.pos:]
    if len(words) != n_frames * n_ch:
        full = len(words) // n_ch
        if len(words) < n_frames * n_ch:
            raise MotionFileError(path, f"has {full} complete frame{'s' if full != 1 else ''} of {n_ch} channels, "
                                        f"but Frames: says {n_frames} (truncated?)")
        raise MotionFileError(path, f"has {len(words) - n_frames * n_ch} values more than Frames: {n_frames} × "
                                    f"{n_ch} channels")
    try:
        values = np.asarray(words, dtype=np.float64)
    except ValueError:
        k = next(i for i, w in enumerate(words) if not _is_number(w))
        raise MotionFileError(path, f"motion value {words[k][:40]!r} (frame {k // n_ch}) is not a number") from None
    values = values.reshape(n_frames, n_ch)
    if not np.isfinite(values).all():
        t, c = _first_bad(~np.isfinite(values))
        joint, chan = _channel_at(names, channels, c)
        raise MotionFileError(path, f"frame {t}: {joint} {chan} is {values[t, c]}: values must be finite")
    offsets = np.asarray(offsets, np.float64)
    rest = np.zeros_like(offsets)
    for i, p in enumerate(parents):
        rest[i] = offsets[i] + (rest[p] if p >= 0 else 0.0)
    local = np.broadcast_to(np.eye(3), (n_frames, len(names), 3, 3)).copy()
    root = np.broadcast_to(offsets[0], (n_frames, 3)).copy()
    translations = {}
    col = 0
    for i, ch in enumerate(channels):
        block = values[:, col:col + len(ch)]
        col += len(ch)
        rot_axes = [c[0] for c in ch if c.endswith("rotation")]
        rot_cols = [j for j, c in enumerate(ch) if c.endswith("rotation")]
        if rot_axes:
            local[:, i] = _euler("".join(rot_axes), block[:, rot_cols], intrinsic=True)
        if i == 0:
            for j, c in enumerate(ch):
                if c.endswith("position"):
                    root[:, "XYZ".index(c[0])] = block[:, j]
        elif any(c.endswith("position") for c in ch):
            # a joint below the root that moves (an engine's pelvis under its root bone): its position channels
            # replace its OFFSET, as they do the root's
            moved = np.broadcast_to(offsets[i], (n_frames, 3)).copy()
            for j, c in enumerate(ch):
                if c.endswith("position"):
                    moved[:, "XYZ".index(c[0])] = block[:, j]
            translations[i] = moved
    src = SourceMotion(name=_clip_name(path), source=f"BVH {path.name}", fps=1.0 / frame_time, names=names,
                       parents=np.array(parents), rest_positions=rest, local_rotations=local, root_positions=root,
                       joint_translations=translations)
    src.animated = [any(c.endswith("rotation") for c in ch) for ch in channels]
    return src


def _is_number(word):
    try:
        float(word)
        return True
    except ValueError:
        return False


def _channel_at(names, channels, column):
    for n, ch in zip(names, channels):
        if column < len(ch):
            return n, ch[column]
        column -= len(ch)
    return "?", "?"
