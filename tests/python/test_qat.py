"""Quantisation-aware fine-tuning (pleat.train.qat, `pleat-quantise finetune`): the forward pass it trains is the int8
arithmetic the runtime runs, its gradients reach the weights, and the asset it writes carries the scales of its
calibration rows. Needs torch."""
import numpy as np
import pytest

torch = pytest.importorskip("torch")

from pleat import asset as pa  # noqa: E402
from pleat import quantise as pq  # noqa: E402
from pleat.reference.mlp import int8_layers, mlp_int8  # noqa: E402
from pleat.train import qat  # noqa: E402


def _random_weights(rng, sizes, I):
    w = {"x_mean": rng.normal(size=I), "x_std": rng.uniform(0.5, 2.0, I), "lp_activation": "relu",
         "dec_activation": "relu"}
    for prefix, dims in (("lp", sizes[0]), ("dec", sizes[1])):
        for i, (a, b) in enumerate(zip(dims[:-1], dims[1:])):
            w[f"{prefix}.{i}.weight"] = (rng.normal(size=(b, a)) / np.sqrt(a)).astype(np.float32)
            w[f"{prefix}.{i}.bias"] = (0.1 * rng.normal(size=b)).astype(np.float32)
    L = sizes[0][-1]
    w.update(z_mean=np.zeros(L), z_std=np.ones(L), z_min=-3 * np.ones(L), z_max=3 * np.ones(L))
    return w


@pytest.mark.parametrize("ranged", [True, False])
def test_the_trained_forward_is_the_runtime_int8_arithmetic(ranged):
    """Network.forward with its quantised weights gives, on calibration inputs, what pleat.reference.mlp.mlp_int8
    (the C kernels' bits) gives for the layers pleat.quantise writes from the same weights and rows, with ranged
    inputs and with symmetric ones."""
    rng = np.random.default_rng(3)
    weights = _random_weights(rng, ([40, 64, 64, 8], [8, 32, 12]), 40)
    x = rng.normal(size=(200, 40))
    model = qat.Model(weights, ranged)
    model.calibrate(x, 100.0)
    quantised, _ = pq.quantise(weights, x, 100.0, ranged=ranged)
    assert bool(quantised["int8_ranged_inputs"]) == ranged
    for prefix, net in (("lp", model.lp), ("dec", model.dec)):
        ref_layers = int8_layers(quantised, prefix)
        assert np.allclose([layer["input_scale"] for layer in ref_layers], net.input_scales.numpy(), rtol=0, atol=0)
        h = x if prefix == "lp" else np.clip(rng.normal(size=(200, 8)), -3, 3)
        with torch.no_grad():
            got = net(torch.as_tensor(h, dtype=torch.float32), net.quantised()).numpy()
        want = mlp_int8(h, ref_layers, "relu")
        assert np.abs(got - want).max() < 1e-4 * max(1.0, np.abs(want).max())
        # and it is not the float network: quantisation shows
        with torch.no_grad():
            exact = net(torch.as_tensor(h, dtype=torch.float32)).numpy()
        assert np.abs(exact - want).max() > 1e-4


def test_gradients_pass_the_rounding():
    """Straight-through: a loss on the int8 forward has a gradient on every weight and bias."""
    rng = np.random.default_rng(4)
    weights = _random_weights(rng, ([20, 32, 6], [6, 16, 5]), 20)
    model = qat.Model(weights)
    model.calibrate(rng.normal(size=(100, 20)), 100.0)
    z, c = model.step(torch.zeros(4, 6), torch.as_tensor(rng.normal(size=(4, 20)), dtype=torch.float32),
                      (model.lp.quantised(), model.dec.quantised()))
    (c ** 2).sum().backward()
    for p in list(model.lp.parameters()) + list(model.dec.parameters()):
        assert p.grad is not None and float(p.grad.abs().sum()) > 0


@pytest.mark.slow
def test_finetune_writes_an_int8_asset_with_its_calibration(tmp_path):
    """On the shipped t-shirt, a short fine-tune: the loss against the float model falls, and the asset loads as
    int8 with the input scales pleat.quantise gives on the calibration rows written beside it."""
    from pleat import REPO_ROOT
    weights = pa.read_asset((REPO_ROOT / "assets" / "tshirt.pleat").read_bytes())
    tuned, x_norm, report = qat.finetune(weights, frames=1000, iterations=60, batch=32, lr=1e-5, recalibrate=0,
                                         window=8, calibration="motion", learn_scales=False, objective="mse")
    assert report["rms_after_mm"] < report["rms_before_mm"]
    out = tmp_path / "t_int8.pleat"
    qat.write(weights, tuned, x_norm, report, out)
    loaded = pa.read_asset(out.read_bytes())
    assert np.asarray(loaded["lp.0.weight"]).dtype == np.int8
    with np.load(out.with_suffix(".calibration.npz")) as z:
        raw = z[pq.CALIBRATION_KEY]
    again, _ = pq.quantise(tuned, pq.normalised_inputs(weights, raw), 100.0)
    for i in range(3):
        assert np.isclose(float(np.asarray(loaded[f"lp.{i}.input_scale"]).ravel()[0]),
                          float(np.asarray(again[f"lp.{i}.input_scale"]).ravel()[0]), rtol=1e-5)


@pytest.mark.slow
def test_learnt_input_scales_are_the_ones_written(tmp_path):
    """--learn-scales: each layer's input scale is a parameter of the fine-tune (LSQ); the asset stores the learnt
    scales, not the calibration's."""
    from pleat import REPO_ROOT
    weights = pa.read_asset((REPO_ROOT / "assets" / "tshirt.pleat").read_bytes())
    tuned, x_norm, report = qat.finetune(weights, frames=400, iterations=15, batch=16, lr=1e-5,
                                         calibration="random", learn_scales=True)
    out = tmp_path / "t_lsq.pleat"
    qat.write(weights, tuned, x_norm, report, out)
    loaded = pa.read_asset(out.read_bytes())
    calibrated, _ = pq.quantise(tuned, x_norm, 100.0)
    moved = 0
    for prefix, scales in report["input_scales"].items():
        for i, v in enumerate(scales):
            stored = float(np.asarray(loaded[f"{prefix}.{i}.input_scale"]).ravel()[0])
            assert stored == pytest.approx(v, rel=1e-6)
            moved += stored != pytest.approx(float(np.asarray(calibrated[f"{prefix}.{i}.input_scale"]).ravel()[0]),
                                             rel=1e-4)
    assert moved > 0
