"""int8 networks (asset 1.3): pleat.quantise, the writer and reader, pleat-pack --int8, the numpy reference's integer
arithmetic. The C kernels against these bits: tests/c/test_int8_matches_reference.c."""
import json

import numpy as np
import pytest

from pleat import asset as pa
from pleat import pack
from pleat import quantise as pq
from pleat.reference.golden import random_weights
from pleat.reference.mlp import FIRST_INPUT, HIDDEN_INPUT, int8_layers, layers, mlp, mlp_int8, quantise


@pytest.fixture(scope="module")
def weights():
    return random_weights(vertices=100, latent=8, blend=6, lp_hidden=(40, 33), dec_hidden=(12,), seed=5)


def test_quantise_rounds_half_to_even_clamps_and_sends_nan_to_the_low_bound():
    q = quantise(np.array([0.5, 1.5, 2.5, -2.5, 126.5, 300, -300, np.nan, np.inf], np.float32), 1.0)
    assert q.tolist() == [0, 2, 2, -2, 126, 127, -127, -127, 127]
    q = quantise(np.array([2046.5, 5000, -5000, np.nan], np.float32), 1.0, FIRST_INPUT)
    assert q.tolist() == [2046, 2047, -2047, -2047]
    q = quantise(np.array([-3, 0.5, 128.5, 300, np.nan], np.float32), 1.0, HIDDEN_INPUT)
    assert q.tolist() == [0, 0, 128, 255, 0]


def test_int8_asset_round_trips_and_is_version_1_3(weights):
    q, record = pq.quantise(weights)
    data = pa.write_asset(None, q)
    header, sections = pa.inspect_asset(data)
    assert header["version"] == (1, 3) and header["flags"] & pa.FLAG_INT8
    by = {s["fourcc"]: s for s in sections}
    assert by["LPW0"]["dtype"] == pa.DTYPE_I8 and by["LPS0"]["dims"] == (40,) and by["LPA0"]["dims"] == (1,)
    assert header["flags"] & pa.FLAG_INT8_RANGED_INPUTS and record["inputs"] == "ranged"   # ReLU networks
    back = pa.read_asset(data)
    for key in ("lp.0.weight", "lp.1.weight_scale", "dec.0.input_scale", "dec.1.bias"):
        assert np.array_equal(back[key], np.asarray(q[key]).astype(back[key].dtype))
    assert back["int8_ranged_inputs"]
    assert int(np.abs(back["lp.0.weight"]).max()) == 127           # each row's largest weight maps to ±127
    assert len(record["input_ranges"]["lp"]) == 3 and len(record["input_ranges"]["dec"]) == 2
    # a first layer's input over ±2047 steps, a hidden layer's (never negative) over 0..255
    assert back["lp.0.input_scale"][0] == pytest.approx(record["input_ranges"]["lp"][0] / 2047, rel=1e-5)
    assert back["lp.1.input_scale"][0] == pytest.approx(record["input_ranges"]["lp"][1] / 255, rel=1e-5)
    symmetric, _ = pq.quantise(weights, ranged=False)
    header, _ = pa.inspect_asset(pa.write_asset(None, symmetric))
    assert header["flags"] & pa.FLAG_INT8 and not header["flags"] & pa.FLAG_INT8_RANGED_INPUTS
    assert "int8_ranged_inputs" not in pa.read_asset(pa.write_asset(None, symmetric))
    # a float asset stays 1.2, byte for byte what the writer made before int8 existed
    assert pa.inspect_asset(pa.write_asset(None, weights))[0]["version"] == (1, 2)


def test_int8_network_tracks_the_float_one(weights):
    """Post-training quantisation keeps the outputs near the float network's on calibration-like inputs."""
    stored = pa.read_asset(pa.write_asset(None, weights))
    x = pq.normalised_inputs(stored, count=256, seed=3)
    q, _ = pq.quantise(stored, x)
    want = mlp(x, *layers(stored, "lp"), stored["lp_activation"])
    got = mlp_int8(x, int8_layers(q, "lp"), q["lp_activation"])
    assert np.abs(got - want).max() < 0.05 * np.abs(want).max()
    # the ranged inputs are the point: more steps where the values are, less error than the symmetric scheme
    s, _ = pq.quantise(stored, x, ranged=False)
    symmetric = mlp_int8(x, int8_layers(s, "lp"), s["lp_activation"])
    assert np.abs(got - want).mean() < 0.75 * np.abs(symmetric - want).mean()


@pytest.mark.parametrize("ranged, index, bounds", [(False, 0, (-127, 127)), (True, 0, (-2047, 2047)),
                                                   (True, 1, (0, 255))])
def test_int8_layer_is_integer_arithmetic(weights, ranged, index, bounds):
    """One layer by hand: quantise within the layer's bounds, int sum, two float32 roundings, the bias."""
    q, _ = pq.quantise(weights, ranged=ranged)
    layer = int8_layers(q, "dec")[index]
    assert layer["input_bounds"] == bounds
    z = 3 * np.random.default_rng(0).standard_normal((4, layer["weight"].shape[1])).astype(np.float32)
    v = np.clip(z.astype(np.float32) * (np.float32(1) / layer["input_scale"]), *bounds)
    acc = np.rint(v).astype(np.int64) @ layer["weight"].astype(np.int64).T
    want = (acc.astype(np.float32) * (layer["weight_scale"] * layer["input_scale"])) + layer["bias"]
    got = mlp_int8(z, [layer], "relu")
    assert got.dtype == np.float32 and np.array_equal(got, want.astype(np.float32))


