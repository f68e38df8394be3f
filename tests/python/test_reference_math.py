"""pleat.reference pieces against independent computations (hand-worked cases, docs/inputs.md formulas)."""
import numpy as np
import pytest

from pleat import asset as pa
from pleat.reference import (Instance, StepError, assemble_inputs, forward_kinematics, mlp, normals, skinning)
from pleat.reference.golden import random_motion, random_weights
from pleat.reference.normals import face_normals, normals_gather, normals_scatter
from pleat.rotations import axis_angle_to_matrix, axis_angle_to_quat, matrix_to_6d, matrix_to_quat, \
    quat_to_axis_angle, rotation_between, sixd_to_matrix


def quat(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.concatenate([axis * np.sin(angle / 2), [np.cos(angle / 2)]])


IDENTITY = np.array([0.0, 0.0, 0.0, 1.0])


@pytest.fixture(scope="module")
def asset():
    w = random_weights(vertices=120, latent=6, blend=4, lp_hidden=(16,), dec_hidden=(8,), seed=5)
    return pa.read_asset(pa.write_asset(None, w))


def test_skinning_of_a_rigid_transform_is_that_transform():
    rng = np.random.default_rng(0)
    x = rng.standard_normal((50, 3))
    R = axis_angle_to_matrix(np.array([0.3, -1.1, 0.4]))
    t = np.array([1.0, 2.0, -0.5])
    m = np.broadcast_to(np.concatenate([R, t[:, None]], 1), (5, 3, 4))
    idx = rng.integers(0, 5, (50, 3))
    w = rng.random((50, 3))
    w /= w.sum(1, keepdims=True)
    np.testing.assert_allclose(skinning(x, idx, w, m), x @ R.T + t, atol=1e-12)


def test_skinning_blends_two_translations_linearly():
    m = np.zeros((2, 3, 4))
    m[:, :, :3] = np.eye(3)
    m[0, :, 3], m[1, :, 3] = [1, 0, 0], [0, 0, 2]
    out = skinning(np.zeros((1, 3)), [[0, 1]], [[0.25, 0.75]], m)
    np.testing.assert_allclose(out, [[0.25, 0.0, 1.5]])


def test_normals_of_a_flat_quad_point_up():
    x = np.array([[0, 0, 0], [0, 0, 1], [1, 0, 1], [1, 0, 0]], float)   # CCW seen from +Y
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    off, adj = pa.normal_adjacency(faces, 4)
    np.testing.assert_allclose(normals(x, faces, off, adj), np.tile([0, 1, 0], (4, 1)), atol=1e-15)


def test_normals_of_an_octahedron_point_outward_and_are_area_weighted():
    v = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    faces = []
    for a, b in [(0, 4), (4, 1), (1, 5), (5, 0)]:                        # ring around Y, CCW from outside
        faces += [[a, b, 2] if np.cross(v[b] - v[a], v[2] - v[a]) @ (v[a] + v[b] + v[2]) > 0 else [b, a, 2]]
        faces += [[b, a, 3] if np.cross(v[a] - v[b], v[3] - v[b]) @ (v[a] + v[b] + v[3]) > 0 else [a, b, 3]]
    faces = np.array(faces)
    off, adj = pa.normal_adjacency(faces, 6)
    np.testing.assert_allclose(normals(v, faces, off, adj), v, atol=1e-12)
    # stretching +X moves the normal of the side vertices towards the bigger faces: area weighting
    v2 = v * [3, 1, 1]
    n2 = normals(v2, faces, off, adj)
    face_n = np.cross(v2[faces[:, 1]] - v2[faces[:, 0]], v2[faces[:, 2]] - v2[faces[:, 0]])
    expected = face_n[[f for f in range(8) if 2 in faces[f]]].sum(0)
    np.testing.assert_allclose(n2[2], expected / np.linalg.norm(expected), atol=1e-12)


def test_normals_scatter_gives_the_gather_normals_and_a_lone_degenerate_vertex_gets_zero():
    """normals_scatter (the C path on one thread) and face_normals + normals_gather are one algorithm's two
    traversals: the same per-vertex sums. A vertex whose faces have no area gets (0, 0, 0), not NaN."""
    rng = np.random.default_rng(3)
    w = random_weights(vertices=80, latent=4, blend=2, lp_hidden=(8,), dec_hidden=(4,), seed=2)
    x = np.asarray(w["template"], np.float64) + 0.01 * rng.standard_normal(np.shape(w["template"]))
    faces = np.asarray(w["faces"])
    off, adj = pa.normal_adjacency(faces, len(x))
    gathered = normals_gather(face_normals(x, faces), off, adj)
    np.testing.assert_allclose(normals_scatter(x, faces), gathered, atol=1e-15)
    np.testing.assert_array_equal(normals(x, faces, off, adj), gathered)
    line = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0]], float)
    tri = np.array([[0, 1, 2]])
    for n in (normals_scatter(line, tri), normals(line, tri, *pa.normal_adjacency(tri, 3))):
        np.testing.assert_array_equal(n, np.zeros((3, 3)))


