"""Garment regions (pleat.eval.regions) on the five procedural garments at 400 vertices: every region non-empty and
where it belongs, the partitions disjoint and complete, the openings inside their bands."""
import numpy as np
import pytest

from pleat.eval.regions import REGION_NAMES, distance_to_loop, garment_regions
from pleat.garment import mesh as M
from pleat.garment.generate import GARMENT_NAMES, make_garment


@pytest.fixture(scope="module")
def garments(body):
    return {name: make_garment(name, vertices=400, body=body) for name in GARMENT_NAMES}


@pytest.fixture(scope="module")
def regions(garments, body):
    return {name: garment_regions(name, g.template, g.faces, body, g.skin_indices, g.skin_weights)
            for name, g in garments.items()}


def _joint(body, name):
    return body.joints()[list(body.joint_names).index(name)]


def _loop_nearest(g, point):
    loops = M.boundary_loops(g.faces)
    return min(loops, key=lambda L: np.linalg.norm(g.template[L].mean(0) - point))


@pytest.mark.parametrize("name", GARMENT_NAMES)
def test_every_region_is_a_nonempty_part_of_the_garment(name, garments, regions):
    n = len(garments[name].template)
    r = regions[name]
    assert set(r) == {"all", *REGION_NAMES[name]}
    assert r["all"].dtype == bool and r["all"].all() and len(r["all"]) == n
    for k in REGION_NAMES[name]:
        assert r[k].dtype == bool and r[k].shape == (n,)
        assert 0 < r[k].sum() < n, (k, int(r[k].sum()))


def test_dress_skirt_hangs_below_the_bodice(garments, regions, body):
    x, r = garments["dress"].template, regions["dress"]
    assert not (r["skirt"] & r["bodice"]).any() and (r["skirt"] | r["bodice"]).all()
    assert x[r["skirt"], 1].max() < x[r["bodice"], 1].min()
    hip_y = 0.5 * (_joint(body, "left_hip")[1] + _joint(body, "right_hip")[1])
    assert x[r["skirt"], 1].max() < hip_y + 0.02 <= x[r["bodice"], 1].min()
    hem = min(M.boundary_loops(garments["dress"].faces), key=lambda L: x[L, 1].mean())
    assert r["skirt"][hem].all()
    assert r["skirt"].sum() > r["bodice"].sum()          # a knee-length skirt is most of the dress


def test_tshirt_sleeves_are_on_the_arms(garments, regions, body):
    g, r = garments["tshirt"], regions["tshirt"]
    assert not (r["sleeves"] & r["torso"]).any() and (r["sleeves"] | r["torso"]).all()
    for side, sign in (("left", 1.0), ("right", -1.0)):
        opening = _loop_nearest(g, _joint(body, f"{side}_elbow"))
        assert r["sleeves"][opening].all()
        assert (sign * g.template[r["sleeves"], 0] > 0).sum() > 0.4 * r["sleeves"].sum()
    neck = _loop_nearest(g, _joint(body, "neck"))
    assert r["torso"][neck].all()
    # without the skin given, the generator's own diffusion gives the same sleeves
    again = garment_regions("tshirt", g.template, g.faces, body)
    np.testing.assert_array_equal(again["sleeves"], r["sleeves"])


def test_pants_waistband_crotch_and_knees_are_apart(garments, regions, body):
    g, r = garments["pants"], regions["pants"]
    x = g.template
    for a, b in (("waistband", "crotch"), ("waistband", "knees"), ("crotch", "knees")):
        assert not (r[a] & r[b]).any(), (a, b)
    assert r["waistband"][g.pinned].all()                         # the pinned top opening is in the band
    assert x[r["crotch"], 1].min() > x[r["knees"], 1].max() - 0.05
    assert np.abs(x[r["crotch"], 0]).max() <= 0.08 + 1e-9
    hip_y = _joint(body, "left_hip")[1]
    assert x[r["crotch"], 1].max() < hip_y
    for side in ("left", "right"):
        knee = _joint(body, f"{side}_knee")
        near = np.linalg.norm(x[r["knees"]] - knee, axis=1)
        assert (near <= 0.10).sum() > 0.3 * r["knees"].sum()


def test_long_sleeve_elbows_and_cuffs_on_both_arms(garments, regions, body):
    g, r = garments["long_sleeve"], regions["long_sleeve"]
    x = g.template
    assert not (r["elbows"] & r["cuffs"]).any()
    for k in ("elbows", "cuffs"):
        assert (x[r[k], 0] > 0).any() and (x[r[k], 0] < 0).any(), k
    for side in ("left", "right"):
        assert r["cuffs"][_loop_nearest(g, _joint(body, f"{side}_wrist"))].all()
    # the cuffs are farther out along the arm than the elbows
    assert np.abs(x[r["cuffs"], 0]).min() > np.abs(x[r["elbows"], 0]).max()


def test_tank_top_armholes_hold_both_openings_and_not_the_neck_or_hem(garments, regions, body):
    g, r = garments["tank_top"], regions["tank_top"]
    for side in ("left", "right"):
        assert r["armholes"][_loop_nearest(g, _joint(body, f"{side}_shoulder"))].all()
    x = g.template
    loops = M.boundary_loops(g.faces)
    neck = max(loops, key=lambda L: x[L, 1].mean())
    hem = min(loops, key=lambda L: x[L, 1].mean())
    assert not r["armholes"][neck].any() and not r["armholes"][hem].any()


def test_an_unknown_garment_has_only_all(garments, body):
    g = garments["dress"]
    r = garment_regions("my_coat", g.template, g.faces, body)
    assert list(r) == ["all"] and r["all"].all()


def test_distance_to_a_square_opening():
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    pts = np.array([[0.5, -0.2, 0.0], [0.5, 0.5, 0.0], [2.0, 1.0, 0.0], [0.25, 0.0, 0.3]])
    np.testing.assert_allclose(distance_to_loop(pts, square), [0.2, 0.5, 1.0, 0.3])
