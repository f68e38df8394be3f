"""The shape blend G_S(β) and the joints it moves, once per β (sdk/src/shape_blend.c):

    shape_blend:   T + Σ_b β_b G_S[b]               the shaped template the learned blend shapes are added to
    shaped_joints: J_template + Σ_b β_b J_shapedirs[b]   J(β), the rest joints of forward kinematics
"""
import numpy as np


def shape_blend(template_positions, shape_blend_shapes, beta):
    """template_positions [N, 3] T; shape_blend_shapes [B, N, 3] G_S; beta [B] clamped → T + G_S(β) [N, 3]."""
    return np.asarray(template_positions, np.float64) + np.tensordot(
        np.asarray(beta, np.float64), np.asarray(shape_blend_shapes, np.float64), axes=1)


def shaped_joints(joint_template, joint_shapedirs, beta):
    """joint_template [J, 3]; joint_shapedirs [B, J, 3]; beta [B] clamped → J(β) [J, 3]."""
    return np.asarray(joint_template, np.float64) + np.tensordot(
        np.asarray(beta, np.float64), np.asarray(joint_shapedirs, np.float64), axes=1)