def test_forward_kinematics_of_a_two_joint_chain_by_hand():
    # joint 0 at (0, 1, 0), joint 1 at (0, 2, 0). R_0 = 90° about Z, R_1 = 90° about X,
    # root: translate (1, 0, 0), rotate 90° about Y.
    joints = np.array([[0, 1, 0], [0, 2, 0]], float)
    rz, rx, ry = quat([0, 0, 1], np.pi / 2), quat([1, 0, 0], np.pi / 2), quat([0, 1, 0], np.pi / 2)
    rot, pos, skin = forward_kinematics([-1, 0], joints, np.stack([rz, rx]), [1, 0, 0], ry)
    # p_0 = t + Ry·J_0 = (1, 1, 0); the bone (0, 1, 0) → Rz → (−1, 0, 0) → Ry → (0, 0, 1)
    np.testing.assert_allclose(pos, [[1, 1, 0], [1, 1, 1]], atol=1e-12)
    Ry = np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]])
    Rz = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    Rx = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])
    np.testing.assert_allclose(rot[1], Ry @ Rz @ Rx, atol=1e-12)
    # skinning matrix maps the rest joint location onto the posed one, and rest point J_1 + (0, 0, 1) follows
    np.testing.assert_allclose(skin[1] @ [0, 2, 0, 1], [1, 1, 1], atol=1e-12)
    np.testing.assert_allclose(skin[1] @ [0, 2, 1, 1], [1, 1, 1] + Ry @ Rz @ Rx @ [0, 0, 1], atol=1e-12)


def test_sixd_round_trip_and_layout():
    R = axis_angle_to_matrix(np.random.default_rng(1).standard_normal((20, 3)))
    d6 = matrix_to_6d(R)
    np.testing.assert_array_equal(d6[:, :3], R[:, :, 0])
    np.testing.assert_array_equal(d6[:, 3:], R[:, :, 1])
    np.testing.assert_allclose(sixd_to_matrix(d6), R, atol=1e-12)


def test_axis_angle_round_trip_on_both_hemispheres():
    """quat_to_axis_angle inverts axis_angle_to_quat (tiny angles included); −q, the same rotation, gives the vector
    of the other way round: angle 2π − θ about the opposite axis."""
    rng = np.random.default_rng(2)
    aa = rng.standard_normal((50, 3))
    aa *= (rng.uniform(0.0, np.pi, 50) / np.linalg.norm(aa, axis=1))[:, None]
    aa[0] = [1e-14, 0.0, 0.0]
    aa[1] = 0.0
    q = axis_angle_to_quat(aa)
    np.testing.assert_allclose(quat_to_axis_angle(q), aa, atol=1e-12)
    other = quat_to_axis_angle(-q[2:])
    angle = np.linalg.norm(aa[2:], axis=1)
    np.testing.assert_allclose(np.linalg.norm(other, axis=1), 2 * np.pi - angle, atol=1e-12)
    np.testing.assert_allclose(axis_angle_to_matrix(other), axis_angle_to_matrix(aa[2:]), atol=1e-12)


def test_rotation_between_takes_a_onto_b_by_the_smallest_rotation():
    rng = np.random.default_rng(4)
    a, b = rng.standard_normal((50, 3)), rng.standard_normal((50, 3))
    a[0], b[0] = [0.0, 2.0, 0.0], [0.0, -1.0, 0.0]                   # opposite: a half turn
    a[1], b[1] = [1.0, 0.0, 0.0], [3.0, 0.0, 0.0]                    # the same direction: identity
    R = rotation_between(a, b)
    unit = lambda v: v / np.linalg.norm(v, axis=-1, keepdims=True)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", R, unit(a)), unit(b), atol=1e-12)
    # (the closed form loses digits as the directions approach opposite: 1 / (1 + a·b))
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-10)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-10)
    np.testing.assert_allclose(R[1], np.eye(3), atol=1e-15)
    # smallest: the rotation angle is the angle between the directions (π for the opposite pair)
    angle = np.arccos(np.clip((np.trace(R, axis1=-2, axis2=-1) - 1) / 2, -1, 1))
    np.testing.assert_allclose(angle, np.arccos(np.clip(np.sum(unit(a) * unit(b), -1), -1, 1)), atol=1e-6)
    np.testing.assert_allclose(rotation_between(a[5], b[5]), R[5], atol=1e-15)  # one pair, no batch axis


