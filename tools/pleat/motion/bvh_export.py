"""A clip on the Pleat body as BVH, and back without retargeting (docs/training.md, "Your own simulation").

`write_bvh` writes the body's own skeleton: joints named as the body's (pelvis, left_hip, ...), in a depth-first
hierarchy, rest offsets J_k(0) − J_parent(k)(0) (the rest A-pose of docs/body.md is the BVH's zero pose), the
pelvis with six channels (world position of the pelvis joint, then its world rotation P = Q_root · R_0), every
other joint three (its local rotation R_k), Euler angles in ZXY order, degrees, 17 significant digits.

`read_pleat_bvh` recognises such a file (the body's joint names, rest offsets proportional to J(0)) and rebuilds
the clip directly: R_0 = identity, Q_root = P, t_root = p_0 − Q_root · J_0(0). That is the same motion exactly
(forward kinematics, X_c and skinning agree to rounding), with no retargeting, grounding or rescaling of the root
path in between — which is what a point cache simulated on that motion needs. Any other BVH goes through
`pleat.motion.load_clip` (retargeted and grounded).
"""
from pathlib import Path

import numpy as np

from pleat.motion.clip import Clip
from pleat.motion.readers import MotionFileError, check_source, read_bvh
from pleat.rotations import matrix_to_quat, quat_to_matrix

EULER_ORDER = "ZXY"
UNITS_M = {"m": 1.0, "cm": 0.01}
REST_TOLERANCE = 1e-4       # relative: offsets proportional to J(0) within this → the Pleat skeleton


def matrix_to_euler_zxy(R):
    """Angles (z, x, y) in radians with R = Rz(z) · Rx(x) · Ry(y) (intrinsic Z, X, Y: BVH's 'Zrotation Xrotation
    Yrotation'); R [..., 3, 3]."""
    R = np.asarray(R, np.float64)
    x = np.arcsin(np.clip(R[..., 2, 1], -1.0, 1.0))
    z = np.arctan2(-R[..., 0, 1], R[..., 1, 1])
    y = np.arctan2(-R[..., 2, 0], R[..., 2, 2])
    # at x = ±90° (gimbal lock) z and y share one angle: put it all into z
    lock = np.abs(R[..., 2, 1]) > 1.0 - 1e-12
    if np.any(lock):
        z = np.where(lock, np.arctan2(R[..., 1, 0], R[..., 0, 0]), z)
        y = np.where(lock, 0.0, y)
    return np.stack([z, x, y], axis=-1)


def _depth_first(parents):
    children = {}
    for k, p in enumerate(parents):
        children.setdefault(int(p), []).append(k)
    order, stack = [], [0]
    while stack:
        k = stack.pop()
        order.append(k)
        stack.extend(reversed(children.get(k, [])))
    return order, children


