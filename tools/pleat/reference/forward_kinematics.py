"""Forward kinematics of docs/inputs.md ("Skeleton and forward kinematics"), vectorised over leading frame axes.

    G_0 = T(t_root) · Rot(Q_root) · T(J_0) · Rot(R_0)
    G_k = G_parent(k) · T(J_k − J_parent(k)) · Rot(R_k)
    M_k = G_k · T(−J_k)            (skinning matrix: rest space → world)

J(β), the joint locations, come from reference.shape_blend.shaped_joints.
"""
import numpy as np

from pleat.rotations import quat_to_matrix


def forward_kinematics(joint_parents, joint_locations, rotations, root_translation, root_rotation):
    """rotations [..., J, 4] local quaternions (x, y, z, w); root_translation [..., 3]; root_rotation [..., 4].

    Returns (global_rotations [..., J, 3, 3], joint_positions [..., J, 3], skin_matrices [..., J, 3, 4])."""
    parents = np.asarray(joint_parents)
    joints = np.asarray(joint_locations, np.float64)
    local = quat_to_matrix(rotations)
    root = quat_to_matrix(root_rotation)
    t_root = np.asarray(root_translation, np.float64)
    J = len(parents)
    rot = np.empty(local.shape)
    pos = np.empty(local.shape[:-1])
    rot[..., 0, :, :] = root @ local[..., 0, :, :]
    pos[..., 0, :] = t_root + root @ joints[0]
    for k in range(1, J):
        p = parents[k]
        rot[..., k, :, :] = rot[..., p, :, :] @ local[..., k, :, :]
        pos[..., k, :] = pos[..., p, :] + rot[..., p, :, :] @ (joints[k] - joints[p])
    skin = np.concatenate([rot, (pos - np.einsum("...kij,kj->...ki", rot, joints))[..., None]], axis=-1)
    return rot, pos, skin
