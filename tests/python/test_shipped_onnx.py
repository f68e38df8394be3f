"""The shipped garments carry their networks as ONNX too (OXLP/OXDC), and the ONNX Runtime backend, given those,
steps them like Pleat's own MLPs."""
from pathlib import Path

import numpy as np
import pytest

from pleat import asset as pa

ROOT = Path(__file__).resolve().parents[2]
GARMENTS = ("tshirt", "dress")


@pytest.fixture(params=GARMENTS)
def shipped(request):
    path = ROOT / "assets" / f"{request.param}.pleat"
    if not path.exists():
        pytest.skip(f"{path.name} absent")
    return path


def test_shipped_asset_has_onnx_sections(shipped):
    w = pa.read_asset(shipped.read_bytes())
    assert len(w.get("onnx_latent_predictor") or b"") > 1000
    assert len(w.get("onnx_decoder") or b"") > 1000


def test_shipped_asset_through_onnxruntime_matches_the_cpu_backend(c_runtime, shipped):
    runtime = c_runtime
    ort = pytest.importorskip("onnxruntime")
    libs = sorted((Path(ort.__file__).parent / "capi").glob("libonnxruntime.so*"))
    if not libs:
        pytest.skip("no libonnxruntime.so in the onnxruntime wheel")
    data = shipped.read_bytes()
    w = pa.read_asset(data)
    J = len(w["joint_names"])
    rng = np.random.default_rng(3)
    # a smooth made-up motion: every joint swinging about a random axis, the root walking forward
    axes = rng.normal(size=(J, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    frames = 40
    out = {}
    with runtime.Context() as ctx:
        asset = ctx.load_asset(data)
        for backend in ("pleat", "onnxruntime"):
            kw = {"onnxruntime_library": libs[0]} if backend == "onnxruntime" else {}
            try:
                inst = ctx.create_instance(asset, backend=backend, **kw)
            except runtime.PleatError as e:
                if e.name != "PLEAT_RESULT_BACKEND_UNAVAILABLE":
                    raise
                pytest.skip(f"ONNX Runtime backend unavailable: {e}")
            pos = []
            for t in range(frames):
                angle = 0.4 * np.sin(0.2 * t + np.arange(J))[:, None]
                q = np.concatenate([axes * np.sin(angle / 2), np.cos(angle / 2)], 1)
                p, _ = inst.step(q, np.array([0.0, 0.9, 0.03 * t]), np.array([0.0, 0.0, 0.0, 1.0]), 1 / 30)
                assert inst.last_result in (0, 1), f"{backend} frame {t}: result {inst.last_result}"
                pos.append(p.copy())
            inst.close()
            out[backend] = np.array(pos)
    # both backends read the same fp16-rounded weights (ONNX sections hold them as fp32); float32 GEMMs summed in
    # different orders through a 40-step recurrence: agreement to 0.5 mm, and the networks do move the garment
    assert np.abs(out["pleat"] - out["onnxruntime"]).max() < 5e-4
