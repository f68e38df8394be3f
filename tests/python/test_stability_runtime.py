"""Stability thresholds on the C runtime (through pleat.runtime), small and fast: a random-weight asset at a small
size (pleat.reference.golden.random_weights, a contractive latent recurrence as a trained model should have) and
random smooth motion on its SMPL-named skeleton. No reference simulator here; the quantity tracked is the deviation
from the LBS-only twin (the network's own displacement, docs/stability.md), and the stated bound is the interval
bound of pleat.eval.bounds, derived from the asset alone."""
import numpy as np
import pytest

from pleat.asset import write_asset
from pleat.eval import bounds, stability
from pleat.eval import scene as S
from pleat.motion import Clip
from pleat.reference.golden import SMPL_JOINT_NAMES, random_motion, random_weights

runtime = pytest.importorskip("pleat.runtime")
if runtime.find_library() is None:
    pytest.skip("libpleat.so not built (set PLEAT_BUILD_DIR or PLEAT_LIBRARY)", allow_module_level=True)

FPS = 30.0


@pytest.fixture(scope="module")
def asset():
    w = random_weights(vertices=300, latent=16, blend=16, lp_hidden=(64, 64), dec_hidden=(32,), seed=5)
    data = write_asset(None, w)
    _, stored = S.read_weights(data)
    return data, stored, S.lbs_only_bytes(stored)


@pytest.fixture(scope="module")
def ctx():
    with runtime.Context() as c:
        yield c


def _clip(frames, seed):
    rot, tr, rr, _ = random_motion(frames, seed=seed)
    return Clip(name=f"random{seed}", fps=FPS, local_rotations=rot, root_translation=tr, root_rotation=rr,
                joint_names=SMPL_JOINT_NAMES)


def _motion(clip):
    return clip.local_rotations, clip.root_translation, clip.root_rotation


@pytest.fixture(scope="module")
def long_run(ctx, asset):
    data, w, lbs = asset
    chain = stability.chained_clip([_clip(240, s) for s in range(4)], 5000)
    assert chain.num_frames >= 5000
    return chain, stability.paired_run(ctx, data, lbs, w, *_motion(chain), 1 / FPS)


def test_chained_run_of_5000_frames_does_not_drift(long_run):
    chain, run = long_run
    d = stability.drift(run["deviation_mm"], FPS)
    # the last 500 frames replay the first 500 frames' motion: same inputs except the carried latent
    s = stability.replay_offset(FPS)
    np.testing.assert_allclose(chain.local_rotations[-500:], chain.local_rotations[s:s + 500], atol=1e-6)
    assert d["first_window_mm"] > 1.0                       # the network does move the garment
    assert d["ratio"] <= 1.2
    assert abs(d["slope_mm_per_min"]) < 0.05 * d["first_window_mm"]


def test_long_run_is_finite_resets_nothing_and_keeps_the_latent_in_its_training_range(long_run):
    _, run = long_run
    assert run["finite"] and run["resets"] == 0 and run["latent_in_range"]
    assert np.isfinite(run["pleat"].latent_norm).all()


def test_every_vertex_stays_within_the_decoder_bound_of_the_skinned_template(long_run, asset):
    _, run = long_run
    _, w, _ = asset
    assert run["bound_excess_mm"] <= 1e-2                   # fp32 slack
    # the LBS twin itself is the skinned template: its vertices stay at their rest distance from the skeleton
    lbs = run["lbs"].positions
    assert np.isfinite(lbs).all()


@pytest.mark.parametrize("speed", [2.0, 3.0])
def test_fast_motion_stays_finite_and_bounded(ctx, asset, speed):
    data, w, lbs = asset
    clip = _clip(300, 11).time_scaled(speed)
    run = stability.paired_run(ctx, data, lbs, w, *_motion(clip), 1 / FPS)
    assert run["finite"] and run["resets"] == 0 and run["latent_in_range"]
    assert run["bound_excess_mm"] <= 1e-2


@pytest.mark.parametrize("component,value", [(0, -4.0), (0, 4.0), (1, -3.0), (1, 3.0), (2, 4.0)])
def test_unusual_bodies_stay_finite_and_bounded(ctx, asset, component, value):
    data, w, lbs = asset
    beta = np.zeros(len(w["shape_blend"]))
    beta[component] = value
    run = stability.paired_run(ctx, data, lbs, w, *_motion(_clip(150, 3)), 1 / FPS, beta)
    assert run["finite"] and run["resets"] == 0 and run["bound_excess_mm"] <= 1e-2


def test_beta_beyond_the_range_is_clamped_to_it(ctx, asset):
    data, w, _ = asset
    clip = _clip(20, 4)
    beta = np.zeros(len(w["shape_blend"]))
    beta[0] = 7.0
    far = S.rollout(ctx, data, *_motion(clip), 1 / FPS, beta)
    beta[0] = float(w["beta_range"][1])
    edge = S.rollout(ctx, data, *_motion(clip), 1 / FPS, beta)
    np.testing.assert_array_equal(far.positions, edge.positions)


