"""The batched physics-loss path (pleat.train.batching: K windows per iteration through one graph) computes what
the per-window path of pleat.train.core computes: the same window draws, the same loss, terms, LBS normaliser and
gradients for stage 1 and the ablation, the same validation and recorded latents (docs/training-speed.md, "Speed").
Tiny preset; skips without PyTorch."""
import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="PyTorch not installed (pip install 'pleat-tools[train]')")

from pleat.train import ablation, batching, core  # noqa: E402

STEPS = 3


def _weights(cfg, s=0.6):
    # past the start of the collision ramp (w_c ≈ 3.5·10⁶), so collision and friction weigh in
    return core.loss_weights(cfg["stage1"], 0, s)


def _picks(setup, clips, seed, count, steps=STEPS):
    rng = np.random.default_rng(seed)
    return [batching.sample_pick(setup, clips, rng, steps + 3) for _ in range(count)]


def _grads(model):
    return [p.grad.detach().clone() if p.grad is not None else torch.zeros_like(p) for p in model.parameters()]


def _assert_grads_close(a, b, rel=1e-4):
    scale = max(float(g.abs().max()) for g in a)
    assert scale > 0
    for ga, gb in zip(a, b):
        assert torch.allclose(ga, gb, rtol=rel, atol=rel * scale), float((ga - gb).abs().max()) / scale