def test_mlp_relu_and_silu_by_hand():
    w0, b0 = np.array([[1.0, -1.0], [2.0, 0.0]]), np.array([0.0, -3.0])
    w1, b1 = np.array([[1.0, 1.0]]), np.array([0.5])
    x = np.array([1.0, 2.0])                       # hidden pre-activation (−1, −1)
    assert mlp(x, [w0, w1], [b0, b1], "relu") == pytest.approx([0.5])
    silu = lambda v: v / (1 + np.exp(-v))
    assert mlp(x, [w0, w1], [b0, b1], "silu") == pytest.approx([2 * silu(-1.0) + 0.5])


def clip(T, J=24, seed=0):
    return random_motion(T, J, seed)


def test_input_count_matches_the_formula(asset):
    x = assemble_inputs(asset, *clip(5))
    L, Jin, B = 6, 19, 10
    assert x.shape == (5, L + 8 + 3 * (6 * Jin + 6) + 9 * Jin + B + 4) == (5, L + 553)
    # the layout's blocks, back to back in the documented order (docs/inputs.md "X_c layout")
    layout = pa.input_layout(L, Jin, B)
    assert list(layout) == ["latent", "root_velocities", "rotations", "positions", "beta", "material"]
    # 6 + 8 = 14; 3·(6·19 + 6) = 360; 9·19 = 171; then β (10) and the material (4): 559 = L + 553
    assert [(s.start, s.stop) for s in layout.values()] == [(0, 6), (6, 14), (14, 374), (374, 545), (545, 555),
                                                            (555, 559)]
    assert pa.input_count(L, Jin, B) == x.shape[1]


def test_first_frame_velocities_are_zero(asset):
    x = assemble_inputs(asset, *clip(4))
    L = 6
    np.testing.assert_array_equal(x[0, L:L + 8], 0.0)
    np.testing.assert_array_equal(x[1, L + 4:L + 8], 0.0)      # v_{t−1} of frame 1 uses the copied frame 0
    assert np.all(x[1, L:L + 3] != 0)
    # the three rotation/position frames of frame 0 are copies
    r = 6 * 19 + 6
    np.testing.assert_array_equal(x[0, L + 8:L + 8 + r], x[0, L + 8 + r:L + 8 + 2 * r])


def test_constant_root_velocity_and_yaw_rate(asset):
    T, J, L = 6, 24, 6
    yaw0, rate, dt = 0.4, 0.9, 1 / 30
    v_world = np.array([0.7, 0.1, -0.3])
    t = np.arange(T) * dt
    rotations = np.tile(IDENTITY, (T, J, 1))
    root_q = np.stack([quat([0, 1, 0], yaw0 + rate * s) for s in t])
    root_t = t[:, None] * v_world
    x = assemble_inputs(asset, rotations, root_t, root_q, np.full(T, dt))
    # pelvis p_0 = t_root + Q_root·J_0, so it also moves as J_0 turns with the yaw; compute it independently
    j0 = asset["joint_template"][0].astype(float)
    p0 = root_t + np.stack([axis_angle_to_matrix([0, yaw0 + rate * s, 0]) @ j0 for s in t])
    for f in (2, 3, 5):
        yaw_inv = axis_angle_to_matrix([0, -(yaw0 + rate * t[f]), 0])
        np.testing.assert_allclose(x[f, L:L + 3], yaw_inv @ (p0[f] - p0[f - 1]) / dt, atol=1e-9)
        np.testing.assert_allclose(x[f, L + 4:L + 7], yaw_inv @ (p0[f - 1] - p0[f - 2]) / dt, atol=1e-9)
        np.testing.assert_allclose([x[f, L + 3], x[f, L + 7]], [rate, rate], atol=1e-9)


