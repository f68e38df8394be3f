"""pleat-eval's plumbing: the LBS-only twin, the garment rebuilt from the asset, the reference cache key, and the
report of `evaluate` (with the slow reference replaced by a known answer)."""
import json

import numpy as np
import pytest

from pleat.asset import write_asset
from pleat.eval import scene as S
from pleat.reference.golden import random_motion, random_weights
from pleat.reference.instance import Instance

runtime = pytest.importorskip("pleat.runtime")
HAVE_LIB = runtime.find_library() is not None
needs_lib = pytest.mark.skipif(not HAVE_LIB, reason="libpleat.so not built (set PLEAT_BUILD_DIR or PLEAT_LIBRARY)")


@pytest.fixture(scope="module")
def weights():
    return random_weights(vertices=200, latent=8, blend=8, lp_hidden=(32,), dec_hidden=(16,), seed=9)


def test_lbs_only_twin_keeps_the_garment_and_zeroes_the_network(weights):
    _, stored = S.read_weights(write_asset(None, weights))
    twin = S.lbs_only_weights(stored)
    for k in ("template", "faces", "skin_indices", "skin_weights", "shape_blend", "joint_template", "pinned"):
        np.testing.assert_array_equal(twin[k], stored[k])
    assert S.is_lbs_only(twin) and not S.is_lbs_only(stored)
    _, back = S.read_weights(S.lbs_only_bytes(stored))
    assert np.all(back["blend_shapes"] == 0)


@needs_lib
def test_c_runtime_on_the_lbs_twin_matches_the_numpy_reference_instance(weights):
    _, stored = S.read_weights(write_asset(None, weights))
    twin = S.read_weights(S.lbs_only_bytes(stored))[1]
    rot, tr, rr, dt = random_motion(12, seed=3)
    beta = np.linspace(-1, 1, len(stored["shape_blend"]))
    with runtime.Context() as ctx:
        run = S.rollout(ctx, S.lbs_only_bytes(stored), rot, tr, rr, dt, beta)
    ref = Instance(twin, beta)
    expected = np.array([ref.step(rot[k], tr[k], rr[k], float(dt[k]))[0] for k in range(len(dt))])
    np.testing.assert_allclose(run.positions, expected, atol=2e-5)
    assert (run.step_us > 0).all() and run.resets == 0


def test_garment_for_the_simulator_is_the_assets_mesh(weights):
    _, stored = S.read_weights(write_asset(None, weights))
    g = S.garment_from_asset(stored)
    np.testing.assert_array_equal(g.template, stored["template"])
    np.testing.assert_array_equal(g.faces, stored["faces"])
    np.testing.assert_array_equal(g.pinned, stored["pinned"])
    assert g.edges.shape[1] == 2 and (g.vertex_area > 0).all()


def _key_inputs(weights):
    """A garment from the asset, a stand-in body and a 10-frame clip: what a reference cache key is made of."""
    from types import SimpleNamespace
    _, stored = S.read_weights(write_asset(None, weights))
    body = SimpleNamespace(v_template=np.zeros((4, 3)), shapedirs=np.zeros((4, 3, 2)), weights=np.ones((4, 1)),
                           faces=np.zeros((1, 3), int), J_regressor=np.ones((1, 4)))
    rot, tr, rr, _ = random_motion(10, seed=1)
    clip = SimpleNamespace(local_rotations=rot, root_translation=tr, root_rotation=rr, fps=30.0)
    return S.garment_from_asset(stored), body, clip


def test_reference_cache_key_changes_with_every_input(weights):
    from types import SimpleNamespace

    from pleat.eval.reference import cache_key
    from pleat.sim import SolverSettings
    g, body, clip = _key_inputs(weights)
    beta, mat, st = np.zeros(10), np.array([0.2, 2e4, 4e4, 1e-5]), SolverSettings()
    base = cache_key(g, body, beta, mat, clip, 10, st)
    assert base == cache_key(g, body, beta.copy(), mat.copy(), clip, 10, SolverSettings())
    changed = [cache_key(g, body, beta + 0.1, mat, clip, 10, st), cache_key(g, body, beta, mat * 1.01, clip, 10, st),
               cache_key(g, body, beta, mat, clip, 9, st),
               cache_key(g, body, beta, mat, clip, 10, SolverSettings(force_tol=2 * st.force_tol)),
               cache_key(g, SimpleNamespace(**dict(vars(body), v_template=np.ones((4, 3)))), beta, mat, clip, 10, st)]
    assert len({base, *changed}) == 6
    # the spread's twin reference has its own key; an unperturbed one keeps the old key (existing caches stay valid)
    assert cache_key(g, body, beta, mat, clip, 10, st, start_perturbation_m=0.0) == base
    assert cache_key(g, body, beta, mat, clip, 10, st, start_perturbation_m=1e-6) not in {base, *changed}
    # another teacher's simulation has its own key; Pleat's simulator keeps the old one
    assert cache_key(g, body, beta, mat, clip, 10, st, teacher="pleat") == base
    blender = cache_key(g, body, beta, mat, clip, 10, st, teacher="blender")
    assert blender not in {base, *changed}