def test_sampling_draws_the_windows_of_the_per_window_path(tiny_physics):
    _, setup, clips = tiny_physics
    r1, r2 = np.random.default_rng(7), np.random.default_rng(7)
    for _ in range(4):
        win, beta, mat, mat01 = core.sample_window(setup, clips, r1, STEPS + 3)
        p = batching.sample_pick(setup, clips, r2, STEPS + 3)
        assert np.array_equal(beta, p["beta"]) and np.array_equal(mat, p["material"])
        one = batching.prepare(batching.kinematics(setup), [p])
        # the kinematics of the pick are the per-window posing's (body posing by a sparse matmul, normals in bulk;
        # normals from frame 3 on, the first frame with a loss)
        for key in ("A", "body", "Hinv", "p0", "dt"):
            np.testing.assert_allclose(one[key][0], win[key], rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(one["body_normals"][0, 3:], win["body_normals"][3:], rtol=1e-10, atol=1e-12)
        assert np.isnan(one["body_normals"][0, :3]).all()


def test_rest_geometry_equals_cloth_rest_for_every_shape(tiny_physics):
    import pleat.physics as ph
    _, setup, _ = tiny_physics
    betas = np.random.default_rng(1).uniform(-3, 3, (3, setup.B))
    kin = batching.kinematics(setup)
    geo = kin.topology.geometry(kin.shaped(betas))
    for k, beta in enumerate(betas):
        ref = ph.cloth_rest(setup.shaped(beta), setup.faces)
        for key in ("dm_inv", "face_area", "hinge_angle", "hinge_weight", "vertex_area"):
            np.testing.assert_allclose(geo[key][k], getattr(ref, key), rtol=1e-12, atol=1e-15)


def test_stage1_batch_has_the_per_window_loss_terms_normaliser_and_gradients(tiny_physics):
    """Three fixed windows: each window's loss, equation-4 terms and LBS-only divisor, and the gradient of the
    iteration's objective (mean of loss / LBS loss), equal the per-window path's (core.Window / rollout_loss /
    lbs_scale, one window at a time) within float32 tolerance."""
    cfg, setup, clips = tiny_physics
    w = _weights(cfg)
    torch.manual_seed(0)
    model = core.Stage1Model(setup)
    picks = _picks(setup, clips, 5, 3)
    model.zero_grad()
    ref_loss, ref_scale, ref_terms = [], [], []
    for p in picks:
        win = setup.pose_window(p["clip"], p["start"], p["length"], p["beta"])
        scale, _ = core.lbs_scale(setup, win, p["beta"], p["material"], p["material01"], STEPS, w, 1.0)
        loss, terms = core.rollout_loss(setup, model, core.Window(setup, win, p["beta"], p["material"],
                                                                  p["material01"]), STEPS, w)
        (loss / scale / len(picks)).backward()
        ref_loss.append(loss.item())
        ref_scale.append(scale)
        ref_terms.append(terms)
    ref_grads = _grads(model)
    model.zero_grad()
    objective, loss, scale, terms = batching.stage1_loss(setup, batching.BatchedStage1(model),
                                                         batching.prepare(batching.kinematics(setup), picks, STEPS),
                                                         STEPS, w, "lbs", 1.0)
    objective.backward()
    np.testing.assert_allclose(loss.detach().numpy(), ref_loss, rtol=1e-5)
    np.testing.assert_allclose(scale, ref_scale, rtol=1e-5)
    for k in core.LOSS_TERMS:
        np.testing.assert_allclose(terms[k], [t[k] for t in ref_terms], rtol=1e-4, atol=1e-9)
    assert max(t["friction"] for t in ref_terms) > 0 and max(t["stretching"] for t in ref_terms) > 0
    _assert_grads_close(ref_grads, _grads(model))


def test_ablation_batch_has_the_per_window_objective_gradients_and_latent_range(tiny_physics):
    cfg, setup, clips = tiny_physics
    w = _weights(cfg)
    c1 = dict(cfg["stage1"], loss_norm="lbs")
    torch.manual_seed(0)
    norms = core.pose_statistics(setup, clips, np.random.default_rng(0), samples=2)
    model = core.AblationModel(setup, norms)
    picks = _picks(setup, clips, 9, 2)
    lo, hi = np.full(setup.L, np.inf), np.full(setup.L, -np.inf)
    model.zero_grad()
    ref = 0.0
    for p in picks:       # core.train_ablation's per-window loop
        win = setup.pose_window(p["clip"], p["start"], p["length"], p["beta"])
        loss, _ = ablation.window_loss(setup, model, win, p["beta"], p["material"], p["material01"], c1, STEPS, w,
                                       lo, hi)
        ref = ref + loss / len(picks)
    ref.backward()
    ref_grads = _grads(model)

    class Fixed:                  # a WindowSource that hands out these picks
        def next(self, steps, next_steps=None):
            return batching._Prepared(batching.kinematics(setup), clips, setup.asset_stub)(picks, True, steps)

    for p in picks:
        p["clip_index"] = next(i for i, c in enumerate(clips) if c is p["clip"])
    z_lo, z_hi = np.full(setup.L, np.inf), np.full(setup.L, -np.inf)
    model.zero_grad()
    objective, rec = batching.ablation_iteration(setup, model, Fixed(), c1, STEPS, w, z_lo, z_hi)
    objective.backward()
    assert objective.item() == pytest.approx(ref.item(), rel=1e-5)
    np.testing.assert_allclose(z_lo, lo, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(z_hi, hi, rtol=1e-5, atol=1e-6)
    _assert_grads_close(ref_grads, _grads(model))


def test_validation_and_recorded_latents_equal_the_per_window_path(tiny_physics):
    cfg, setup, _ = tiny_physics
    torch.manual_seed(0)
    model = core.Stage1Model(setup).eval()
    per_window = dict(cfg, stage1=dict(cfg["stage1"], batched=False, validation_windows=3))
    batched = dict(cfg, stage1=dict(cfg["stage1"], batched=True, validation_windows=3))
    a, b = core.validate_stage1(setup, model, per_window), core.validate_stage1(setup, model, batched)
    assert a.keys() == b.keys()
    for k in a:
        assert b[k] == pytest.approx(a[k], rel=1e-4, abs=1e-9), k
    clips = core.sources.clips("validation", 30.0, 1, 12, setup.body)
    setup.cfg = per_window
    old = core.record_latents(setup, model, clips, 3, 6, np.random.default_rng(2))
    setup.cfg = batched
    new = core.record_latents(setup, model, clips, 3, 6, np.random.default_rng(2))
    setup.cfg = cfg
    assert len(old) == len(new) == 3
    for o, n in zip(old, new):
        np.testing.assert_allclose(n["static"], o["static"], rtol=1e-12)
        np.testing.assert_allclose(n["z"], o["z"], rtol=1e-4, atol=1e-5)


def test_data_worker_prepares_the_same_windows_as_the_trainer_would(tiny_physics):
    """The forked worker prepares iteration i + 1 while iteration i trains: the windows it hands out are those the
    in-process source draws from the same generator, also across a change of rollout length (the guess misses and
    the windows are drawn again)."""
    _, setup, clips = tiny_physics
    here = batching.WindowSource(setup, clips, np.random.default_rng(3), 2, static=True)
    there = batching.WindowSource(setup, clips, np.random.default_rng(3), 2, static=True, workers=1)
    try:
        schedule = [1, 1, 2, 2]
        for i, steps in enumerate(schedule):
            a = there.next(steps, steps)     # the trainer's guess for the next iteration: this one's length
            if i and schedule[i - 1] != steps:
                here.next(schedule[i - 1])   # what the worker drew for the missed guess, dropped
            b = here.next(steps)
            for key in ("A", "body", "static", "beta", "material"):
                np.testing.assert_array_equal(a[key], b[key])
            for key in core.LOSS_TERMS:
                np.testing.assert_array_equal(a["lbs_terms"][key], b["lbs_terms"][key])
            assert a["A"].shape[1] == steps + 3
            assert len(a["trees"]) == 2 and len(a["trees"][0]) == steps + 3
    finally:
        there.close()


def test_several_data_workers_hand_out_the_windows_in_order(tiny_physics):
    """Three workers, round robin, three iterations ahead: on a steady schedule the windows are the in-process
    source's, in order; across a change of rollout length every window has the new length (the three guesses
    that missed are drawn and prepared again) and closing with jobs in flight returns."""
    _, setup, clips = tiny_physics
    here = batching.WindowSource(setup, clips, np.random.default_rng(4), 2)
    there = batching.WindowSource(setup, clips, np.random.default_rng(4), 2, workers=3)
    try:
        assert len(there.procs) == 3
        for _ in range(5):
            a, b = there.next(1, 1), here.next(1)
            for key in ("A", "body", "beta", "material"):
                np.testing.assert_array_equal(a[key], b[key])
            for key in core.LOSS_TERMS:
                np.testing.assert_array_equal(a["lbs_terms"][key], b["lbs_terms"][key])
        assert there.worker_cpu_s > 0
        for _ in range(5):
            a = there.next(2, 2)
            assert a["A"].shape[1] == 2 + 3 and len(a["trees"][0]) == 2 + 3
    finally:
        there.close()
    assert not there.procs


def test_nearest_on_the_device_is_the_kdtree_one(tiny_physics):
    """stage1.nearest = "torch": exact float32 distances on the trainer's device instead of the prepared KD-trees.
    The same nearest body vertex (up to near-ties), and on fixed windows the same losses and gradients within
    float32 tolerance; a source with drop_trees hands out windows without trees, which then take this path."""
    from scipy.spatial import cKDTree
    cfg, setup, clips = tiny_physics
    win = batching.prepare(batching.kinematics(setup), _picks(setup, clips, 6, 3), STEPS)
    x = batching.WindowBatch(setup, win).states[2]
    body = torch.as_tensor(win["body"][:, 3], dtype=torch.float32)
    dist, idx = batching.nearest_on_device(x, body, max_elements=x.shape[1] * body.shape[1] * 2)  # two groups
    for k in range(len(x)):
        d_ref, i_ref = cKDTree(win["body"][k, 3]).query(x[k].numpy().astype(np.float64))
        np.testing.assert_allclose(dist[k].numpy(), d_ref, rtol=0, atol=2e-6)
        differ = idx[k].numpy() != i_ref
        # a different index only where another body vertex is as near, to float32 rounding
        np.testing.assert_allclose(np.linalg.norm(win["body"][k, 3][idx[k].numpy()[differ]] - x[k].numpy()[differ],
                                                  axis=1), d_ref[differ], atol=2e-6)
        assert differ.mean() < 0.01
    w = _weights(cfg)
    torch.manual_seed(0)
    model = core.Stage1Model(setup)
    results = []
    for nearest in ("kdtree", "torch"):
        model.zero_grad()
        batch = batching.WindowBatch(setup, win, nearest=nearest)
        assert batch.on_device == (nearest == "torch")
        graph, net = batching.block_graph(setup, batch.K), batching.BatchedStage1(model)

        def predict(f):
            node, edges, body_e, recv = batch.features(f)
            return net(node, edges, body_e, recv, graph, batch.K)[1]

        loss, _ = batching.rollout(batch, STEPS, w, predict)
        loss.sum().backward()
        results.append((loss.detach().numpy(), _grads(model)))
    np.testing.assert_allclose(results[1][0], results[0][0], rtol=1e-5)
    _assert_grads_close(results[0][1], results[1][1])
    source = batching.WindowSource(setup, clips, np.random.default_rng(4), 2, drop_trees=True)
    assert "trees" not in source.next(1) and batching.WindowBatch(setup, source.next(1)).on_device


def test_vertex_major_compressor_is_the_einsum_one(tiny_physics):
    """compress with K > 1 runs vertex-major: within float32 rounding the same Z and gradients as the einsum form
    that K = 1 keeps (another summation order)."""
    _, setup, _ = tiny_physics
    torch.manual_seed(0)
    comp = core.Stage1Model(setup).phi.compressor
    h = torch.randn(3, setup.N, comp.blocks[0].conv.basis.shape[1], requires_grad=True)
    weight = torch.randn(3, comp.flat.out_features)
    out = []
    for fn in (lambda c, x: torch.cat([batching.compress(c, x[i:i + 1]) for i in range(3)]),
               batching._compress_vertex_major):
        comp.zero_grad()
        h.grad = None
        z = fn(comp, h)
        (z * weight).sum().backward()
        out.append((z.detach(), [h.grad.clone()] + [p.grad.clone() for p in comp.parameters()]))
    torch.testing.assert_close(out[1][0], out[0][0], rtol=1e-6, atol=1e-6)
    _assert_grads_close(out[0][1], out[1][1], rel=1e-5)


def test_compiled_terms_are_the_eager_ones_and_follow_the_collision_ramp(tiny_physics):
    """With stage1.compile the equation-4 terms run through torch.compile: the same values within float32 rounding,
    and the collision weight, which moves every iteration on its ramp, is an input, not a constant (no
    recompilation when it changes)."""
    from torch._dynamo.utils import counters
    cfg, setup, clips = tiny_physics
    win = batching.prepare(batching.kinematics(setup), _picks(setup, clips, 6, 2), STEPS)
    disp = torch.zeros(2, setup.N, 3)
    disp[:, :, 1] = -0.01                      # drop the garment 1 cm: collision and friction active
    out = {}
    for compiled in (False, True):
        batch = batching.WindowBatch(setup, win, compiled_terms=compiled)
        batch.advance(3, disp)
        out[compiled] = [batch.losses(3, core.loss_weights(cfg["stage1"], 0, s)["collision"]) for s in (0.5, 0.7)]
        if compiled:
            graphs = counters["stats"]["unique_graphs"]
            batch.losses(3, 1234.5)
            assert counters["stats"]["unique_graphs"] == graphs
    for eager, comp in zip(out[False], out[True]):
        for k in core.LOSS_TERMS:     # gravity is a difference of two sums of ~1 J: 10 µJ absolute
            atol = 1e-5 if k == "gravity" else 1e-9
            torch.testing.assert_close(comp[k], eager[k], rtol=1e-4, atol=atol, msg=k)
    assert float(out[False][1]["friction"].max()) > float(out[False][0]["friction"].max()) > 0


def test_data_worker_and_nearest_settings():
    """stage1.data_worker: false / true / a count; stage1.nearest: auto (the trees, also on a GPU, where
    they measured faster), kdtree, torch;
    anything else is refused before training (by the declarations, pleat.train.settings)."""
    from pleat.train import config, settings

    def stage1(**values):
        return settings.resolve("tiny", overrides={f"stage1.{k}": v for k, v in values.items()})["stage1"]
    assert [config.data_workers(stage1(data_worker=v)) for v in (False, True, 0, 3)] == [0, 1, 0, 3]
    assert config.data_workers(stage1()) == 0
    for bad in (-1, "2", 1.5):
        with pytest.raises(settings.SettingError, match="stage1.data_worker"):
            stage1(data_worker=bad)
    assert not config.searches_on_device(stage1()) and not config.searches_on_device(stage1(nearest="auto"))
    assert config.searches_on_device(stage1(nearest="torch"))
    assert not config.searches_on_device(stage1(nearest="kdtree"))
    with pytest.raises(settings.SettingError, match="stage1.nearest"):
        stage1(nearest="gpu")