def test_rest_pose_blocks(asset):
    """Identity pose with a yaw-only root: every 6D is identity, positions are yaw⁻¹-free rest offsets."""
    T, J, L, Jin, B = 2, 24, 6, 19, 10
    beta = np.linspace(-1, 1, B)
    root_q = np.tile(quat([0, 1, 0], 2.5), (T, 1))
    x = assemble_inputs(asset, np.tile(IDENTITY, (T, J, 1)), np.zeros((T, 3)), root_q, np.full(T, 0.02), beta=beta,
                        material=asset["material_max"])
    rot = x[1, L + 8:L + 8 + 3 * (6 * Jin + 6)]
    np.testing.assert_allclose(rot, np.tile([1, 0, 0, 0, 1, 0], 3 * (Jin + 1)), atol=1e-12)
    joints = asset["joint_template"] + np.tensordot(beta, asset["joint_shapedirs"].astype(float), 1)
    rel = (joints[asset["input_joints"]] - joints[0]).reshape(-1)
    pos = x[1, L + 8 + 3 * (6 * Jin + 6):L + 8 + 3 * (6 * Jin + 6) + 9 * Jin]
    np.testing.assert_allclose(pos, np.tile(rel, 3), atol=1e-6)
    np.testing.assert_allclose(x[1, -B - 4:-4], beta)
    np.testing.assert_allclose(x[1, -4:], 1.0)


def test_vertical_forward_axis_keeps_the_previous_yaw(asset):
    T, J, L, Jin = 2, 24, 6, 19
    root_q = np.stack([quat([0, 1, 0], 0.7), quat([0, 1, 0], 0.7)])
    rotations = np.tile(IDENTITY, (T, J, 1))
    rotations[1, 0] = quat([1, 0, 0], -np.pi / 2)     # pelvis pitched so its +Z points straight up
    x = assemble_inputs(asset, rotations, np.zeros((T, 3)), root_q, np.full(T, 0.03))
    assert x[1, L + 3] == pytest.approx(0.0, abs=1e-9)      # yaw unchanged → ω = 0
    tilt = x[1, L + 8 + 6 * Jin:L + 8 + 6 * Jin + 6]      # yaw⁻¹·P = the pitch alone
    np.testing.assert_allclose(tilt, matrix_to_6d(axis_angle_to_matrix([-np.pi / 2, 0, 0])), atol=1e-9)


def run_clip(inst, motion):
    out = []
    for k in range(len(motion[3])):
        out.append(inst.step(motion[0][k], motion[1][k], motion[2][k], motion[3][k]))
    return out


def test_instance_builds_the_same_inputs_as_assemble_inputs(asset):
    motion = clip(8, seed=3)
    inst = Instance(asset, beta=np.full(10, 0.5))
    latents, xs = [], []
    for k in range(8):
        latents.append(inst.latent.copy())
        inst.step(motion[0][k], motion[1][k], motion[2][k], motion[3][k])
        xs.append(inst.x_c)
    x = assemble_inputs(asset, *motion, beta=np.full(10, 0.5), latents=np.array(latents))
    np.testing.assert_allclose(np.array(xs), x, atol=1e-12)


def test_instance_output_is_skinned_blend_shapes(asset):
    """Independent recomposition of one step from X_c: normalise, LP, clamp, decoder, blend, skin."""
    motion = clip(1, seed=4)
    inst = Instance(asset, body_contact=False)
    pos, nrm = inst.step(motion[0][0], motion[1][0], motion[2][0], motion[3][0])
    f = lambda k: np.asarray(asset[k], float)
    h = (inst.x_c - f("x_mean")) / f("x_std")
    h = np.maximum(h @ f("lp.0.weight").T + f("lp.0.bias"), 0) @ f("lp.1.weight").T + f("lp.1.bias")
    z = np.clip(h * f("z_std") + f("z_mean"), f("z_min"), f("z_max"))
    np.testing.assert_allclose(inst.latent, z, atol=1e-12)
    w = np.maximum(z @ f("dec.0.weight").T + f("dec.0.bias"), 0) @ f("dec.1.weight").T + f("dec.1.bias")
    rest = f("template") + np.einsum("d,dnc->nc", w, f("blend_shapes"))
    m = inst.skin_matrices
    expected = np.einsum("nk,nkij,nj->ni", f("skin_weights"), m[asset["skin_indices"].astype(int)][..., :3], rest) + \
        np.einsum("nk,nki->ni", f("skin_weights"), m[asset["skin_indices"].astype(int)][..., 3])
    np.testing.assert_allclose(pos, expected, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(nrm, axis=1), 1.0, atol=1e-12)