def test_blenders_key_holds_its_scenes_cloth_defaults(weights, monkeypatch):
    """A changed default of the add-on's cloth (pleat_blender.cloth) simulates anew: Blender's cached simulations
    are keyed by it, Pleat's simulator's are not."""
    from pleat.eval.reference import cache_key
    from pleat.sim import SolverSettings
    from pleat_blender import cloth
    g, body, clip = _key_inputs(weights)
    args = (g, body, np.zeros(10), np.array([0.2, 2e4, 4e4, 1e-5]), clip, 10, SolverSettings())
    before = cache_key(*args, teacher="blender"), cache_key(*args)
    monkeypatch.setitem(cloth.CLOTH, "collision_distance_m", 0.004)
    assert cache_key(*args, teacher="blender") != before[0]
    assert cache_key(*args) == before[1]
    monkeypatch.setitem(cloth.BODY_COLLISION, "thickness_outer_m", 0.004)
    monkeypatch.setitem(cloth.CLOTH, "collision_distance_m", 0.001)
    assert cache_key(*args, teacher="blender") != before[0]


def test_an_unknown_teacher_is_refused_by_name():
    from pleat.eval.reference import TEACHERS, check_teacher
    assert check_teacher("pleat") == "pleat"
    with pytest.raises(ValueError, match="use one of pleat, blender"):
        check_teacher("houdini")
    assert TEACHERS == ("pleat", "blender")


def test_blender_as_teacher_without_bpy_says_how_to_install_it(monkeypatch):
    import importlib.util

    from pleat.eval.reference import check_teacher
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "bpy" else real(name, *a))
    with pytest.raises(ValueError, match=r"pip install -e 'tools\[blender\]'"):
        check_teacher("blender")


@needs_lib
def test_evaluate_scores_lbs_zero_when_the_reference_is_lbs(monkeypatch, tmp_path):
    """With the reference replaced by the LBS garment itself, the LBS-only baseline must score exactly 0 mm, and
    the report carries the keys docs/accuracy.md promises."""
    from pleat import REPO_ROOT
    from pleat.eval import cli
    asset = REPO_ROOT / "assets" / "tshirt.pleat"
    if not asset.is_file() or not (REPO_ROOT / "assets" / "body.npz").is_file():
        pytest.skip("assets/tshirt.pleat or assets/body.npz missing")

    def fake_reference(garment, body, clip, beta, material, frames=None, start_perturbation_m=0.0, **kw):
        _, M = S.posed_body(body, clip, beta)
        x = garment.skin(M, beta).astype(np.float32)
        x[..., 0] += 2e3 * start_perturbation_m          # the twin reference: every vertex 2 mm off along x
        return x, dict(key=f"fake{start_perturbation_m}", cache_hit=False)
    monkeypatch.setattr("pleat.eval.reference.cached_simulate", fake_reference)
    out = tmp_path / "r.json"
    cli.main(["--asset", str(asset), "--motion", "deepmimic_pybullet/humanoid3d_punch", "--max-frames", "4",
              "--json", str(out), "--plots", str(tmp_path), "--no-progress", "--reference-spread"])
    r = json.loads(out.read_text())
    assert r["frames"] == 4 and r["fps"] == 30.0
    for m in ("pleat", "lbs"):
        for k in ("mean_mm", "p95_mm", "penetration_pct", "max_depth_mm", "jitter", "edge_strain_error"):
            assert np.isfinite(r[m][k])
    assert r["lbs"]["mean_mm"] < 1e-3 and r["pleat"]["step_us"] > 0
    assert r["teacher"] is None and r["teacher_reason"]
    assert r["reference_spread"]["mean_mm"] == pytest.approx(2.0, rel=1e-3)
    assert r["reference_spread"]["start_perturbation_m"] == 1e-6
    # the faces' share inside the body (pleat.sim.surface): the LBS twin is the reference here, so the same numbers
    lbs_in, ref_in = r["lbs"]["surface_inside"], r["reference"]["surface_inside"]
    assert lbs_in["frames"] == ref_in["frames"] == 4 and lbs_in["inside_pct"] == pytest.approx(ref_in["inside_pct"])
    assert lbs_in["max_depth_mm"] == pytest.approx(ref_in["max_depth_mm"], abs=1e-3)     # float32 skinning apart
    default_inside = r["pleat"]["surface_inside"]["inside_pct"]
    # a 2 cm body-contact clearance pushes Pleat's garment off the body: no more of its surface inside than before
    cli.main(["--asset", str(asset), "--motion", "deepmimic_pybullet/humanoid3d_punch", "--max-frames", "4",
              "--json", str(out), "--no-progress", "--body-contact-offset", "0.02"])
    r = json.loads(out.read_text())
    assert r["body_contact_offset_m"] == 0.02 and r["pleat"]["surface_inside"]["inside_pct"] <= default_inside
    assert r["pleat"]["mean_mm"] > r["lbs"]["mean_mm"]                  # it moved: the garment is not the reference
    # at 60 fps with the networks at 30 Hz: 8 frames of 1/60 s, the LBS baseline still exact
    cli.main(["--asset", str(asset), "--motion", "deepmimic_pybullet/humanoid3d_punch", "--max-frames", "8",
              "--fps", "60", "--network-rate", "30", "--json", str(out), "--no-progress"])
    r = json.loads(out.read_text())
    assert (r["frames"], r["fps"], r["network_rate_hz"]) == (8, 60.0, 30.0)
    assert r["lbs"]["mean_mm"] < 1e-3 and np.isfinite(r["pleat"]["mean_mm"]) and r["pleat"]["mean_step_us"] > 0
    assert list(tmp_path.glob("*.png"))