def test_ranged_inputs_need_relu_networks(weights):
    """A SiLU network's hidden inputs can be negative: quantised as never negative they would be wrong, so the
    quantiser falls back to symmetric inputs, and neither it, the writer nor the reader take ranged ones."""
    silu = dict(weights, lp_activation="silu")
    q, record = pq.quantise(silu)
    assert record["inputs"] == "symmetric" and not q["int8_ranged_inputs"]
    with pytest.raises(ValueError, match="ReLU"):
        pq.quantise(silu, ranged=True)
    with pytest.raises(pa.AssetError, match="ReLU"):
        pa.write_asset(None, dict(q, int8_ranged_inputs=True))
    # a float dict derived from a ranged int8 one (e.g. networks replaced) is written as the float asset it is
    header, _ = pa.inspect_asset(pa.write_asset(None, dict(weights, int8_ranged_inputs=True)))
    assert header["flags"] & (pa.FLAG_INT8 | pa.FLAG_INT8_RANGED_INPUTS) == 0
    data = bytearray(pa.write_asset(None, q))                       # the flag set on the SiLU file by hand
    data[28] |= pa.FLAG_INT8_RANGED_INPUTS
    with pytest.raises(pa.AssetError, match="ReLU"):
        pa.read_asset(bytes(data), verify_checksum=False)


def test_writer_refuses_what_the_runtime_refuses(weights):
    q, _ = pq.quantise(weights)
    bad = dict(q)
    bad["lp.1.weight"] = q["lp.1.weight"].copy()
    bad["lp.1.weight"][0, 0] = -128
    with pytest.raises(pa.AssetError, match="-128"):
        pa.write_asset(None, bad)
    bad = dict(q, **{"dec.0.weight_scale": np.zeros_like(q["dec.0.weight_scale"])})
    with pytest.raises(pa.AssetError, match="positive"):
        pa.write_asset(None, bad)
    bad = dict(q, **{"lp.1.weight": np.asarray(weights["lp.1.weight"], np.float32)})        # one float layer in an int8 network
    with pytest.raises(pa.AssetError, match="int8"):
        pa.write_asset(None, bad)
    with pytest.raises(ValueError, match="int8 already"):
        pq.quantise(q)


def test_pack_int8_with_calibration_rows_and_onnx(tmp_path, weights):
    src = tmp_path / "w.npz"
    pa.save_weights(src, weights)
    rows = tmp_path / "calibration.npz"
    I = len(weights["x_mean"])
    np.savez(rows, x_c=np.asarray(weights["x_mean"]) + np.random.default_rng(1).standard_normal((64, I)))
    out = tmp_path / "a.pleat"
    assert pack.main([str(src), "-o", str(out), "--int8", "--fp16", "--calibration", str(rows), "--onnx",
                      "--quiet"]) == 0
    data = out.read_bytes()
    header, _ = pa.inspect_asset(data)
    assert header["flags"] == pa.FLAG_INT8 | pa.FLAG_INT8_RANGED_INPUTS | pa.FLAG_FP16   # fp16 blend shapes
    back = pa.read_asset(data)
    assert back["lp.0.weight"].dtype == np.int8 and back["blend_shapes"].dtype == np.float16
    assert back["onnx_latent_predictor"] == pa.read_asset(pa.write_asset(None, weights, onnx=True))[
        "onnx_latent_predictor"]                                          # the float networks it came from
    meta = json.loads(back["metadata_json"])
    assert meta["int8"]["rows"] == 64 and meta["int8"]["calibration"] == "calibration.npz"
    assert pack.main([str(src), "-o", str(tmp_path / "b.pleat"), "--precision", "int8", "--quiet"]) == 0
    assert pa.read_asset((tmp_path / "b.pleat").read_bytes())["lp.0.weight"].dtype == np.int8
    assert pack.main([str(src), "-o", str(tmp_path / "c.pleat"), "--int8", "--symmetric-inputs", "--quiet"]) == 0
    flags = pa.inspect_asset((tmp_path / "c.pleat").read_bytes())[0]["flags"]
    assert flags & pa.FLAG_INT8 and not flags & pa.FLAG_INT8_RANGED_INPUTS
    with pytest.raises(SystemExit):
        pack.main([str(src), "-o", str(tmp_path / "d.pleat"), "--symmetric-inputs", "--quiet"])


def test_reference_instance_steps_an_int8_asset(weights):
    """The numpy reference runtime runs the integer networks where the asset's are int8 (and float ones elsewhere)."""
    from pleat.reference.golden import random_motion
    from pleat.reference.instance import Instance
    q, _ = pq.quantise(weights)
    asset = pa.read_asset(pa.write_asset(None, q))
    inst = Instance(asset)
    assert inst.lp_int8 is not None and inst.dec_int8 is not None
    rotations, root_translation, root_rotation, dt_s = random_motion(4, len(asset["joint_parents"]), 0)
    for t in range(4):
        positions, normals = inst.step(rotations[t], root_translation[t], root_rotation[t], dt_s[t])
        assert np.all(np.isfinite(positions)) and inst.last_result == "ok"
