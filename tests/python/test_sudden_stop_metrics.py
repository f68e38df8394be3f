"""Sudden-stop numbers on synthetic speed series: the late-hold floor, the follow-through above it, the settle time
(interpolated, measured above the floor), the ratios to the reference, the probes' cut; and the CLI's refusals."""
from types import SimpleNamespace

import numpy as np
import pytest

from pleat.eval import sudden_stop as SS

FPS = 30.0
MOVE = 10                                    # speed[0:9] the body moves, speed[9:] the hold


def series(hold):
    """Mean vertex speed [MOVE − 1 + len(hold)]: 1 m/s while the body moves, then `hold`."""
    return np.concatenate([np.full(MOVE - 1, 1.0), np.asarray(hold, float)])


def test_floor_follow_through_and_settle_of_a_step_series():
    # 6 frames at 50 mm/s, 3 at 20 mm/s, then 31 at a 3 mm/s creep
    v = series([0.05] * 6 + [0.02] * 3 + [0.003] * 31)
    assert SS.late_floor(v, MOVE, FPS) == pytest.approx(0.003)
    # the first 0.5 s = 15 frames: 6 × 47 + 3 × 17 mm/s, each for 1/30 s, and nothing above the floor after
    assert SS.follow_through_mm(v, MOVE, FPS, 0.003) == pytest.approx((6 * 47 + 3 * 17) / 30.0)
    t, settled = SS.settle_time(v, MOVE, FPS, 0.003, 0.01)
    # the last sample above (17 mm/s at 8.5/30 s) to the next (0 at 9.5/30 s): 10 mm/s is crossed 7/17 of the way
    assert settled and t == pytest.approx((8.5 + 7.0 / 17.0) / FPS)
    m = SS.stop_metrics(v, MOVE, FPS)
    assert m == pytest.approx({"floor_m_s": 0.003, "follow_through_mm": (6 * 47 + 3 * 17) / 30.0,
                               "settle_s": (8.5 + 7.0 / 17.0) / FPS, "settled": True})


def test_the_floor_is_the_median_of_the_last_0_4_s():
    hold = np.full(40, 0.005)
    hold[-12:] = [0.004, 0.001, 0.002] * 4                  # the last 12 frames = 0.4 s at 30 fps
    hold[-13] = 10.0                                         # just outside the window
    assert SS.late_floor(series(hold), MOVE, FPS) == pytest.approx(0.002)


def test_a_garment_that_comes_to_rest_is_not_punished_for_the_references_creep():
    k = np.arange(40)
    decay = 0.08 * np.exp(-(k + 0.5) / FPS / 0.08)
    reference = series(decay + 0.004)                       # the same motion on a 4 mm/s creep that never stops
    pleat = series(decay)                                    # comes to rest
    r, p = SS.stop_metrics(reference, MOVE, FPS), SS.stop_metrics(pleat, MOVE, FPS)
    assert r["floor_m_s"] == pytest.approx(0.004, abs=1e-6) and p["floor_m_s"] == pytest.approx(0.0, abs=1e-6)
    assert p["follow_through_mm"] == pytest.approx(r["follow_through_mm"], rel=1e-3)
    assert p["settle_s"] == pytest.approx(r["settle_s"], abs=1e-3)
    c = SS.compare(p, r)
    assert c["follow_through_within"] and c["settle_within"]
    assert c["follow_through_ratio"] == pytest.approx(1.0, rel=1e-3)
    # without the floor the creep alone (4 mm/s for 0.5 s = 2 mm) would count as follow-through
    raw = lambda v: SS.follow_through_mm(v, MOVE, FPS, 0.0)      # noqa: E731
    assert raw(reference) - raw(pleat) == pytest.approx(2.0, rel=1e-6)


def test_a_dead_stop_settles_at_once_and_a_moving_garment_never():
    dead = series(np.zeros(40))                              # LBS-only: the garment stops with the body
    assert SS.stop_metrics(dead, MOVE, FPS) == {"floor_m_s": 0.0, "follow_through_mm": 0.0, "settle_s": 0.0,
                                                "settled": True}
    # a swing that keeps going to the end of the hold, well above its own floor
    swing = series(0.05 + 0.04 * np.sin(np.arange(40) * 2 * np.pi / 12) * (np.arange(40) > 20))
    t, settled = SS.settle_time(swing, MOVE, FPS, SS.late_floor(swing, MOVE, FPS), 0.01)
    assert not settled and t == pytest.approx(40 / FPS)


