"""int8 blend shapes (asset 1.4): pleat.quantise.quantise_blend_shapes, the writer and reader, pleat-pack
--int8-blend-shapes, and the C runtime against the float asset holding the same values. The kernels against each other:
tests/c/test_simd_matches_scalar.c, test_batched_kernels_match_single.c, test_batch_step_matches_single.c (a crowd bit
for bit) and test_gpu_mode_matches_cpu.c (the GL path)."""
import json
import struct

import numpy as np
import pytest

from pleat import asset as pa
from pleat import pack
from pleat import quantise as pq
from pleat.reference.golden import random_weights


@pytest.fixture(scope="module")
def weights():
    w = random_weights(vertices=150, latent=8, blend=7, lp_hidden=(24,), dec_hidden=(16,), seed=9)
    w["blend_shapes"] = np.asarray(w["blend_shapes"], np.float32)
    w["blend_shapes"][3] = 0.0                                     # an all-zero shape: scale 1, every q 0
    w["blend_shapes"][5] *= 40.0                                   # shapes of very different sizes
    return w


def test_each_shape_gets_its_own_scale_and_the_values_are_what_the_runtime_reads(weights):
    q, record = pq.quantise_blend_shapes(weights)
    d = np.asarray(weights["blend_shapes"], np.float64)
    scales = q["blend_shape_scales"]
    assert q["blend_shapes_int8"].dtype == np.int8 and scales.dtype == np.float32
    assert scales[3] == 1.0 and not q["blend_shapes_int8"][3].any()
    for j in (0, 1, 2, 4, 5, 6):
        assert scales[j] == pytest.approx(np.abs(d[j]).max() / 127, rel=1e-6)
        assert int(np.abs(q["blend_shapes_int8"][j]).max()) == 127          # the largest element maps to ±127
    assert int(q["blend_shapes_int8"].min()) >= -127
    values = q["blend_shapes_int8"].astype(np.float32) * scales[:, None, None]
    assert np.array_equal(q["blend_shapes"], values)                         # float32((float)q · s), one rounding
    error = np.abs(q["blend_shapes"] - d)
    assert np.all(error <= 0.5 * scales[:, None, None] * (1 + 1e-5))          # half a step at most
    assert record["max_element_error_m"] == pytest.approx(error.max())


def test_int8_blend_shapes_round_trip_as_version_1_4_and_refuse_what_the_runtime_refuses(weights):
    q, _ = pq.quantise_blend_shapes(weights)
    data = pa.write_asset(None, q, fp16=True)
    header, sections = pa.inspect_asset(data)
    by = {s["fourcc"]: s for s in sections}
    assert header["version"] == (1, 4) and header["flags"] == pa.FLAG_FP16 | pa.FLAG_INT8_BLEND_SHAPES
    assert by["BLND"]["dtype"] == pa.DTYPE_I8 and by["BLSC"]["dims"] == (7,)
    assert by["LPW0"]["dtype"] == pa.DTYPE_F16                                # fp16 networks beside them
    back = pa.read_asset(data)
    assert np.array_equal(back["blend_shapes_int8"], q["blend_shapes_int8"])
    assert np.array_equal(back["blend_shape_scales"], q["blend_shape_scales"])
    assert np.array_equal(back["blend_shapes"], q["blend_shapes"])
    assert pa.write_asset(None, back, fp16=True) == data                      # a repack changes nothing
    bad = bytearray(data)                                                     # a zero scale
    bad[by["BLSC"]["offset"]:by["BLSC"]["offset"] + 4] = struct.pack("<f", 0.0)
    with pytest.raises(pa.AssetError):
        pa.read_asset(bytes(bad), verify_checksum=False)
    bad = bytearray(data)                                                     # -128: outside the symmetric range
    bad[by["BLND"]["offset"]] = 0x80
    with pytest.raises(pa.AssetError):
        pa.read_asset(bytes(bad), verify_checksum=False)
    with pytest.raises(pa.AssetError, match="blend_shape_scales"):
        pa.write_asset(None, dict(q, blend_shape_scales=q["blend_shape_scales"][:3]))
    with pytest.raises(pa.AssetError, match="quantise them again"):        # floats changed, int8 keys stale
        pa.write_asset(None, dict(q, blend_shapes=q["blend_shapes"] * 1.5))


