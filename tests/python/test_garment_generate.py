"""Procedural garments: vertex count, manifold and outward orientation, edge uniformity, clearance for β ∈ {−3,0,3},
skin weights and pinned sets. Small garments (≈ 800 vertices) on the shipped body."""
import numpy as np
import pytest

from pleat.garment import GARMENT_NAMES, Garment, make_garment
from pleat.garment import mesh as M

N_TEST = 800


@pytest.fixture(scope="module")
def garments(body):
    return {name: make_garment(name, vertices=N_TEST, body=body) for name in GARMENT_NAMES}


@pytest.mark.parametrize("name", GARMENT_NAMES)
def test_vertex_count_within_five_percent(garments, name):
    assert abs(garments[name].num_vertices - N_TEST) <= 0.05 * N_TEST


@pytest.mark.parametrize("name", GARMENT_NAMES)
def test_manifold_consistently_oriented_outward_with_openings(garments, name, body):
    g = garments[name]
    f = g.faces.astype(np.int64)
    assert M.check_manifold(f, g.num_vertices) == []
    loops = M.boundary_loops(f)
    expected = {"tshirt": 4, "long_sleeve": 4, "tank_top": 4, "dress": 4, "pants": 3}[name]
    assert len(loops) == expected                                   # neck, hem, 2 sleeves / waist, 2 legs
    # outward: normals point away from the nearest body point
    from pleat.body import BodyCollider
    n = M.vertex_normals(g.template.astype(np.float64), f)
    _, idx, _ = BodyCollider(body.v_template, body.faces).signed_distance(g.template)
    away = np.einsum("ij,ij->i", n, g.template - body.v_template[idx])
    assert np.mean(away > 0) > 0.95


@pytest.mark.parametrize("name", GARMENT_NAMES)
def test_edge_lengths_are_near_uniform(garments, name):
    el = garments[name].rest_edge_length
    assert el.std() / el.mean() < 0.25                              # coefficient of variation
    assert np.percentile(el, 99) / np.percentile(el, 1) < 4.0
    assert el.min() > 0.15 * np.median(el)


@pytest.mark.parametrize("name", GARMENT_NAMES)
@pytest.mark.parametrize("beta0", [-3.0, 0.0, 3.0])
def test_no_vertex_inside_the_shaped_body(garments, body, name, beta0):
    from pleat.body import BodyCollider
    g = garments[name]
    for comp in range(2):                                           # the first two shape components
        beta = np.zeros(10)
        beta[comp] = beta0
        x = g.shaped(beta)
        d, _, _ = BodyCollider(body.shaped_vertices(beta), body.faces).signed_distance(x, k=8)
        assert d.min() > -2e-3, f"{name} β{comp}={beta0}: {d.min() * 1000:.1f} mm inside"


@pytest.mark.parametrize("name", GARMENT_NAMES)
def test_skin_weights_and_pins(garments, name):
    g = garments[name]
    assert g.skin_indices.shape == (g.num_vertices, 4)
    assert np.allclose(g.skin_weights.sum(1), 1.0, atol=1e-5)
    assert np.all(g.skin_weights >= 0)
    assert np.all(np.diff(g.skin_weights, axis=1) <= 1e-7)          # largest first
    assert g.shape_blend.shape == (10, g.num_vertices, 3)
    if name == "pants":
        assert len(g.pinned) > 10
        assert g.template[g.pinned, 1].min() > np.percentile(g.template[:, 1], 90)  # the waistband, at the top
    else:
        assert len(g.pinned) == 0


def test_save_load_round_trip_and_obj_import(tmp_path, garments, body):
    g = garments["tank_top"]
    g.save(tmp_path / "g.npz")
    h = Garment.load(tmp_path / "g.npz")
    assert h.name == "tank_top" and np.array_equal(h.faces, g.faces) and np.array_equal(h.template, g.template)
    M.write_obj(tmp_path / "g.obj", g.template, g.faces)
    from pleat.garment import garment_from_obj
    o = garment_from_obj(tmp_path / "g.obj", body=body)
    assert o.num_vertices == g.num_vertices
    # same diffusion from the same geometry: same skin
    assert np.array_equal(o.skin_indices[:, 0], g.skin_indices[:, 0])
