"""Two-stage training (pleat.train): schedules, the tiny preset end to end, and the proof that the trained inference
block gives the same garment in torch, in the numpy reference (pleat.reference) and in the C runtime (pleat.runtime).

Skips cleanly without PyTorch (CI installs only the base tools)."""
import json
import os

import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="PyTorch not installed (pip install 'pleat-tools[train]')")

from pleat.train import core  # noqa: E402


def test_schedules_follow_the_paper_scaled_to_the_run():
    cfg = core.load_config("tiny")["stage1"]
    n = cfg["iterations"]
    # autoregressive rollout: one step at first, one more per `rollout_every` of the run, at most five
    assert core.rollout_steps(cfg, 0) == 1
    assert core.rollout_steps(cfg, n - 1) == 5
    assert all(core.rollout_steps(cfg, i) <= core.rollout_steps(cfg, i + 1) for i in range(n - 1))
    # collision weight: 5e3 until 50k/120k of the run, then linear to 8e6 at 100k/120k
    assert core.loss_weights(cfg, 0)["collision"] == pytest.approx(5e3)
    assert core.loss_weights(cfg, int(0.4 * n))["collision"] == pytest.approx(5e3)
    assert core.loss_weights(cfg, n - 1)["collision"] == pytest.approx(8e6)
    # inertia 3 → 5 and gravity 2 → 3 over the run, the others 1
    w0, w1 = core.loss_weights(cfg, 0), core.loss_weights(cfg, n - 1)
    assert (w0["inertia"], w1["inertia"], w0["gravity"], w1["gravity"]) == pytest.approx((3, 5, 2, 3))


def test_schedules_follow_the_time_budget_when_it_ends_the_run_first():
    cfg = core.load_config("tiny")["stage1"]
    # a run stopped by --max-minutes at half its iterations has still gone through the whole schedule
    s = core.run_fraction(cfg, 10, elapsed_s=60.0, budget_s=60.0)
    assert s == 1.0
    assert core.rollout_steps(cfg, 10, s) == cfg["rollout_max"]
    assert core.loss_weights(cfg, 10, s)["collision"] == pytest.approx(8e6)
    # without a budget (or ahead of it) the iteration count decides
    assert core.run_fraction(cfg, 10) == pytest.approx(10 / (cfg["iterations"] - 1))
    assert core.run_fraction(cfg, 10, elapsed_s=1.0, budget_s=1e6) == pytest.approx(10 / (cfg["iterations"] - 1))


@pytest.fixture(scope="module")
def tiny_setup():
    return core.Setup(core.load_config("tiny"), "tshirt", "cpu")


def test_garment_at_rest_on_the_shaped_body_has_no_stretching(tiny_setup):
    """The rest metric is the garment template shaped for β (T + G_S(β)): LBS in the rest pose reproduces it, so the
    stretching and bending energies vanish for any β, while the β = 0 template's metric would not."""
    import pleat.physics as ph
    s = tiny_setup
    J = len(s.joint_names)
    q = np.zeros((3, J, 4))
    q[..., 3] = 1.0
    clip = type("RestClip", (), dict(rotations=q, root_translation=np.zeros((3, 3)),
                                     root_rotation=np.tile([0.0, 0.0, 0.0, 1.0], (3, 1)), fps=30.0))()
    beta = np.random.default_rng(3).uniform(-3, 3, s.B)
    win = s.pose_window(clip, 0, 3, beta)
    w = core.Window(s, win, beta, np.array([0.2, 23600.0, 44400.0, 4e-5]), np.full(4, 0.5))
    x, rest = w.states[-1], w.rest                                   # float32, as training evaluates them
    mu, lam, k = 23600.0, 44400.0, 4e-5
    area = float(rest.face_area.sum())
    assert float(ph.stretching_energy(x, rest, mu, lam)) < 1e-6 * mu * area
    assert float(ph.bending_energy(x, rest, k)) < 1e-9
    beta0_rest = ph.cloth_rest(s.template, s.faces)
    assert ph.stretching_energy(x.double().numpy(), beta0_rest, mu, lam) > 1e-3 * mu * area


def test_body_subset_matches_the_full_body_where_it_is_kept(tiny_setup):
    """Collision and proximity use the body vertices near the garment (a speed-up); they must be the full body's
    vertices and normals at those indices, and cover everything within body_subset_m of the template."""
    from pleat import reference
    from scipy.spatial import cKDTree
    s = tiny_setup
    body = s.body
    clip = core.sources.clips("validation", 30.0, 1, 12, body)[0]
    beta = np.linspace(-2, 2, s.B)
    win = s.pose_window(clip, 5, 3, beta)
    feats = reference.pose_features(s.parents, s.joints_of(beta), s.input_joints, clip.rotations[5:8],
                                    clip.root_translation[5:8], clip.root_rotation[5:8])
    M = feats["skin_matrices"]
    v = body.v_template + np.einsum("vcb,b->vc", body.shapedirs, beta)
    A = np.einsum("vk,wkab->wvab", body.weights, M)
    full = np.einsum("wvab,vb->wva", A[..., :3], v) + A[..., 3]
    from pleat.asset import normal_adjacency
    adj = normal_adjacency(body.faces, len(v))
    n_full = reference.normals(full[1], body.faces, *adj)
    np.testing.assert_allclose(win["body"], full[:, s.body_index], atol=1e-9)
    np.testing.assert_allclose(win["body_normals"][1], n_full[s.body_index], atol=1e-9)
    near = np.nonzero(cKDTree(s.template).query(body.v_template)[0] < s.cfg["model"]["body_subset_m"])[0]
    assert np.isin(near, s.body_index).all()
    assert len(s.body_index) < 0.5 * len(body.v_template)


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    from pleat.train.cli import main
    out = tmp_path_factory.mktemp("tiny")
    assert main(["all", "--preset", "tiny", "--garment", "tshirt", "--out", str(out), "--no-progress"]) == 0
    return out


