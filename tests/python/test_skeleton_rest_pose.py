"""The C skeleton API (plAsset_GetRestPose, plInstance_GetRestPose) against the numpy reference on the shipped
t-shirt: parents as the asset's JPAR, positions J(β) as pleat.reference.shape_blend.shaped_joints with the
clamped β, local translations J_k − J_parent, identity local rotations; and forward kinematics of the identity pose
puts every joint at its rest position."""
from pathlib import Path

import numpy as np
import pytest

from pleat.asset import read_asset
from pleat.reference.forward_kinematics import forward_kinematics
from pleat.reference.shape_blend import shaped_joints
from pleat.reference.input_assembly import clamp_beta

ASSET = Path(__file__).resolve().parents[2] / "assets" / "tshirt.pleat"


def _expect_rest_pose(pose, parents, joints):
    np.testing.assert_array_equal(pose["parents"], parents)
    # Both sides form J(β) in double and round once to float; the sums' order differs (C adds β_b · J_shapedirs[b] in
    # b order, numpy uses tensordot), so allow one float rounding step (≤ 6e-8 m at these magnitudes).
    np.testing.assert_allclose(pose["positions"], joints, rtol=0, atol=2e-7)
    origin = np.where(parents[:, None] >= 0, joints[np.maximum(parents, 0)], 0.0)
    np.testing.assert_allclose(pose["local_translations"], joints - origin, rtol=0, atol=2e-7)
    np.testing.assert_array_equal(pose["local_rotations"], np.tile([0, 0, 0, 1], (len(parents), 1)))


@pytest.mark.parametrize("beta", [None, [1.5, -2.0, 0.5], [9.0, -9.0]])
def test_rest_pose_matches_the_reference(beta, c_runtime):
    runtime = c_runtime
    data = ASSET.read_bytes()
    asset = read_asset(data)
    parents = np.asarray(asset["joint_parents"], np.int64)
    with runtime.Context() as ctx:
        c_asset = ctx.load_asset(data)
        _expect_rest_pose(c_asset.rest_pose(), parents,
                          shaped_joints(asset["joint_template"], asset["joint_shapedirs"], clamp_beta(asset, None)[0]))
        inst = ctx.create_instance(c_asset, beta=beta)
        clamped, _ = clamp_beta(asset, beta)  # [9, -9] is outside the asset's range: J(β) uses the clamped β
        joints = shaped_joints(asset["joint_template"], asset["joint_shapedirs"], clamped)
        pose = inst.rest_pose()
        _expect_rest_pose(pose, parents, joints)
        # The identity pose's forward kinematics (reference) places each joint at the rest position the API gives.
        _, positions, _ = forward_kinematics(parents, joints, np.tile([0.0, 0.0, 0.0, 1.0], (len(parents), 1)),
                                             np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]))
        np.testing.assert_allclose(pose["positions"], positions, atol=1e-6)