def test_a_larger_threshold_settles_sooner():
    v = series(0.1 * np.exp(-(np.arange(40) + 0.5) / FPS / 0.1))
    floor = SS.late_floor(v, MOVE, FPS)
    times = [SS.settle_time(v, MOVE, FPS, floor, thr)[0] for thr in (0.005, 0.01, 0.02, 0.05)]
    assert all(a > b for a, b in zip(times, times[1:]))
    # an exponential crosses 0.01 m/s (above its near-zero floor) at 0.1 · ln(10) s; interpolation is within a frame
    assert times[1] == pytest.approx(0.1 * np.log(10.0), abs=0.5 / FPS)


def test_ratios_and_the_band():
    ref = {"follow_through_mm": 10.0, "settle_s": 0.2}
    assert SS.compare({"follow_through_mm": 12.9, "settle_s": 0.141}, ref) == pytest.approx(
        {"follow_through_ratio": 1.29, "follow_through_within": True, "settle_ratio": 0.705, "settle_within": True})
    c = SS.compare({"follow_through_mm": 13.5, "settle_s": 0.1}, ref)
    assert not c["follow_through_within"] and not c["settle_within"]
    assert SS.compare({"follow_through_mm": 13.5, "settle_s": 0.1}, ref, tolerance=0.5)["follow_through_within"]
    # both at rest at once: the same; only the reference at rest: no ratio, not within
    at_rest = {"follow_through_mm": 0.0, "settle_s": 0.0}
    assert SS.compare(at_rest, at_rest)["settle_ratio"] == 1.0
    c = SS.compare({"follow_through_mm": 1.0, "settle_s": 0.1}, at_rest)
    assert c["follow_through_ratio"] is None and not c["follow_through_within"]


def test_the_probe_cut_is_where_the_body_moves_fastest_not_a_one_frame_jump(body):
    """All joints move with the root here, so the joints' mean speed is the root's."""
    T = 40
    v = np.full(T - 1, 1.0)
    v[5] = 9.0                       # before the earliest cut (0.5 s = frame 15): not eligible
    v[20] = 8.0                      # a one-frame jump (a loop seam): the median of 3 ignores it
    v[27:32] = [1.5, 2.5, 3.2, 2.7, 1.8]     # a peak: its medians of 3 tie at 2.7 around it; the peak is the cut
    x = np.concatenate([[0.0], np.cumsum(v) / FPS])
    clip = SimpleNamespace(fps=FPS, root_translation=np.stack([x, np.zeros(T), np.zeros(T)], 1),
                           local_matrices=lambda: body.rest_pose((T,)),
                           root_matrices=lambda: np.broadcast_to(np.eye(3), (T, 3, 3)))
    move, speed, jumps = SS.fast_cut(clip, body)
    assert move == 29 + 2 and speed == pytest.approx(3.2)      # interval 29 (frame 29 → 30) is the last moving one
    assert jumps == [5, 20]
    assert SS.fast_cut(clip, body, earliest_s=0.0)[0] == 29 + 2    # 9 m/s at interval 5 is a single frame too


def test_no_probe_stop_just_after_a_pose_jump(body):
    T = 40
    v = np.full(T - 1, 1.0)
    v[20] = 4.0                      # a loop seam ...
    v[21:24] = [1.6, 1.7, 1.6]       # ... and the fastest stretch right after it
    v[30:33] = [1.3, 1.4, 1.3]
    x = np.concatenate([[0.0], np.cumsum(v) / FPS])
    clip = SimpleNamespace(fps=FPS, root_translation=np.stack([x, np.zeros(T), np.zeros(T)], 1),
                           local_matrices=lambda: body.rest_pose((T,)),
                           root_matrices=lambda: np.broadcast_to(np.eye(3), (T, 3, 3)))
    move, speed, jumps = SS.fast_cut(clip, body)
    assert jumps == [20] and move == 31 + 2 and speed == pytest.approx(1.4)
    assert SS.pose_jumps([1.0, 1.2, 1.0, 1.0]) == [] and SS.pose_jumps([1.0, 1.4, 1.0, 1.0]) == [1]


def test_the_probe_set_is_four_stops_from_the_repos_clips():
    from pleat.motion.split import TRAINING, VALIDATION
    assert [p[0] for p in SS.PROBES] == ["run", "walk", "jump", "punch"]
    assert all(m in TRAINING + VALIDATION for _, m in SS.PROBES)