def test_jittered_frame_times_stay_finite_and_bounded(ctx, asset):
    data, w, lbs = asset
    clip = _clip(400, 6)
    rot, tr, rr, dts = stability.jittered_motion(clip, seed=2)
    assert dts.min() >= 1 / 120 and dts.max() <= 1 / 15
    run = stability.paired_run(ctx, data, lbs, w, rot, tr, rr, dts)
    assert run["finite"] and run["resets"] == 0 and run["bound_excess_mm"] <= 1e-2


def test_dt_above_the_range_is_clamped_to_dt_max(ctx, asset):
    data, w, _ = asset
    rot, tr, rr = _motion(_clip(10, 8))
    dt_max = float(w["dt_range_s"][1])
    slow = S.rollout(ctx, data, rot, tr, rr, 0.5)
    clamped = S.rollout(ctx, data, rot, tr, rr, dt_max)
    assert all(r == runtime.RESULT_CLAMPED for r in slow.results)
    np.testing.assert_array_equal(slow.positions, clamped.positions)


def test_nan_pose_is_rejected_and_leaves_the_instance_as_it_was(ctx, asset):
    data, _, _ = asset
    rot, tr, rr = _motion(_clip(6, 9))
    a_asset, b_asset = ctx.load_asset(data), ctx.load_asset(data)
    a, b = ctx.create_instance(a_asset), ctx.create_instance(b_asset)
    try:
        for k in range(3):
            a.step(rot[k], tr[k], rr[k], 1 / FPS)
            b.step(rot[k], tr[k], rr[k], 1 / FPS)
        bad = rot[3].copy()
        bad[5, 0] = np.nan
        with pytest.raises(runtime.PleatError):
            a.step(bad, tr[3], rr[3], 1 / FPS)
        with pytest.raises(runtime.PleatError):
            a.step(rot[3], tr[3], rr[3], float("inf"))
        pa, _ = a.step(rot[3], tr[3], rr[3], 1 / FPS)
        pb, _ = b.step(rot[3], tr[3], rr[3], 1 / FPS)
        np.testing.assert_array_equal(pa, pb)
    finally:
        for o in (a, b, a_asset, b_asset):
            o.close()


def test_overflow_inside_the_network_resets_to_a_first_frame(ctx):
    """A root-velocity input normalised by a tiny std overflows f_LP: the step must report NUMERIC_RESET and give
    what a fresh instance gives on the same pose (a first frame), all finite."""
    w = random_weights(vertices=120, latent=8, blend=8, lp_hidden=(16,), dec_hidden=(16,), seed=7)
    L = len(w["z_min"])
    w["x_std"] = np.asarray(w["x_std"], np.float64).copy()
    w["x_std"][L] = 1e-30                                   # first root-velocity component
    w["lp.0.weight"] = np.asarray(w["lp.0.weight"], np.float64).copy()
    w["lp.0.weight"][:, L] = np.where(np.arange(w["lp.0.weight"].shape[0]) % 2, 1e30, -1e30)
    data = write_asset(None, w)
    rot, tr, rr = _motion(_clip(4, 10))
    tr = np.zeros_like(tr)
    tr[2:, 0] = 0.05                                         # moves between frames 1 and 2: velocity ≠ 0
    a_asset, b_asset = ctx.load_asset(data), ctx.load_asset(data)
    a, b = ctx.create_instance(a_asset), ctx.create_instance(b_asset)
    try:
        a.step(rot[0], tr[0], rr[0], 1 / FPS)
        a.step(rot[0], tr[1], rr[0], 1 / FPS)
        pa, _ = a.step(rot[0], tr[2], rr[0], 1 / FPS)
        assert a.last_result == runtime.RESULT_NUMERIC_RESET
        pb, _ = b.step(rot[0], tr[2], rr[0], 1 / FPS)
        assert np.isfinite(pa).all()
        np.testing.assert_array_equal(pa, pb)
        np.testing.assert_array_equal(a.latent, b.latent)
    finally:
        for o in (a, b, a_asset, b_asset):
            o.close()


def test_lbs_only_asset_moves_nothing(ctx, asset):
    """The zero network's bound is 0, and the runtime agrees: Pleat on the LBS-only twin equals the twin."""
    _, w, lbs = asset
    lw = S.lbs_only_weights(w)
    assert bounds.displacement_bound_m(lw).max() == 0.0
    run = stability.paired_run(ctx, lbs, lbs, lw, *_motion(_clip(30, 12)), 1 / FPS)
    assert run["deviation_max_mm"] == 0.0
