"""The latent's velocity components (simsup.latent_velocity; pleat.train.distill.tier_sequences): K latent components
after the L coefficients carry the change of the K largest since the previous frame, scaled to unit RMS, zero at a
sequence's first frame; a fit with them packs a network K components wider that the C runtime runs like any other.

Skips without PyTorch."""
import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="PyTorch not installed (pip install 'pleat-tools[train]')")

from pleat.eval import tiers  # noqa: E402
from pleat.train import core, distill  # noqa: E402

SPEC = tiers.Tier("test", vertices=0, latent=6, blend=6, lp_hidden=(32,), dec_hidden=(16,))


def _sequences(rng, N, inputs, count=3, T=10):
    """Displacements that move from frame to frame, on random X_c rows (latent block of width 2)."""
    shapes = rng.normal(size=(6, N, 3)) * 0.01
    seqs = []
    for _ in range(count):
        w = np.cumsum(rng.normal(size=(T, 6)), 0)
        seqs.append({"static": rng.normal(size=(T, inputs)), "disp": np.einsum("tk,knc->tnc", w, shapes)})
    return seqs


def test_velocity_components_are_the_scaled_change_of_the_largest_coefficients():
    rng = np.random.default_rng(0)
    seqs = _sequences(rng, N=5, inputs=9)
    shapes, sigma, Vt, _ = distill.principal_shapes(seqs, 6)
    K, L = 3, 4
    scale = distill.velocity_scale(seqs, Vt, sigma, K)
    plain = distill.tier_sequences(seqs, Vt, sigma, L, 2)
    moving = distill.tier_sequences(seqs, Vt, sigma, L, 2, (K, scale))
    for a, b, s in zip(plain, moving, seqs):
        np.testing.assert_array_equal(b["z"][:, :L], a["z"])                  # the coefficients are unchanged
        c = distill.coefficients(s, Vt, sigma)
        np.testing.assert_allclose(b["z"][1:, L:] * scale, c[1:, :K] - c[:-1, :K], atol=1e-12)
        assert not b["z"][0, L:].any()                                          # a reset has no velocity
        assert b["static"].shape[1] == a["static"].shape[1] + K                 # the latent block is K wider
        np.testing.assert_array_equal(b["static"][:, L + K:], s["static"][:, 2:])
    d = np.concatenate([b["z"][1:, L:] for b in moving])
    np.testing.assert_allclose(np.sqrt((d ** 2).mean(0)), 1.0, rtol=1e-9)     # unit RMS, like the coefficients


def test_a_fit_with_latent_velocity_packs_and_runs_in_the_c_runtime(tmp_path):
    """distill with latent_velocity K: the network's latent is L + K wide, packed by the training pack code, and the
    C runtime steps it to the same garment as the numpy reference."""
    from pleat import reference, runtime
    from pleat.asset import read_asset
    cfg = core.load_config("tiny", overrides={"model.blend_init_m": 0.01, "clips.train_limit": 2,
                                              "clips.frames_limit": 40})
    torch.manual_seed(0)
    setup = core.Setup(cfg, "tshirt", "cpu")
    model = core.Stage1Model(setup)
    run = tmp_path / "teacher"
    run.mkdir()
    torch.save({"config": cfg, "garment": "tshirt", "model": model.state_dict()}, run / "stage1.pt")
    seqs, setup, _ = distill.record(run, sequences=3, frames=16, seed=0)
    lp, block, norms, shim, garment, rep = distill.distill(seqs, setup, SPEC, val_seqs=seqs[:1], seed=0,
                                                           iterations=30, dec_iterations=30, batch=16, window=4,
                                                           latent_velocity=2)
    assert rep["latent"] == SPEC.latent + 2 and rep["latent_velocity"] == 2
    assert len(norms["z_mean"]) == SPEC.latent + 2
    path = tmp_path / "tshirt_velocity.pleat"
    distill.pack_tier(path, lp, block, norms, shim, garment, setup, rep, 30.0, fp16=True)
    data = path.read_bytes()
    asset = read_asset(data)
    assert len(asset["z_min"]) == SPEC.latent + 2 and asset["blend_shapes"].shape[0] == SPEC.blend

    clip = core.sources.clips("validation", 30.0, 1, 20, setup.body)[0]
    dt = np.full(len(clip.rotations), 1.0 / clip.fps)
    inst = reference.Instance(asset)
    ref = np.stack([inst.step(clip.rotations[f], clip.root_translation[f], clip.root_rotation[f], dt[f])[0]
                    for f in range(len(dt))])
    assert np.all(np.isfinite(ref))
    if runtime.find_library() is None:
        pytest.skip("libpleat.so not built: C runtime comparison skipped")
    with runtime.Context() as ctx:
        c_inst = ctx.create_instance(ctx.load_asset(data))
        c_pos = np.stack([c_inst.step(clip.rotations[f], clip.root_translation[f], clip.root_rotation[f], dt[f])[0]
                          for f in range(len(dt))])
    np.testing.assert_allclose(c_pos, ref, atol=5e-4)
