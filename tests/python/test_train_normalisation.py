"""Stage-1 per-window loss normalisation and clip exclusion (docs/training.md, "Stage-1 clips and per-window
normalisation"). Skips without PyTorch."""
import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="PyTorch not installed (pip install 'pleat-tools[train]')")

from pleat.train import core  # noqa: E402


def test_default_preset_trains_the_1k_shirt_with_normalised_windows_and_without_shredded_clips():
    cfg = core.load_config("default")
    assert cfg["garment_vertices"] == 1000
    c1 = cfg["stage1"]
    assert c1["loss_norm"] == "lbs" and c1["loss_norm_floor"] > 0
    for name in ("cartwheel", "crawl", "roll", "getup_", "backflip", "spin"):
        assert name in c1["exclude_clips"]


def test_physics_clips_drop_the_excluded_names(monkeypatch):
    clip = type("C", (), {})
    names = ["humanoid3d_walk", "humanoid3d_cartwheel", "humanoid3d_dance_spin", "humanoid3d_spinkick", "run"]
    clips = []
    for n in names:
        c = clip()
        c.name = n
        clips.append(c)
    monkeypatch.setattr(core.sources, "clips", lambda *a, **k: list(clips))
    cfg = core.load_config("tiny")
    cfg["stage1"]["exclude_clips"] = ["cartwheel", "spin"]
    assert [c.name for c in core.physics_clips(cfg, None)] == ["humanoid3d_walk", "run"]
    cfg["stage1"]["exclude_clips"] = []
    assert len(core.physics_clips(cfg, None)) == len(names)


@pytest.fixture(scope="module")
def tiny():
    cfg = core.load_config("tiny")
    setup = core.Setup(cfg, "tshirt", "cpu")
    clips = core.sources.clips("validation", 30.0, 1, 12, setup.body)
    return cfg, setup, clips


def test_lbs_scale_is_the_zero_network_loss_of_the_same_window(tiny):
    """The divisor is the loss of the garment following LBS on the same window (a network whose displacement is
    zero), over the nonnegative terms, floored."""
    cfg, setup, clips = tiny
    rng = np.random.default_rng(0)
    c1 = cfg["stage1"]
    w = core.loss_weights(c1, c1["iterations"] - 1)
    win, beta, mat, mat01 = core.sample_window(setup, clips, rng, 3 + 3)
    scale, terms = core.lbs_scale(setup, win, beta, mat, mat01, 3, w, 1e-9)
    zero = torch.zeros(setup.N, 3)
    _, t = core.rollout_loss(setup, None, core.Window(setup, win, beta, mat, mat01), 3, w, lambda f: zero)
    expected = sum(w[k] * t[k] for k in ("bending", "stretching", "inertia", "friction", "collision"))
    assert scale == pytest.approx(expected, rel=1e-6)
    assert terms["stretching"] == pytest.approx(t["stretching"], rel=1e-6)
    assert scale > 0
    big, _ = core.lbs_scale(setup, win, beta, mat, mat01, 3, w, 1e9)
    assert big == 1e9