def test_clamps_and_rejections_leave_the_instance_unchanged(asset):
    motion = clip(4, seed=6)
    a, b = Instance(asset), Instance(asset)
    for inst in (a, b):
        inst.step(motion[0][0], motion[1][0], motion[2][0], motion[3][0])
    bad_q = motion[0][1].copy()
    bad_q[3] *= 1.01
    nan_q = motion[0][1].copy()
    nan_q[0, 0] = np.nan
    for args, code in [((bad_q, motion[1][1], motion[2][1], 0.03), "INVALID_QUATERNION"),
                       ((nan_q, motion[1][1], motion[2][1], 0.03), "NON_FINITE_INPUT"),
                       ((motion[0][1], motion[1][1], motion[2][1], 0.0), "INVALID_DT"),
                       ((motion[0][1], motion[1][1], motion[2][1], 1.5), "INVALID_DT"),
                       ((motion[0][1], motion[1][1], motion[2][1], np.inf), "NON_FINITE_INPUT"),
                       ((motion[0][1][:5], motion[1][1], motion[2][1], 0.03), "JOINT_COUNT_MISMATCH")]:
        with pytest.raises(StepError) as e:
            a.step(*args)
        assert e.value.code == code
    pa_, na_ = a.step(motion[0][1], motion[1][1], motion[2][1], motion[3][1])
    pb_, nb_ = b.step(motion[0][1], motion[1][1], motion[2][1], motion[3][1])
    np.testing.assert_array_equal(pa_, pb_)
    # dt above dt_max is clamped (result "clamped") and gives the same output as dt_max itself
    a.step(motion[0][2], motion[1][2], motion[2][2], 0.5)
    assert a.last_result == "clamped"
    b.step(motion[0][2], motion[1][2], motion[2][2], float(asset["dt_range_s"][1]))
    assert b.last_result == "ok"
    np.testing.assert_array_equal(a.latent, b.latent)
    assert a.set_shape(np.full(10, 9.0)) is True and np.all(a.beta == 4.0)
    assert a.set_material(asset["material_max"] * 2) is True
    np.testing.assert_allclose(a.material_normalised, 1.0)


def test_non_finite_inside_a_step_resets_and_recomputes(asset):
    motion = clip(3, seed=7)
    poisoned = dict(asset)
    poisoned["x_std"] = np.asarray(asset["x_std"], np.float64).copy()
    poisoned["x_mean"] = np.asarray(asset["x_mean"], np.float64).copy()
    # latent input 0: (Z_t[0] − 0) / 1e-320 is 0 from a reset (Z_0 = 0) and overflows once Z_t[0] ≠ 0
    poisoned["x_std"][0], poisoned["x_mean"][0] = 1e-320, 0.0
    inst = Instance(poisoned)
    inst.step(motion[0][0], motion[1][0], motion[2][0], motion[3][0])
    assert inst.last_result == "ok" and inst.latent[0] != 0
    pos, _ = inst.step(motion[0][1], motion[1][1], motion[2][1], motion[3][1])
    assert inst.last_result == "numeric_reset"
    fresh = Instance(poisoned)
    expected, _ = fresh.step(motion[0][1], motion[1][1], motion[2][1], motion[3][1])
    np.testing.assert_array_equal(pos, expected)


def test_latent_is_clamped_to_the_asset_range(asset):
    narrow = dict(asset)
    narrow["z_min"] = np.asarray(asset["z_mean"]) - 0.01
    narrow["z_max"] = np.asarray(asset["z_mean"]) + 0.01
    inst = Instance(narrow)
    for k, args in enumerate(zip(*clip(5, seed=8))):
        inst.step(*args)
        assert np.all(inst.latent >= narrow["z_min"]) and np.all(inst.latent <= narrow["z_max"])


def test_random_weights_recurrence_is_contractive():
    """The golden generator promises bounded rollouts: ‖Z_t+1(a) − Z_t+1(b)‖ < ‖a − b‖ for two latents."""
    w = random_weights(vertices=60, latent=16, blend=4, lp_hidden=(32, 32), dec_hidden=(8,), seed=9)
    asset = pa.read_asset(pa.write_asset(None, w))
    motion = clip(3, seed=9)
    a, b = Instance(asset), Instance(asset)
    for inst in (a, b):
        inst.step(*(m[0] for m in motion))
    b.latent = a.latent + np.random.default_rng(0).normal(0, 0.3, 16)
    gap = np.linalg.norm(a.latent - b.latent)
    for inst in (a, b):
        inst.step(*(m[1] for m in motion))
    assert np.linalg.norm(a.latent - b.latent) < 0.75 * gap


