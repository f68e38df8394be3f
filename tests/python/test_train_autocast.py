"""stage1.autocast_bf16 (docs/training-speed.md, "Speed"): Φ's matmuls under bfloat16 autocast on the batched path. The
config is off by default, rejected where the device has no native bf16 and when set to anything else; off, the
batched network is float32 throughout; on, one iteration's objective, per-window losses and gradients stay within a
tolerance of float32's on fixed windows. Tiny preset; skips without PyTorch (and the numeric test without native
bf16, e.g. on AVX2-only machines)."""
import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="PyTorch not installed (pip install 'pleat-tools[train]')")

from pleat.train import batching, config, core, settings  # noqa: E402

STEPS = 3


@pytest.mark.parametrize("native", [False, True])
def test_autocast_bf16_setting_is_off_by_default_and_checked_against_the_device(monkeypatch, native):
    monkeypatch.setattr(config, "native_bf16", lambda device: native)
    assert config.autocast_bf16(_stage1(), "cpu") is False
    assert config.autocast_bf16(_stage1(autocast_bf16=False), "cpu") is False
    assert config.autocast_bf16(_stage1(autocast_bf16="auto"), "cpu") is native
    if native:
        assert config.autocast_bf16(_stage1(autocast_bf16=True), "cpu") is True
    else:
        with pytest.raises(ValueError, match="no native bfloat16"):
            config.autocast_bf16(_stage1(autocast_bf16=True), "cpu")
    with pytest.raises(settings.SettingError, match='must be false, true or "auto"'):
        _stage1(autocast_bf16="yes")


def _stage1(**values):
    """The tiny preset's stage1 section with `values` set as --set would set them (checked by the declarations)."""
    return settings.resolve("tiny", overrides={f"stage1.{k}": v for k, v in values.items()})["stage1"]


def test_autocast_bf16_needs_the_batched_path(monkeypatch):
    monkeypatch.setattr(config, "native_bf16", lambda device: True)
    with pytest.raises(ValueError, match="batched path"):
        config.autocast_bf16(_stage1(autocast_bf16=True, batched=False), "cpu")
    assert config.autocast_bf16(_stage1(autocast_bf16="auto", batched=False), "cpu") is False


def test_the_default_configs_leave_autocast_off():
    for preset in ("tiny", "default"):
        assert config.autocast_bf16(core.load_config(preset)["stage1"], "cpu") is False


def test_stage1_refuses_bf16_on_a_device_without_it_before_training(monkeypatch, tiny_physics, tmp_path):
    from pleat.train import stage1
    cfg, _, _ = tiny_physics
    monkeypatch.setattr(config, "native_bf16", lambda device: False)
    bad = dict(cfg, stage1=dict(cfg["stage1"], autocast_bf16=True))
    with pytest.raises(ValueError, match="no native bfloat16"):
        stage1.train_stage1(bad, "tshirt", tmp_path, device="cpu", progress=False)
    assert not (tmp_path / "stage1.pt").exists()


def _one_iteration(setup, model, win, w, bf16):
    model.zero_grad()
    objective, loss, _, _ = batching.stage1_loss(setup, batching.BatchedStage1(model, bf16=bf16), win, STEPS, w,
                                                 "lbs", 1.0)
    objective.backward()
    grads = torch.cat([p.grad.reshape(-1) for p in model.parameters() if p.grad is not None])
    return objective.item(), loss.detach().numpy(), grads


def _trained_a_little(setup):
    torch.manual_seed(0)
    model = core.Stage1Model(setup)
    with torch.no_grad():           # away from the initialisation, so Φ's displacements are not ~0
        for p in model.parameters():
            p.add_(0.005 * torch.randn_like(p))
    return model


def test_float32_batched_network_has_no_bf16_anywhere(tiny_physics):
    cfg, setup, clips = tiny_physics
    model = _trained_a_little(setup)
    rng = np.random.default_rng(4)
    win = batching.prepare(batching.kinematics(setup), [batching.sample_pick(setup, clips, rng, STEPS + 3)
                                                       for _ in range(2)], STEPS)
    batch = batching.WindowBatch(setup, win)
    node, edges, body, recv = batch.features(3)
    seen = set()
    hooks = [m.register_forward_hook(lambda m, i, o: seen.add(o.dtype)) for m in model.modules()
             if isinstance(m, (torch.nn.Linear, torch.nn.LayerNorm))]
    try:
        z, disp = batching.BatchedStage1(model)(node, edges, body, recv, batching.block_graph(setup, 2), 2)
        assert seen == {torch.float32} and z.dtype == disp.dtype == torch.float32
        seen.clear()
        if config.native_bf16("cpu"):
            z, disp = batching.BatchedStage1(model, bf16=True)(node, edges, body, recv,
                                                               batching.block_graph(setup, 2), 2)
            assert torch.bfloat16 in seen and z.dtype == disp.dtype == torch.float32
    finally:
        for h in hooks:
            h.remove()


@pytest.mark.skipif(not config.native_bf16("cpu"), reason="this CPU has no native bfloat16 (AVX-512 BF16 / AMX)")
def test_bf16_iteration_stays_within_tolerance_of_float32(tiny_physics):
    """Three fixed windows, past the start of the collision ramp, Φ moved off its initialisation so that its
    displacements matter (objective ≈ 1.5, LBS = 1): the iteration's objective within 0.5 % of float32's and every
    window's loss within 1 % (bf16 keeps 8 bits: 0.4 % per rounding), the gradient within 10 % (relative norm of the
    difference) and pointing the same way (cosine > 0.995). Measured here: objective 10⁻³, losses 3·10⁻³, gradient
    2-3 %, cosine 0.9996; on the default preset 10⁻⁶ on the losses and 0.6 % on the gradient."""
    cfg, setup, clips = tiny_physics
    w = core.loss_weights(cfg["stage1"], 0, 0.6)
    model = _trained_a_little(setup)
    rng = np.random.default_rng(5)
    win = batching.prepare(batching.kinematics(setup), [batching.sample_pick(setup, clips, rng, STEPS + 3)
                                                       for _ in range(3)], STEPS)
    o32, l32, g32 = _one_iteration(setup, model, win, w, False)
    o16, l16, g16 = _one_iteration(setup, model, win, w, True)
    assert o32 > 1.2                                      # the network's displacements are in the loss
    assert o16 == pytest.approx(o32, rel=5e-3)
    np.testing.assert_allclose(l16, l32, rtol=1e-2)
    assert float((g16 - g32).norm() / g32.norm()) < 0.1
    assert float(torch.nn.functional.cosine_similarity(g16, g32, 0)) > 0.995


@pytest.mark.skipif(not config.native_bf16("cpu"), reason="this CPU has no native bfloat16 (AVX-512 BF16 / AMX)")
def test_stage1_trains_under_bf16_and_says_so(tiny_physics, tmp_path):
    import json
    cfg, _, _ = tiny_physics
    c1 = dict(cfg["stage1"], iterations=2, checkpoint_every=2, validation_every=0, validation_windows=2,
              windows_per_iteration=2, autocast_bf16="auto")
    core.train_stage1(dict(cfg, stage1=c1), "tshirt", tmp_path, device="cpu", progress=False)
    records = [json.loads(line) for line in (tmp_path / "metrics_stage1.jsonl").read_text().splitlines()]
    steps = [r for r in records if "ratio" in r]
    assert len(steps) == 2 and all(r["autocast_bf16"] is True and np.isfinite(r["loss"]) for r in steps)