def _records(out, stage):
    return [json.loads(line) for line in (out / f"metrics_{stage}.jsonl").read_text().splitlines()]


def test_tiny_stage1_validation_loss_falls(tiny_run):
    # same validation windows, seeds and (final) loss weights before and after training
    vals = [r for r in _records(tiny_run, "stage1") if "validation" in r]
    before, after = vals[0]["validation"]["loss"], vals[-1]["validation"]["loss"]
    assert vals[0]["iteration"] == 0 and after < before


def test_tiny_stage2_loss_falls_and_latent_range_recorded(tiny_run):
    train = [r["loss"] for r in _records(tiny_run, "stage2") if "loss" in r]
    assert np.mean(train[-20:]) < 0.5 * np.mean(train[:20])
    state = torch.load(tiny_run / "stage2.pt", weights_only=False)
    assert np.all(state["norms"]["z_min"] <= state["norms"]["z_max"])
    assert np.all(state["norms"]["x_std"] > 0)


def test_tiny_asset_matches_reference_and_runtime(tiny_run):
    from pleat import reference
    from pleat.asset import read_asset
    assets = list(tiny_run.glob("*.pleat"))
    assert len(assets) == 1
    data = assets[0].read_bytes()
    asset = read_asset(data)
    meta = json.loads(asset["metadata_json"])
    assert meta["training"]["preset"] == "tiny" and meta["training"]["losses"]["stage1"]["iterations"] > 0

    model, setup, cfg, _ = core.load_stage1(tiny_run)
    s2 = torch.load(tiny_run / "stage2.pt", weights_only=False)
    lp = core.LatentPredictor(setup, s2["norms"])
    lp.load_state_dict(s2["model"])
    clip = core.sources.clips("validation", cfg["fps"], 1, 40, setup.body)[0]
    beta = np.linspace(-1.5, 1.5, setup.B)
    material = np.array([0.3, 30000.0, 40000.0, 1e-4])
    dt = np.full(len(clip.rotations), 1.0 / clip.fps)
    torch_pos, torch_z = core.torch_inference(setup, lp, model.block, clip.rotations, clip.root_translation,
                                              clip.root_rotation, dt, beta, material)
    # torch_inference is the networks and skinning only; the runtime's body contact (the trainer's assets carry body
    # anchors) is compared below, reference against C with it on
    assert "body_anchor" in asset
    inst = reference.Instance(asset, beta, material, body_contact=False)
    ref = np.stack([inst.step(clip.rotations[f], clip.root_translation[f], clip.root_rotation[f], dt[f])[0]
                    for f in range(len(dt))])
    # The asset stores fp32 weights and the torch model evaluates those same fp32 values in float64, so the two
    # differ only by the float32 rounding of the non-weight arrays (template, skin weights): well below 0.1 mm.
    np.testing.assert_allclose(ref, torch_pos, atol=1e-4)
    # the garment is not a plain LBS: the trained blend shapes move it
    assert np.abs(torch_z).max() > 0

    from pleat import runtime
    if runtime.find_library() is None:
        pytest.skip("libpleat.so not built: C runtime comparison skipped (torch and reference agreed)")
    inst = reference.Instance(asset, beta, material)
    ref = np.stack([inst.step(clip.rotations[f], clip.root_translation[f], clip.root_rotation[f], dt[f])[0]
                    for f in range(len(dt))])
    with runtime.Context() as ctx:
        c_asset = ctx.load_asset(data)
        c_inst = ctx.create_instance(c_asset, beta=beta, material=material)
        c_pos = np.stack([c_inst.step(clip.rotations[f], clip.root_translation[f], clip.root_rotation[f], dt[f])[0]
                          for f in range(len(dt))])
    # float32 C kernels over 40 autoregressive steps vs float64: 0.5 mm
    np.testing.assert_allclose(c_pos, ref, atol=5e-4)


def test_time_budget_stops_checkpoints_and_resumes(tmp_path):
    from pleat.train.cli import main
    args = ["stage1", "--preset", "tiny", "--garment", "tshirt", "--out", str(tmp_path), "--no-progress",
            "--set", "stage1.iterations=100000", "--set", "stage1.validation_windows=1"]
    assert main(args + ["--max-minutes", "0.04"]) == 0
    stopped = [r for r in _records(tmp_path, "stage1") if "stopped" in r]
    assert len(stopped) == 1 and stopped[0]["stopped"] == "time budget"
    first = torch.load(tmp_path / "stage1.pt", weights_only=False)
    assert 0 < first["iteration"] == stopped[0]["iteration"] < 100000
    # the budget counts across a resume: the elapsed time was saved, so a resumed run gets only what is left
    assert first["elapsed_s"] >= 0.04 * 60
    assert main(args + ["--max-minutes", "0.08", "--resume"]) == 0
    second = torch.load(tmp_path / "stage1.pt", weights_only=False)
    assert second["iteration"] > first["iteration"]
    assert 0.08 * 60 <= second["elapsed_s"] < 0.08 * 60 + 30
