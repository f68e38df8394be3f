"""The GPU backend (PLEAT_MLP_BACKEND_GPU: both networks as GLSL compute beside the deformation, docs/gpu.md
"Networks on the GPU") steps the shipped garments like the CPU backend, through the Python binding, on whatever GL
the machine has (Mesa llvmpipe here); int8 networks stay on the CPU and the GPU backend says so."""
from pathlib import Path

import numpy as np
import pytest

from pleat import asset as pa
from pleat import quantise as pq
from pleat.reference.golden import random_weights

ROOT = Path(__file__).resolve().parents[2]


def _instance_or_skip(runtime, ctx, asset, **kw):
    try:
        return ctx.create_instance(asset, **kw)
    except runtime.PleatError as e:
        if e.name == "PLEAT_RESULT_GL_UNAVAILABLE":
            pytest.skip(f"no GL 4.3 context here: {e}")
        raise


def _shipped(garment):
    """The shipped garment's bytes and a swing of its joints: swing(t, amplitude, speed) gives frame t's rotations,
    every joint about its own random axis."""
    path = ROOT / "assets" / f"{garment}.pleat"
    if not path.exists():
        pytest.skip(f"{path.name} absent")
    data = path.read_bytes()
    J = len(pa.read_asset(data)["joint_names"])
    axes = np.random.default_rng(3).normal(size=(J, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)

    def swing(t, amplitude, speed):
        angle = amplitude * np.sin(speed * t + np.arange(J))[:, None]
        return np.concatenate([axes * np.sin(angle / 2), np.cos(angle / 2)], 1)
    return data, swing


@pytest.mark.parametrize("garment", ["tshirt", "dress"])
def test_shipped_garment_on_gpu_networks_matches_the_cpu_backend(c_runtime, garment):
    runtime = c_runtime
    data, swing = _shipped(garment)
    frames = 12
    out, latents = {}, {}
    with runtime.Context() as ctx:
        asset = ctx.load_asset(data)
        for backend, gpu in (("pleat", "none"), ("gpu", "headless")):
            inst = _instance_or_skip(runtime, ctx, asset, backend=backend, gpu=gpu)
            pos = []
            for t in range(frames):
                q = swing(t, 0.4, 0.3)
                p, _ = inst.step(q, np.array([0.0, 0.9, 0.05 * t]), np.array([0.0, 0.0, 0.0, 1.0]), 1 / 30)
                assert inst.last_result in (0, 1), f"{backend} frame {t}: result {inst.last_result}"
                pos.append(p.copy())
            latents[backend] = np.array(inst.latent)
            inst.close()
            out[backend] = np.array(pos)
    # the same fp16 weights, the sums in another order, through a 12-step recurrence: within 20 µm, while the
    # networks do move the garment (the first frame against the last)
    diff = np.abs(out["pleat"] - out["gpu"]).max()
    print(f"{garment}: max position difference {diff:.3g} m, latent {np.abs(latents['pleat'] - latents['gpu']).max():.3g}")
    assert diff < 2e-5, diff
    assert np.abs(latents["pleat"] - latents["gpu"]).max() < 3e-5
    assert np.abs(out["gpu"][-1] - out["gpu"][0]).max() > 1e-2


@pytest.mark.slow
@pytest.mark.parametrize("garment", ["tshirt", "dress", "pants", "tank_top", "long_sleeve"])
def test_long_run_on_gpu_networks_stays_with_the_cpu_backend(c_runtime, garment):
    """300 frames of swinging joints and a walking, turning root: the two backends' difference, fed back through the
    latent every frame, stays within 0.1 mm (llvmpipe: at most 3.2e-5 m over the five garments, reached anywhere in the
    run, not growing with it)."""
    runtime = c_runtime
    data, swing = _shipped(garment)
    with runtime.Context() as ctx:
        asset = ctx.load_asset(data)
        cpu = ctx.create_instance(asset, backend="pleat")
        gpu = _instance_or_skip(runtime, ctx, asset, backend="gpu", gpu="headless")
        worst = []
        for t in range(300):
            q = swing(t, 0.6, 0.15)
            root = np.array([0.3 * np.sin(0.05 * t), 0.9, 0.04 * t])
            turn = np.array([0.0, np.sin(0.01 * t), 0.0, np.cos(0.01 * t)])
            a, _ = cpu.step(q, root, turn, 1 / 30)
            b, _ = gpu.step(q, root, turn, 1 / 30)
            worst.append(np.abs(a - b).max())
        cpu.close()
        gpu.close()
    assert max(worst) < 1e-4, max(worst)


def test_shared_instances_step_like_their_own(c_runtime):
    """gpu_share: a second t-shirt on the first one's GPU data (and headless context) gives the same outputs as one
    with its own copy."""
    runtime = c_runtime
    data = (ROOT / "assets" / "tshirt.pleat").read_bytes()
    J = len(pa.read_asset(data)["joint_names"])
    q = np.tile([0.0, 0.0, 0.0, 1.0], (J, 1))
    with runtime.Context() as ctx:
        asset = ctx.load_asset(data)
        first = _instance_or_skip(runtime, ctx, asset, backend="gpu", gpu="headless")
        alone = ctx.create_instance(asset, backend="gpu", gpu="headless")
        shared = ctx.create_instance(asset, backend="gpu", gpu="headless", gpu_share=first)
        for t in range(4):
            root = np.array([0.0, 0.9, 0.05 * t])
            a, _ = alone.step(q, root, np.array([0.0, 0.0, 0.0, 1.0]), 1 / 30)
            b, _ = shared.step(q, root, np.array([0.0, 0.0, 0.0, 1.0]), 1 / 30)
            assert np.array_equal(a, b)
        for inst in (first, alone, shared):
            inst.close()


def test_gpu_backend_refuses_int8_networks(c_runtime):
    runtime = c_runtime
    w = random_weights(vertices=100, latent=8, blend=6, lp_hidden=(40, 33), dec_hidden=(12,), seed=5)
    q, _ = pq.quantise(w)
    with runtime.Context() as ctx:
        asset = ctx.load_asset(pa.write_asset(None, q))
        with pytest.raises(runtime.PleatError) as failure:
            inst = _instance_or_skip(runtime, ctx, asset, backend="gpu", gpu="headless")
            inst.close()
        assert failure.value.name == "PLEAT_RESULT_BACKEND_UNAVAILABLE"
        with pytest.raises(runtime.PleatError) as failure:
            ctx.create_instance(asset, backend="gpu")             # no GPU mode
        assert failure.value.name == "PLEAT_RESULT_INVALID_DEF"