def test_body_contact_pushes_each_vertex_out_of_its_nearest_candidates_blended_plane(asset):
    """The contact job against its definition (pleat.h BODY CONTACT), recomputed here point by point and vertex by
    vertex (the points' normals from their posed rings where they have rings): the usable candidates within the margin of the nearest, (1 + η)·m + ε², blend with weights
    max(0, margin − d²) into one plane; a vertex behind it moves along n by r·(offset − d), r the reach: 1 within 3 cm
    of the nearest candidate, 0 beyond 5 cm, linear in m between (those within reach end at least offset_m in front);
    vertices in front are untouched. The golden tube's blend shapes push many through the stand-in body, and its
    candidates overlap, so the test sees single candidates and blends of several, and pushes at every reach."""
    from pleat.reference.body_contact import (CONTACT_BLEND_M, CONTACT_BLEND_SHARE, CONTACT_REACH_FAR_M,
                                              CONTACT_REACH_NEAR_M)
    motion = clip(6, seed=5)
    offset = 0.002
    plain, contact = Instance(asset, body_contact=False), Instance(asset, body_contact_offset_m=offset)
    f = lambda k: np.asarray(asset[k], float)
    points = f("body_anchor") + np.einsum("b,bnc->nc", plain.beta, f("body_anchor_shape"))
    table = np.asarray(asset["body_anchor_candidates"], int)
    P = len(points)
    moved_total, blended, faded, beyond = 0, 0, 0, 0
    for k in range(6):
        before, _ = plain.step(*(m[k] for m in motion))
        after, _ = contact.step(*(m[k] for m in motion))
        m = plain.skin_matrices[asset["body_anchor_skin_indices"].astype(int)]          # [P, K, 3, 4]
        blend = np.einsum("pk,pkij->pij", f("body_anchor_skin_weights"), m)
        a = np.einsum("pij,pj->pi", blend[..., :3], points) + blend[..., 3]
        n = np.einsum("pij,pj->pi", blend[..., :3], f("body_anchor_normal"))
        for p, ring in enumerate(np.asarray(asset["body_anchor_ring"], int)):     # the posed fan's normal
            r = [q for q in ring if q < P]
            if r:
                n[p] = sum(np.cross(a[r[i]] - a[p], a[r[(i + 1) % len(r)]] - a[p]) for i in range(len(r)))
        usable = (np.linalg.norm(n, axis=1) > 1e-12) & np.any(f("body_anchor_normal") != 0, axis=1)
        n[usable] /= np.linalg.norm(n[usable], axis=1, keepdims=True)
        for v in range(len(before)):
            near = [(np.sum((before[v] - a[p]) ** 2), p) for p in table[v] if p < P and usable[p]]
            if not near:
                np.testing.assert_array_equal(after[v], before[v])
                continue
            nearest = min(d2 for d2, _ in near)
            reach = min(1.0, max(0.0, (CONTACT_REACH_FAR_M ** 2 - nearest)
                                 / (CONTACT_REACH_FAR_M ** 2 - CONTACT_REACH_NEAR_M ** 2)))
            margin = (1 + CONTACT_BLEND_SHARE) * nearest + CONTACT_BLEND_M ** 2
            weights = [(margin - d2, p) for d2, p in near if d2 < margin]
            blended += len(weights) > 1
            total = sum(w for w, _ in weights)
            anchor = sum(w * a[p] for w, p in weights) / total
            normal = sum(w * n[p] for w, p in weights)
            normal /= np.linalg.norm(normal)
            d = np.dot(before[v] - anchor, normal)
            if d < offset and reach > 0:
                moved_total += 1
                faded += reach < 1
                np.testing.assert_allclose(after[v], before[v] + reach * (offset - d) * normal, rtol=0, atol=1e-10)
            else:
                beyond += d < offset
                np.testing.assert_array_equal(after[v], before[v])
            if reach == 1:
                assert np.dot(after[v] - anchor, normal) >= offset - 1e-10
    assert 0 < moved_total < 6 * len(table)
    assert blended > 0                   # several candidates within the margin: the blend is exercised
    assert faded > 0 and beyond > 0      # and pushes by a share, and vertices beyond the reach
