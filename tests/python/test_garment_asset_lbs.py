"""pleat.garment_asset: the weights dict it assembles, and the LBS-only model behaving as plain skinning."""
import io
import json

import numpy as np
import pytest

from pleat.asset import read_asset, write_asset
from pleat.garment_asset import LBS_ONLY_MODEL, input_joint_indices, weights_from_garment
from pleat.reference.instance import Instance
from pleat.rotations import axis_angle_to_matrix, matrix_to_quat, quat_to_matrix

SMPL_NAMES = ["pelvis", "left_hip", "right_hip", "spine1", "left_knee", "right_knee", "spine2", "left_ankle",
              "right_ankle", "spine3", "left_foot", "right_foot", "neck", "left_collar", "right_collar", "head",
              "left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist",
              "left_hand", "right_hand"]
SMPL_PARENTS = [-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19, 20, 21]


def make_body(rng, vertex_count=80, beta_count=10):
    v_template = rng.normal(scale=0.3, size=(vertex_count, 3)) + [0.0, 1.0, 0.0]
    regressor = rng.uniform(size=(24, vertex_count)) * (rng.uniform(size=(24, vertex_count)) < 0.1)
    regressor[:, 0] += 1e-3
    regressor /= regressor.sum(axis=1, keepdims=True)
    return {"v_template": v_template, "shapedirs": rng.normal(scale=0.01, size=(vertex_count, 3, beta_count)),
            "J_regressor": regressor, "parents": np.array(SMPL_PARENTS), "joint_names": np.array(SMPL_NAMES)}


def make_garment(rng, beta_count=10, side=6):
    xs, ys = np.meshgrid(np.linspace(-0.2, 0.2, side), np.linspace(0.9, 1.4, side))
    template = np.stack([xs.ravel(), ys.ravel(), np.full(side * side, 0.15)], axis=1)
    faces = []
    for r in range(side - 1):
        for c in range(side - 1):
            a = r * side + c
            faces += [[a, a + 1, a + side + 1], [a, a + side + 1, a + side]]
    n = template.shape[0]
    skin_indices = np.stack([rng.choice(24, size=4, replace=False) for _ in range(n)])
    skin_weights = rng.uniform(0.1, 1.0, size=(n, 4))
    skin_weights /= skin_weights.sum(axis=1, keepdims=True)
    return {"name": "test_sheet", "template": template, "faces": np.array(faces), "skin_indices": skin_indices,
            "skin_weights": skin_weights, "shape_blend": rng.normal(scale=0.01, size=(beta_count, n, 3)),
            "pinned": np.array([0, 1])}


def test_input_joints_are_all_but_pelvis_wrists_and_hands():
    # SMPL order: pelvis is 0, wrists 20 and 21, hands 22 and 23 — so the inputs are joints 1..19.
    assert input_joint_indices(SMPL_NAMES).tolist() == list(range(1, 20))
    shuffled = SMPL_NAMES[::-1]
    expected = [k for k, name in enumerate(shuffled) if "wrist" not in name and "hand" not in name and name != "pelvis"]
    assert input_joint_indices(shuffled).tolist() == expected


def test_skeleton_reproduces_the_body_joint_regressor_for_any_beta():
    rng = np.random.default_rng(1)
    body, garment = make_body(rng), make_garment(rng)
    w = weights_from_garment(garment, body)
    beta = rng.uniform(-3, 3, size=10)
    shaped_vertices = body["v_template"] + body["shapedirs"] @ beta
    expected_joints = body["J_regressor"] @ shaped_vertices
    joints = w["joint_template"] + np.einsum("b,bjc->jc", beta, w["joint_shapedirs"])
    np.testing.assert_allclose(joints, expected_joints, atol=1e-5)
    assert w["joint_parents"].tolist() == SMPL_PARENTS
    assert list(w["joint_names"]) == SMPL_NAMES