def test_the_c_runtime_reads_int8_blend_shapes_as_the_float_asset_of_the_same_values(weights, tmp_path):
    """The runtime folds each shape's scale into its weight, (w · s) · q, where the float twin computes w · (q · s):
    a rounding apart, over frames (blend shapes do not feed back into the networks); a NaN scale is refused."""
    runtime = pytest.importorskip("pleat.runtime")
    q, _ = pq.quantise_blend_shapes(weights)
    twin = {k: v for k, v in q.items() if k not in ("blend_shapes_int8", "blend_shape_scales")}
    rng = np.random.default_rng(0)
    with runtime.Context() as ctx:
        runs = []
        for w in (q, twin):
            inst = ctx.create_instance(ctx.load_asset(pa.write_asset(None, w)))
            frames = []
            for t in range(12):
                rot = np.tile([0.0, 0.0, 0.0, 1.0], (inst.joint_count, 1)) + 0.05 * rng.normal(
                    size=(inst.joint_count, 4))
                rot /= np.linalg.norm(rot, axis=1, keepdims=True)
                frames.append(inst.step(rot, [0.01 * t, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 1 / 30)[0])
            inst.close()
            rng = np.random.default_rng(0)
            runs.append(np.array(frames))
        offsets = np.abs(runs[1] - np.asarray(twin["template"])[None]).max()
        assert offsets > 1e-3                                                # the blend shapes move the sheet
        assert np.abs(runs[0] - runs[1]).max() < 1e-6
        bad = bytearray(pa.write_asset(None, q))
        s = {x["fourcc"]: x for x in pa.inspect_asset(bytes(bad))[1]}["BLSC"]
        bad[s["offset"]:s["offset"] + 4] = struct.pack("<f", float("nan"))
        struct.pack_into("<I", bad, pa.CHECKSUM_OFFSET, pa.checksum(bytes(bad)))
        with pytest.raises(runtime.PleatError) as e:
            ctx.load_asset(bytes(bad))
        assert e.value.name == "PLEAT_RESULT_INVALID_ASSET_DATA"


def test_pack_int8_blend_shapes_records_them_in_meta(weights, tmp_path, capsys):
    src = tmp_path / "in.pleat"
    pa.write_asset(src, dict(weights, metadata_json=json.dumps({"garment": "sheet"})))
    out = tmp_path / "out.pleat"
    assert pack.main([str(src), "-o", str(out), "--fp16", "--int8-blend-shapes", "--quiet"]) == 0
    back = pa.read_asset(out.read_bytes())
    meta = json.loads(back["metadata_json"])
    assert meta["garment"] == "sheet" and meta["int8_blend_shapes"]["max_element_error_m"] > 0
    assert back["blend_shapes_int8"].dtype == np.int8
    assert pack.info(out) == 0 and "(int8 blend shapes)" in capsys.readouterr().out
    again = tmp_path / "again.pleat"                                           # a repack keeps them as they are
    assert pack.main([str(out), "-o", str(again), "--fp16", "--int8-blend-shapes", "--quiet"]) == 0
    assert np.array_equal(pa.read_asset(again.read_bytes())["blend_shapes_int8"], back["blend_shapes_int8"])


def test_lbs_only_twin_of_an_int8_shapes_asset_has_no_blend_shapes(weights):
    """pleat-eval's LBS-only baseline drops the network and the blend shapes, int8 ones included."""
    from pleat.eval import scene as S
    q, _ = pq.quantise_blend_shapes(weights)
    twin = pa.read_asset(S.lbs_only_bytes(pa.read_asset(pa.write_asset(None, q))))
    assert twin["blend_shapes"].shape[0] == 1 and not twin["blend_shapes"].any()
    assert "blend_shapes_int8" not in twin


def test_the_numpy_reference_folds_the_scales_as_the_runtime_does(weights):
    """pleat.reference.Instance on an int8-shapes asset: the int8 q with (w · s) folded in float32, as
    plFoldShapeScales; it tracks the C runtime to rounding."""
    runtime = pytest.importorskip("pleat.runtime")
    from pleat.reference import Instance
    from pleat.reference.blend_shapes import fold_shape_scales
    q, _ = pq.quantise_blend_shapes(weights)
    data = pa.write_asset(None, q)
    stored = pa.read_asset(data)
    w = np.array([0.5, -1.25, 3.0], np.float32)
    assert np.array_equal(fold_shape_scales(w, stored["blend_shape_scales"][:3]),
                          (w * stored["blend_shape_scales"][:3]).astype(np.float32))
    ref = Instance(stored)
    rng = np.random.default_rng(1)
    with runtime.Context() as ctx:
        inst = ctx.create_instance(ctx.load_asset(data))
        for t in range(6):
            rot = np.tile([0.0, 0.0, 0.0, 1.0], (inst.joint_count, 1)) + 0.05 * rng.normal(size=(inst.joint_count, 4))
            rot /= np.linalg.norm(rot, axis=1, keepdims=True)
            c_pos = inst.step(rot, [0.01 * t, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 1 / 30)[0]
            r_pos = ref.step(rot, [0.01 * t, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 1 / 30)[0]
            assert np.abs(c_pos - r_pos).max() < 2e-5, t
        inst.close()
