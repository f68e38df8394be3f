import numpy as np
import pytest

from pleat.eval import metrics


def test_vertex_error_is_distance_in_mm():
    ref = np.zeros((2, 3, 3))
    pred = ref.copy()
    pred[1, 2] = [0.003, 0.004, 0.0]  # 5 mm
    err = metrics.vertex_error_mm(pred, ref)
    assert err.shape == (2, 3)
    assert err[1, 2] == pytest.approx(5.0)
    assert err.sum() == pytest.approx(5.0)


def test_shape_mismatch_is_rejected():
    with pytest.raises(ValueError):
        metrics.vertex_error_mm(np.zeros((2, 3, 3)), np.zeros((2, 4, 3)))


def test_uniformly_stretched_edges_have_that_strain():
    rest = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    faces = np.array([[0, 1, 2]])
    edges = metrics.unique_edges(faces)
    assert len(edges) == 3
    rest_len = np.linalg.norm(rest[edges[:, 1]] - rest[edges[:, 0]], axis=-1)
    strain = metrics.edge_strain((rest * 1.1)[None], edges, rest_len)
    np.testing.assert_allclose(strain, 0.1, atol=1e-12)


def test_constant_acceleration_is_recovered():
    dt = 1 / 30
    t = np.arange(10) * dt
    pos = np.zeros((10, 1, 3))
    pos[:, 0, 1] = -0.5 * 9.81 * t ** 2
    acc = metrics.acceleration(pos, dt)
    np.testing.assert_allclose(acc[:, 0, 1], -9.81, rtol=1e-9)


def test_penetration_counts_vertices_inside():
    d = np.array([[0.01, -0.002, 0.02, 0.03], [0.01, 0.01, 0.01, -0.005]])
    p = metrics.penetration(d)
    assert p["penetration_pct"] == pytest.approx(25.0)
    assert p["max_depth_mm"] == pytest.approx(5.0)


def test_score_of_reference_against_itself_is_zero():
    rng = np.random.default_rng(1)
    ref = rng.normal(size=(5, 4, 3))
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    s = metrics.score(ref, ref, faces, ref[0], 1 / 30)
    assert s["mean_mm"] == 0 and s["p95_mm"] == 0 and s["jitter"] == 0 and s["edge_strain_error"] == 0
