"""Quality tiers distilled from a stage-1 teacher (pleat.train.distill, docs/pareto.md), on a tiny stand-in teacher:
an untrained tiny Φ with centimetre-scale blend shapes, so that its garment moves with the pose. The tier must
reproduce the teacher's displacements better than zero (LBS) does, pack with the training pack code, and run in the
numpy reference and the C runtime with the same garment.

Skips without PyTorch."""
import json

import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="PyTorch not installed (pip install 'pleat-tools[train]')")

from pleat.eval import tiers  # noqa: E402
from pleat.train import core, distill  # noqa: E402

SPEC = tiers.Tier("test", vertices=0, latent=8, blend=8, lp_hidden=(64,), dec_hidden=(32,))


@pytest.fixture(scope="module")
def teacher(tmp_path_factory):
    cfg = core.load_config("tiny", overrides={"model.blend_init_m": 0.01, "clips.train_limit": 2,
                                              "clips.frames_limit": 40})
    torch.manual_seed(0)
    setup = core.Setup(cfg, "tshirt", "cpu")
    model = core.Stage1Model(setup)
    run = tmp_path_factory.mktemp("teacher")
    torch.save({"config": cfg, "garment": "tshirt", "model": model.state_dict()}, run / "stage1.pt")
    seqs, setup, _ = distill.record(run, sequences=4, frames=24, seed=0)
    return run, seqs, setup


@pytest.fixture(scope="module")
def tier(teacher):
    run, seqs, setup = teacher
    return distill.distill(seqs, setup, SPEC, val_seqs=seqs[:1], seed=0, iterations=300, dec_iterations=300,
                           batch=32, window=4)


def test_recorded_teacher_displacements_are_its_blend_shapes_at_its_latents(teacher):
    _, seqs, setup = teacher
    assert len(seqs) == 4
    for s in seqs:
        assert s["disp"].shape == (len(s["z"]), setup.N, 3)
        assert s["static"].shape[0] == len(s["z"])
    # the stand-in teacher moves the garment, and differently from frame to frame
    d = np.concatenate([s["disp"] for s in seqs])
    assert np.abs(d).max() > 1e-3 and d.std(0).max() > 1e-5


def test_principal_shapes_reproduce_the_displacements_they_span(teacher):
    _, seqs, _ = teacher
    shapes, sigma, Vt, energy = distill.principal_shapes(seqs, 200)
    X = np.concatenate([s["disp"].reshape(len(s["disp"]), -1) for s in seqs])
    # the teacher's displacements live in the span of its 16 blend shapes: at most 16 directions are kept, exactly
    assert len(sigma) <= 16 and energy == pytest.approx(1.0, abs=1e-9)
    np.testing.assert_allclose(X @ Vt.T @ Vt, X, atol=1e-8)   # float32 teacher
    np.testing.assert_allclose(shapes.reshape(len(sigma), -1), sigma[:, None] * Vt)
    assert np.all(np.diff(sigma) <= 1e-12)


def test_tier_approximates_the_teacher_better_than_zero(tier):
    *_, report = tier
    assert report["latent"] == 8 and report["blend"] == 8
    # free-running from Z'_0 = 0, as the runtime runs it
    assert report["train"]["rms_mm"] < 0.5 * report["train"]["rms_zero_mm"]
    assert report["validation"]["rms_mm"] < report["validation"]["rms_zero_mm"]


def test_barycentric_transfer_interpolates_on_the_source_mesh(teacher):
    _, _, setup = teacher
    P = distill.barycentric_transfer(setup.template, setup.faces, setup.template)
    np.testing.assert_allclose(P @ setup.template, setup.template, atol=1e-9)
    tri = setup.template[setup.faces[:5]]
    points = tri.mean(1)
    P = distill.barycentric_transfer(setup.template, setup.faces, points)
    np.testing.assert_allclose(np.asarray(P.sum(1)).ravel(), 1.0)
    f = np.random.default_rng(0).normal(size=setup.N)
    np.testing.assert_allclose(P @ f, f[setup.faces[:5]].mean(1), atol=1e-6)


def test_packed_tier_runs_in_the_reference_and_the_c_runtime(tier, teacher, tmp_path):
    from pleat import reference
    from pleat.asset import read_asset
    from pleat.eval import scene as S
    _, _, setup = teacher
    lp, block, norms, shim, garment, report = tier
    path = tmp_path / "tshirt_test.pleat"
    distill.pack_tier(path, lp, block, norms, shim, garment, setup, report, 30.0, fp16=True)
    data = path.read_bytes()
    asset = read_asset(data)
    meta = json.loads(asset["metadata_json"])
    assert meta["tier"] == "test" and "distilled" in meta["model"]
    assert len(asset["z_min"]) == 8 and asset["blend_shapes"].shape == (8, setup.N, 3)

    clip = core.sources.clips("validation", 30.0, 1, 20, setup.body)[0]
    dt = np.full(len(clip.rotations), 1.0 / clip.fps)
    inst = reference.Instance(asset)
    ref = np.stack([inst.step(clip.rotations[f], clip.root_translation[f], clip.root_rotation[f], dt[f])[0]
                    for f in range(len(dt))])
    lbs = reference.Instance(S.lbs_only_weights(asset))
    ref_lbs = np.stack([lbs.step(clip.rotations[f], clip.root_translation[f], clip.root_rotation[f], dt[f])[0]
                        for f in range(len(dt))])
    assert np.all(np.isfinite(ref)) and np.abs(ref - ref_lbs).max() > 1e-3   # the tier moves the garment

    from pleat import runtime
    if runtime.find_library() is None:
        pytest.skip("libpleat.so not built: C runtime comparison skipped")
    with runtime.Context() as ctx:
        c_asset = ctx.load_asset(data)
        c_inst = ctx.create_instance(c_asset)
        c_pos = np.stack([c_inst.step(clip.rotations[f], clip.root_translation[f], clip.root_rotation[f], dt[f])[0]
                          for f in range(len(dt))])
    np.testing.assert_allclose(c_pos, ref, atol=5e-4)
