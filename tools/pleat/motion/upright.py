"""Which way is up in a source skeleton, and the skeleton turned to Pleat's +Y up.

BVH says nothing about its up axis and most files are +Y up, but not all: an exporter that keeps a Z-up scene's
axes writes a skeleton standing along +Z. Read as +Y up, its legs are found sideways, left and right come out
swapped, and the body lies on its back with no error. So the up axis is read from the rest skeleton: of the six
axis directions, the one along which two low leaves at the same height (the feet) meet well above them (the hips)
and the skeleton reaches as far again above (the head). +Y is kept whenever it reads as a standing skeleton at all.

    up_rotation(parents, rest, tips) -> (R, axis name)    # R turns the file's up to +Y
    uprighted(src, R)                                     # the SourceMotion in the turned frame
"""
from dataclasses import replace

import numpy as np

# R maps the named axis onto +Y (a quarter or half turn about X or Z)
CANDIDATES = {
    "+Y": np.eye(3),
    "+Z": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),
    "-Z": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),
    "+X": np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
    "-X": np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
    "-Y": np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]),
}
FEET_LEVEL = 0.10        # the two leg tips within this share of the skeleton's height of each other
KEEP_Y = 0.8             # +Y stays up unless another axis reads as standing this much better


def standing_score(parents, rest, tips=None):
    """How well the rest skeleton, read +Y up, stands: (top − feet) / height when two low leaves at one level meet
    well above them and the skeleton reaches above that fork; else 0."""
    from pleat.motion.structure import _height, _leg_tips, _Skeleton
    sk = _Skeleton(parents, rest, [True] * len(parents), tips)
    height = _height(sk)
    pair = _leg_tips(sk, height)
    if pair is None:
        return 0.0
    feet = [sk.point(s)[1] for s in pair]
    fork = sk.rest[sk.lca(*pair)][1]
    top = max(sk.point(s)[1] for s in range(len(sk.parents)))
    if abs(feet[0] - feet[1]) > FEET_LEVEL * height or top - fork < 0.2 * height:
        return 0.0
    return float((top - np.mean(feet)) / height)


def up_rotation(parents, rest, tips=None):
    """(R, name): the rotation that turns the skeleton's up axis to +Y, and that axis ("+Y": R is the identity)."""
    rest = np.asarray(rest, np.float64)
    scores = {}
    for name, R in CANDIDATES.items():
        turned_tips = None if not tips else {k: R @ np.asarray(v, np.float64) for k, v in tips.items()}
        scores[name] = standing_score(parents, rest @ R.T, turned_tips)
    best = max(scores, key=scores.get)
    if scores["+Y"] > 0 and scores["+Y"] >= KEEP_Y * scores[best]:
        best = "+Y"
    return CANDIDATES[best], best


def uprighted(src, R, axis):
    """`src` (a SourceMotion) with every position and rotation turned by R: rest and root positions, the joints'
    own translations, bone tips (ASF) and local rotations (R · L · Rᵀ, which keeps the rest pose at identity)."""
    if axis == "+Y":
        return src
    local = np.einsum("ij,tsjk,lk->tsil", R, src.local_rotations, R)
    out = replace(src, rest_positions=np.asarray(src.rest_positions, np.float64) @ R.T,
                  root_positions=np.asarray(src.root_positions, np.float64) @ R.T, local_rotations=local,
                  joint_translations={k: np.asarray(v, np.float64) @ R.T for k, v in src.joint_translations.items()},
                  source=f"{src.source}, turned from {axis} up to +Y")
    for key in ("animated", "dropped_above_hips"):
        if hasattr(src, key):
            setattr(out, key, getattr(src, key))
    if hasattr(src, "tips"):
        out.tips = {k: R @ np.asarray(v, np.float64) for k, v in src.tips.items()}
    return out