def test_probe_clips_are_named_by_their_motion():
    assert SS.probe_set(["deepmimic_github/humanoid3d_jog", "mocap/take_07.bvh", "walker/turn_right1"]) == (
        ("jog", "deepmimic_github/humanoid3d_jog"), ("take_07", "mocap/take_07.bvh"),
        ("turn_right1", "walker/turn_right1"))


@pytest.mark.parametrize("argv, message", [
    (["--probes", "--motion", "deepmimic_pybullet/humanoid3d_run"], "--probes chooses"),
    (["--probes", "--move", "12"], "--probes chooses"),
    (["--probes", "--hold", "30"], "--hold of at least 1.3 s"),
    (["--settle-threshold", "0"], "--settle-threshold"),
    (["--hold", "1"], "--hold must be"),
    (["--probe-clips", "deepmimic_github/humanoid3d_jog"], "--probe-clips goes with --probes"),
])
def test_cli_refuses_options_that_do_not_go_together(argv, message, capsys, tmp_path):
    with pytest.raises(SystemExit) as exc:
        SS.main(["--asset", "unused.pleat", "--out", str(tmp_path / "o.json"), *argv])
    assert exc.value.code == 2 and message in capsys.readouterr().err


def test_cli_names_the_regions_when_one_is_unknown(capsys, tmp_path):
    from pleat import REPO_ROOT
    asset = REPO_ROOT / "assets" / "tshirt.pleat"
    if not asset.is_file() or not (REPO_ROOT / "assets" / "body.npz").is_file():
        pytest.skip("assets/tshirt.pleat or assets/body.npz missing")
    with pytest.raises(SystemExit) as exc:
        SS.main(["--asset", str(asset), "--region", "skirt", "--out", str(tmp_path / "o.json")])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "sleeves" in err and "torso" in err
    assert not (tmp_path / "o.json").exists()


@pytest.mark.slow
def test_probe_run_on_the_shipped_tshirt(tmp_path, c_runtime):
    """The whole probe set through the C runtime and the reference simulator (minutes on a CPU; cached after)."""
    import json

    from pleat import REPO_ROOT
    asset = REPO_ROOT / "assets" / "tshirt.pleat"
    if not asset.is_file():
        pytest.skip("assets/tshirt.pleat missing")
    out = tmp_path / "probes.json"
    assert SS.main(["--asset", str(asset), "--probes", "--out", str(out), "--no-progress"]) == 0
    rep = json.loads(out.read_text())
    assert [r["probe"] for r in rep["probes"]] == ["run", "walk", "jump", "punch"]
    for r in rep["probes"]:
        assert r["hold_frames"] >= 39 and r["move_frames"] >= 17
        assert r["lbs"]["follow_through_mm"] < 0.5 * r["reference"]["follow_through_mm"]    # LBS stops dead
        for m in ("pleat", "lbs", "reference"):
            assert np.isfinite([r[m]["floor_m_s"], r[m]["follow_through_mm"], r[m]["settle_s"]]).all()
        assert set(r["pleat_vs_reference"]) == {"follow_through_ratio", "follow_through_within", "settle_ratio",
                                                "settle_within"}
    assert 0 <= rep["follow_through_within"] <= 4 and isinstance(rep["all_within"], bool)


def test_reference_spread_scores_a_second_reference_started_1_um_apart(tmp_path, c_runtime):
    """--reference-spread: a second reference from a start moved by 1 µm (pleat-eval's spread), measured like a
    method and compared with the first: how far two valid simulations' follow-through and settle time are apart."""
    import json

    from pleat import REPO_ROOT
    asset = REPO_ROOT / "assets" / "tshirt.pleat"
    out = tmp_path / "stop.json"
    assert SS.main(["--asset", str(asset), "--motion", "deepmimic_pybullet/humanoid3d_walk", "--move", "4", "--hold",
                    "6", "--reference-spread", "--out", str(out), "--no-progress"]) == 0
    rep = json.loads(out.read_text())
    first, second = rep["reference"], rep["reference_spread"]
    assert len(second["speed_m_s"]) == len(first["speed_m_s"]) == 9
    assert second["speed_m_s"] != first["speed_m_s"]                      # another valid simulation, not a copy
    assert np.allclose(second["speed_m_s"], first["speed_m_s"], atol=0.05)  # ... of the same cloth
    assert set(rep["spread_vs_reference"]) == set(rep["pleat_vs_reference"])
    assert np.isfinite(rep["spread_vs_reference"]["follow_through_ratio"])