def test_lbs_only_asset_is_the_smallest_zero_network_and_says_so():
    rng = np.random.default_rng(2)
    body, garment = make_body(rng), make_garment(rng)
    asset = read_asset(write_asset(io.BytesIO(), weights_from_garment(garment, body)))
    assert asset["z_mean"].shape == (1,) and asset["blend_shapes"].shape[0] == 1
    # I = L + 8 + 3·(6·19 + 6) + 9·19 + 10 + 4 = 1 + 553 (docs/inputs.md)
    assert asset["x_mean"].shape == (554,) and asset["lp.0.weight"].shape == (1, 554)
    assert not np.any(asset["lp.0.weight"]) and not np.any(asset["dec.0.weight"]) and not np.any(asset["blend_shapes"])
    assert asset["z_min"][0] == 0.0 and asset["z_max"][0] == 0.0
    assert json.loads(asset["metadata_json"])["model"] == LBS_ONLY_MODEL
    np.testing.assert_allclose(asset["beta_range"], [-4, 4])
    np.testing.assert_allclose(asset["dt_range_s"], [1 / 240, 1 / 15], rtol=1e-6)
    assert np.all(asset["material_min"] <= asset["material_default"])
    assert np.all(asset["material_default"] <= asset["material_max"])


def _forward_kinematics(parents, joints, rotations, root_translation, root_rotation):
    """docs/inputs.md, written out independently: G_0 = T(t)·Rot(Q)·T(J_0)·Rot(R_0), G_k = G_p·T(J_k − J_p)·Rot(R_k)."""
    J = len(parents)
    G = np.zeros((J, 4, 4))
    local = quat_to_matrix(rotations)
    root = np.eye(4)
    root[:3, :3], root[:3, 3] = quat_to_matrix(root_rotation), root_translation
    for k in range(J):
        t = np.eye(4)
        t[:3, :3] = local[k]
        t[:3, 3] = joints[k] - (joints[parents[k]] if k > 0 else 0.0)
        G[k] = (root if k == 0 else G[parents[k]]) @ t
    M = G.copy()
    M[:, :3, 3] -= np.einsum("kij,kj->ki", G[:, :3, :3], joints)
    return M


def test_lbs_only_asset_dresses_the_garment_by_plain_skinning():
    rng = np.random.default_rng(3)
    body, garment = make_body(rng), make_garment(rng)
    asset = read_asset(write_asset(io.BytesIO(), weights_from_garment(garment, body)))
    beta = rng.uniform(-2, 2, size=10)
    instance = Instance(asset, beta=beta)
    joints = body["J_regressor"] @ (body["v_template"] + body["shapedirs"] @ beta)
    shaped = garment["template"] + np.einsum("b,bnc->nc", beta, garment["shape_blend"])
    for frame in range(4):
        axis_angles = rng.normal(scale=0.4, size=(24, 3))
        rotations = matrix_to_quat(axis_angle_to_matrix(axis_angles))
        root_t = np.array([0.1 * frame, 0.02, 0.3 * frame])
        root_q = np.array([0.0, np.sin(0.2 * frame), 0.0, np.cos(0.2 * frame)])
        positions, normals = instance.step(rotations, root_t, root_q, 1 / 30)
        M = _forward_kinematics(SMPL_PARENTS, joints, rotations, root_t, root_q)
        expected = np.einsum("nk,nkij,nj->ni", garment["skin_weights"], M[garment["skin_indices"]][..., :3, :],
                             np.concatenate([shaped, np.ones((len(shaped), 1))], axis=1))
        np.testing.assert_allclose(positions, expected, atol=1e-4)  # float32-stored weights and template
        np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-5)


def test_shape_blend_with_wrong_beta_count_is_rejected():
    rng = np.random.default_rng(4)
    body, garment = make_body(rng), make_garment(rng, beta_count=8)
    with pytest.raises(ValueError):
        weights_from_garment(garment, body)
