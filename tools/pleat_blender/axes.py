"""Pleat ↔ Blender: axes, units, and the armature's pose. numpy only (no bpy), so it is usable and testable outside
Blender.

Pleat is metres, +Y up, the character facing +Z (docs/inputs.md). Blender is Z up with the character facing −Y; a
Blender unit is `scene.unit_settings.scale_length` metres. A Pleat point p is at C · p / unit in Blender, with C the
map (x, y, z) ↦ (x, −z, y) — pleat.garment.meshio's `up="z"`, so OBJ, PC2 and BVH files of a Blender scene read
back through the same code any Z-up file does.

The armature: every bone rests at its joint J_k(β), pointing along Blender +Z with roll 0. A bone so placed has
the rest orientation C, that is, its local axes are Pleat's axes. Blender's pose chain
M_k = M_parent · (Rest_parent⁻¹ · Rest_k) · Basis_k then reproduces Pleat's forward kinematics
G_k = G_parent · [R_k | J_k − J_parent] (pleat.body.BodyModel.forward_kinematics) with Basis_k = R_k for every bone
but the root, unchanged: a bone's pose quaternion is Pleat's local rotation. The root bone (the pelvis) carries the
clip's root motion: rotation P = Q · R_0 and location L = t + Q · J_0 − J_0 (bone axes are Pleat axes; divided by
the unit). Reading a pose back splits P as pleat.motion.bvh_export does (R_0 = identity, Q = P), so the clip from
the armature is the clip `motion.bvh` carries.
"""
import numpy as np

# Pleat → Blender axes (a rotation: +90° about X)
C = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
BONE_LENGTH_M = 0.06          # display only: the pose does not depend on it


def to_blender(points, unit_m=1.0):
    """Pleat points [..., 3] (metres, Y up) → Blender coordinates (Z up, in units of `unit_m` metres)."""
    return np.asarray(points, np.float64) @ C.T / unit_m


def to_pleat(points, unit_m=1.0):
    """Blender coordinates [..., 3] → Pleat points (metres, Y up)."""
    return np.asarray(points, np.float64) @ C * unit_m


def units_label(unit_m):
    """The `units` value of a kit's manifest for a Blender unit of `unit_m` metres (a name where one fits)."""
    from pleat.garment.meshio import UNITS_M
    for name, value in UNITS_M.items():
        if abs(value - unit_m) <= 1e-9 * value:
            return name
    return float(unit_m)


def clip_pose(clip, body, beta=None, unit_m=1.0):
    """A Clip on the body's skeleton → (bone quaternions [T, J, 4] as Blender stores them (w, x, y, z), in the body's
    joint order; root bone location [T, 3] in Blender units)."""
    from pleat.rotations import matrix_to_quat, quat_continuous, quat_to_matrix
    if list(clip.joint_names) != list(body.joint_names):
        raise ValueError("the clip's joints are not the body's")
    R = quat_to_matrix(clip.local_rotations)                     # [T, J, 3, 3]
    Q = quat_to_matrix(clip.root_rotation)                       # [T, 3, 3]
    R = R.copy()
    R[:, 0] = Q @ R[:, 0]
    J0 = body.joints(beta)[0]
    loc = clip.root_translation + np.einsum("tij,j->ti", Q, J0) - J0
    q = matrix_to_quat(R)                                        # (x, y, z, w)
    return quat_continuous(q)[..., [3, 0, 1, 2]], loc / unit_m


def pose_clip(quats_wxyz, root_location, body, fps, beta=None, unit_m=1.0, name="blender"):
    """Inverse of clip_pose: the armature's pose per frame → a Clip with R_0 = identity and Q = the root bone's
    rotation (the split of pleat.motion.bvh_export)."""
    from pleat.motion.clip import Clip
    from pleat.rotations import quat_to_matrix
    q = np.asarray(quats_wxyz, np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    q = q[..., [1, 2, 3, 0]]                                     # (x, y, z, w)
    Q = q[:, 0].copy()
    local = q.copy()
    local[:, 0] = (0.0, 0.0, 0.0, 1.0)
    J0 = body.joints(beta)[0]
    t = np.asarray(root_location, np.float64) * unit_m + J0 - np.einsum("tij,j->ti", quat_to_matrix(Q), J0)
    return Clip(name=name, fps=float(fps), local_rotations=local, root_translation=t, root_rotation=Q,
                source="Blender armature", joint_names=tuple(body.joint_names))


def error_colours(error_m, full_scale_m=0.02):
    """Per-vertex error (metres) → RGBA [N, 4] in linear colour: blue at 0, through green and yellow, red at
    `full_scale_m` and beyond (the range where a cloth error is visible at arm's length)."""
    s = np.clip(np.asarray(error_m, np.float64) / full_scale_m, 0.0, 1.0)
    stops = np.array([[0.05, 0.15, 0.9], [0.1, 0.8, 0.2], [0.95, 0.85, 0.1], [0.9, 0.05, 0.05]])
    x = s * (len(stops) - 1)
    i = np.minimum(x.astype(np.int64), len(stops) - 2)
    a = (x - i)[:, None]
    rgb = stops[i] * (1 - a) + stops[i + 1] * a
    return np.concatenate([rgb, np.ones((len(rgb), 1))], axis=1)