def write_bvh(path, clip, body, units="cm"):
    """The clip (on `body`'s skeleton, its joint order) as a BVH file in `units` (cm or m), written atomically."""
    from pleat.fileio import write_text
    if list(clip.joint_names) != list(body.joint_names):
        raise ValueError("the clip's joints are not the body's")
    s = 1.0 / UNITS_M[units]
    J = body.joints()                                            # [K, 3] rest joints at β = 0
    parents = np.asarray(body.parents)
    names = list(body.joint_names)
    order, children = _depth_first(parents)
    lines = ["HIERARCHY"]

    def fmt(values):
        return " ".join(f"{float(v):.17g}" for v in values)

    depth = 0
    stack = []                                                   # (joint, open children left)
    for k in order:
        while stack and parents[k] != stack[-1]:
            depth -= 1
            lines.append("\t" * depth + "}")
            stack.pop()
        ind = "\t" * depth
        if k == 0:
            lines += [f"ROOT {names[0]}", "{", f"\tOFFSET {fmt(J[0] * s)}",
                      "\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"]
        else:
            lines += [f"{ind}JOINT {names[k]}", f"{ind}{{", f"{ind}\tOFFSET {fmt((J[k] - J[parents[k]]) * s)}",
                      f"{ind}\tCHANNELS 3 Zrotation Xrotation Yrotation"]
        depth += 1
        stack.append(k)
        if not children.get(k):
            bone = J[k] - J[parents[k]] if k else np.array([0.0, 0.1, 0.0])
            tip = bone / max(np.linalg.norm(bone), 1e-9) * 0.05     # a 5 cm end site along the last bone
            ind2 = "\t" * depth
            lines += [f"{ind2}End Site", f"{ind2}{{", f"{ind2}\tOFFSET {fmt(tip * s)}", f"{ind2}}}"]
    while stack:
        depth -= 1
        lines.append("\t" * depth + "}")
        stack.pop()
    R = quat_to_matrix(clip.local_rotations)                    # [T, K, 3, 3]
    Q = quat_to_matrix(clip.root_rotation)                      # [T, 3, 3]
    P = Q @ R[:, 0]
    p0 = clip.root_translation + np.einsum("tij,j->ti", Q, J[0])
    ang = np.rad2deg(matrix_to_euler_zxy(R))                    # [T, K, 3]
    ang[:, 0] = np.rad2deg(matrix_to_euler_zxy(P))
    lines += ["MOTION", f"Frames: {clip.num_frames}", f"Frame Time: {1.0 / clip.fps:.17g}"]
    for t in range(clip.num_frames):
        row = [fmt(p0[t] * s)] + [fmt(ang[t, k]) for k in order]
        lines.append(" ".join(row))
    write_text(path, "\n".join(lines) + "\n")
    return Path(path)


def pleat_skeleton_scale(src, body):
    """Metres per BVH unit when `src` (a SourceMotion from read_bvh) is the Pleat body's own skeleton (its joint
    names and rest offsets proportional to J(0)); None when the names or the rest pose differ (the body's names on a
    T-pose, say: that file is retargeted like any other)."""
    names = [n for n in src.names if not n.endswith("_end")]
    if sorted(names) != sorted(body.joint_names):
        return None
    idx = [src.names.index(n) for n in body.joint_names]
    rest = np.asarray(src.rest_positions, np.float64)[idx]
    J = body.joints()
    a, b = rest - rest[0], J - J[0]
    scale = float(np.sum(np.linalg.norm(b, axis=1)) / max(np.sum(np.linalg.norm(a, axis=1)), 1e-12))
    err = float(np.abs(a * scale - b).max())
    extent = float(np.abs(b).max())
    if err > REST_TOLERANCE * extent:
        return None
    return scale


def clip_from_pleat_skeleton(src, body, scale):
    """The Clip of a BVH of the Pleat skeleton (see the module doc), exactly."""
    idx = [src.names.index(n) for n in body.joint_names]
    local = np.asarray(src.local_rotations, np.float64)[:, idx]  # [T, K, 3, 3]
    Q = local[:, 0].copy()
    R = local.copy()
    R[:, 0] = np.eye(3)
    J0 = body.joints()[0]
    trans = np.asarray(src.root_positions, np.float64) * scale - np.einsum("tij,j->ti", Q, J0)
    return Clip(name=src.name, fps=float(src.fps), local_rotations=matrix_to_quat(R), root_translation=trans,
                root_rotation=matrix_to_quat(Q), source=src.source + " (Pleat skeleton, not retargeted)",
                joint_names=tuple(body.joint_names))


def read_pleat_bvh(path, body):
    """A BVH of the Pleat skeleton → its Clip exactly; None for any other BVH (use load_clip for those)."""
    path = Path(path)
    try:
        src = read_bvh(path)
    except (MotionFileError, OSError):
        raise
    except (ValueError, IndexError, KeyError, TypeError, OverflowError) as exc:
        raise MotionFileError(path, f"malformed BVH file ({type(exc).__name__}: {exc})") from None
    check_source(src, path)
    scale = pleat_skeleton_scale(src, body)
    if scale is None:
        return None
    return clip_from_pleat_skeleton(src, body, scale)
