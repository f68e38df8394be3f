"""The simulator-supervised recipe (pleat.train.simdata / simsup / contact): targets, end to end, contact term."""
import json
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from pleat.train import contact, core, simdata, simsup  # noqa: E402


@pytest.fixture(scope="module")
def tiny_setup():
    return core.Setup(core.load_config("tiny"), "tshirt")


def test_unskin_inverts_the_per_vertex_affine_map():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(2, 5, 3, 4))
    A[..., :3] += 3.0 * np.eye(3)                     # well conditioned, like a blend of rotations
    v = rng.normal(size=(2, 5, 3))
    x = np.einsum("tnab,tnb->tna", A[..., :3], v) + A[..., 3]
    np.testing.assert_allclose(simdata.unskin(A, x), v, atol=1e-12)


@pytest.mark.slow
def test_a_simulated_segment_is_reproduced_by_skinning_its_targets(tiny_setup, tmp_path):
    """The targets are exactly what the runtime's blend shapes must add: LBS of (T + G_S(β) + d) gives back the
    simulated frames, so the runtime's skinning and the simulator's pinned LBS are the same map."""
    setup = tiny_setup
    clips = simsup._clips("train", 30.0, setup.body)
    name = sorted(clips)[0]
    beta = np.zeros(setup.B)
    beta[0] = 1.5
    seg = simdata.Segment(name, "fast", 0, 6, tuple(beta), tuple(simdata.ga.MATERIAL_DEFAULT))
    done, cpu_s = simdata.simulate_segments(setup, [seg], 1, tmp_path)
    assert len(done) == 1 and cpu_s > 0
    with np.load(done[0][1]) as z:
        pos = z["positions"]
    clip = simdata.cut(simdata.variant_clip(clips[name], "fast"), 0, 6)
    s = simdata.sequence(setup, clip, beta, np.array(simdata.ga.MATERIAL_DEFAULT), pos)
    from types import SimpleNamespace
    c = SimpleNamespace(rotations=clip.local_rotations, root_translation=clip.root_translation,
                        root_rotation=clip.root_rotation, fps=clip.fps)
    A = setup.pose_window(c, 0, len(pos), beta)["A"]
    x = np.einsum("tnab,tnb->tna", A[..., :3], setup.shaped(beta)[None] + s["disp"]) + A[..., 3]
    assert np.abs(x - pos).max() < 1e-5                        # metres; float32 positions
    assert np.abs(s["disp"]).max() > 1e-3                      # the simulation does deform the garment
    assert s["static"].shape == (6, setup.input_count) and s["M"].shape[:2] == (6, len(setup.parents))


def test_thinned_data_keeps_evenly_spaced_segments_and_the_validation():
    """simsup.data_segments: N of an export's segments, evenly spaced (every clip keeps its share), first and last
    included; 0 or more than there are keeps them all."""
    loaded = (list("abcdefghij"), list(range(10)), ["val"], 1.0, 2.0)
    done, seqs, val, sim, vcpu = simsup.thinned_data(loaded, 4)
    assert seqs == [0, 3, 6, 9] and done == ["a", "d", "g", "j"] and val == ["val"] and (sim, vcpu) == (1.0, 2.0)
    assert simsup.thinned_data(loaded, 0) is loaded and simsup.thinned_data(loaded, 11) is loaded


def test_contact_term_penalises_only_vertices_inside_or_within_eps():
    """One garment vertex above a body vertex with normal +y: no penalty 5 mm out, a penalty 1 mm out (ε = 2 mm) and
    a larger one inside; the share inside counts only the last."""
    M = torch.zeros(1, 1, 1, 12)
    M[..., 0] = M[..., 5] = M[..., 10] = 1.0                   # identity joint
    data = {"M": M, "disp": torch.zeros(1, 1, 1, 3), "nearest": torch.zeros(1, 1, 1, dtype=torch.long),
            "shaped_g": torch.zeros(1, 1, 3), "shaped_b": torch.zeros(1, 1, 3),
            "normals_b": torch.tensor([[[0.0, 1.0, 0.0]]]), "skin_idx": torch.zeros(1, 1, dtype=torch.long),
            "skin_w": torch.ones(1, 1), "body_w": torch.ones(1, 1)}
    seq, frame = torch.zeros(1, dtype=torch.long), torch.zeros(1, dtype=torch.long)
    out = [contact.terms(data, seq, frame, torch.tensor([[[0.0, y, 0.0]]]), 2e-3) for y in (5e-3, 1e-3, -3e-3)]
    assert float(out[0][1]) == 0.0
    assert float(out[1][1]) == pytest.approx(1.0, rel=1e-4)    # (2 − 1)² mm²
    assert float(out[2][1]) == pytest.approx(25.0, rel=1e-4)   # (2 + 3)² mm²
    assert [float(o[2]) for o in out] == [0.0, 0.0, 1.0]
    assert float(out[2][0]) == pytest.approx(9.0, rel=1e-4)    # squared error against the simulated frame, mm²


def test_strain_term_is_the_edge_length_error_against_the_simulated_frame():
    """Two garment vertices 10 mm apart in the simulated frame: a prediction that moves one of them 3 mm along the
    edge has an edge-length error of 3 mm (9 mm²), one that moves both rigidly has none (the position term does not
    tell them apart); without strain=True the term is not computed."""
    M = torch.zeros(1, 1, 1, 12)
    M[..., 0] = M[..., 5] = M[..., 10] = 1.0                   # identity joint
    data = {"M": M, "disp": torch.zeros(1, 1, 2, 3), "nearest": torch.zeros(1, 1, 2, dtype=torch.long),
            "shaped_g": torch.tensor([[[0.0, 0.0, 0.0], [0.01, 0.0, 0.0]]]), "shaped_b": torch.zeros(1, 1, 3),
            "normals_b": torch.tensor([[[0.0, 1.0, 0.0]]]), "skin_idx": torch.zeros(2, 1, dtype=torch.long),
            "skin_w": torch.ones(2, 1), "body_w": torch.ones(1, 1), "edges": torch.tensor([[0, 1]])}
    seq, frame = torch.zeros(1, dtype=torch.long), torch.zeros(1, dtype=torch.long)
    stretched = torch.tensor([[[0.0, 0.05, 0.0], [0.003, 0.05, 0.0]]])
    moved = torch.tensor([[[0.0, 0.05, 0.0], [0.0, 0.05, 0.0]]])
    assert len(contact.terms(data, seq, frame, stretched, 2e-3)) == 3
    err_s, _, _, strain_s = contact.terms(data, seq, frame, stretched, 2e-3, strain=True)
    err_m, _, _, strain_m = contact.terms(data, seq, frame, moved, 2e-3, strain=True)
    assert float(strain_s) == pytest.approx(9.0, rel=1e-4)
    assert float(strain_m) == pytest.approx(0.0, abs=1e-9)
    assert float(err_m) < float(err_s)


@pytest.mark.slow
def test_simsup_tiny_end_to_end(tmp_path, capsys):
    """Simulate, export, refit from the export, fine-tune, pack: the asset loads, says how it was made, and the run
    prints a verdict against LBS-only."""
    # One torch thread, as pleat-train runs by default (--threads): the forked fits run on one thread each, and the
    # same networks one by one and side by side holds at equal thread counts only (torch splits its reductions by
    # thread, so a many-core machine's default thread count rounds differently).
    threads = torch.get_num_threads()
    core.set_threads(1)
    try:
        _simsup_tiny_end_to_end(tmp_path, capsys)
    finally:
        torch.set_num_threads(threads)


def _simsup_tiny_end_to_end(tmp_path, capsys):
    cfg = core.load_config("tiny", overrides={"simsup.max_segments": 2, "simsup.segment_frames": 8,
                                             "simsup.validation_frames": 6, "simsup.iterations": 20,
                                             "simsup.dec_iterations": 10, "simsup.contact_iterations": 3})
    data = tmp_path / "data.npz"
    path, summary = simsup.train(cfg, "tshirt", tmp_path / "a", workers=1, progress=False,
                                 cache_dir=tmp_path / "cache", export=str(data))
    assert summary["segments"] == 2 and summary["frames"] == 16
    # simsup.exclude_sources: a refit without one motion folder drops that folder's segments from the data
    setup = core.Setup(cfg, "tshirt")
    train_clips, val_clips = simsup._clips("train", 30.0, setup.body), simsup._clips("validation", 30.0, setup.body)
    done, seqs, val, _, _ = simsup.load_datasets(setup, str(data), train_clips, val_clips, 6)
    sources = [simsup.source_of(seg.clip) for seg, _ in done]
    kept = simsup.load_datasets(setup, str(data), train_clips, val_clips, 6, leave_out={sources[0]})
    others = [k for k, src in enumerate(sources) if src != sources[0]]
    assert len(seqs) == 2 and len(kept[1]) == len(others) and len(kept[2]) == len(val)
    assert all(simsup.source_of(seg.clip) != sources[0] for seg, _ in kept[0])
    for q, k in zip(kept[1], others):                  # each kept segment keeps its own frames
        np.testing.assert_array_equal(q["disp"], seqs[k]["disp"])
    # the refit as the shipped recipe makes it: two member fits averaged into one network of the large sizes
    cfg2 = core.load_config("tiny", overrides={"simsup.max_segments": 2, "simsup.segment_frames": 8,
                                              "simsup.validation_frames": 6, "simsup.iterations": 20,
                                              "simsup.dec_iterations": 10, "simsup.contact_iterations": 3,
                                              "simsup.ensemble_members": 2, "simsup.member_tier": "member",
                                              "simsup.tier": "large", "simsup.input_noise": 0.1,
                                              "simsup.students": 2, "simsup.tier_teacher_frames": 30,
                                              "simsup.contact_candidates": 6})
    path2, summary2 = simsup.train(cfg2, "tshirt", tmp_path / "b", progress=False, data=str(data))
    assert summary2["frames"] == 16
    fit = summary2["fit"]
    # two students of the pair's mean, each on the 16 simulated frames and ≥ 30 frames only the pair labelled
    assert fit["ensemble_of"] == ["member", "member"] and fit["teacher_only_frames"] == 30
    assert all(m["train_frames"] >= 16 + 30 for m in fit["members"])
    assert fit["students_of"]["ensemble_of"] == ["member", "member"]    # the teacher: the mean of two fits
    assert fit["latent"] == 2 * fit["members"][0]["latent"] and fit["blend"] == 2 * fit["members"][0]["blend"]
    printed = capsys.readouterr().out
    assert printed.count("verdict: ") == 2 and "than LBS-only on 1 validation clips" in printed   # one per run
    from pleat.asset import read_asset
    w = read_asset(path2.read_bytes())
    meta = json.loads(w["metadata_json"])
    assert meta["training"]["recipe"] == "simulator-supervised"
    assert meta["training"]["contact"]["iterations"] == 3
    # the top tier's contact candidates came from the run's simulated frames (written once, used by every pack)
    assert (tmp_path / "b" / simsup.CANDIDATES_FILE).is_file()
    assert meta["body_contact"]["candidates_from"] == "simulated frames" and meta["body_contact"]["candidates"] == 6
    assert w["body_anchor_candidates"].shape == (len(w["template"]), 6)
    assert meta["model"].startswith("pleat simulator-supervised: the mean of 2 member networks distilled from a fit")
    assert w["lp.0.weight"].shape[0] == 512 and w["blend_shapes"].shape[0] == fit["blend"]
    # the contact fine-tune kept the members apart: the blocks between them are still exactly zero, so the runtime
    # skips them (sdk/src/layer_blocks.c)
    for key in ("lp.1.weight", "dec.1.weight"):
        W = np.asarray(w[key], np.float32)
        h, half_in = W.shape[0] // 2, W.shape[1] // 2
        assert not W[:h, half_in:].any() and not W[h:, :half_in].any() and W[:h, :half_in].any()
    assert np.isfinite(w["blend_shapes"]).all() and np.abs(w["blend_shapes"]).max() > 0
    # a contact step whose budget is already spent runs no iteration and says so (it used to fail on no loss)
    _, rep = simsup.contact_tune(tmp_path / "b", str(data), iterations=2, progress=False, deadline=0.0)
    assert rep["iterations"] == 0 and rep["final_error_mm2"] is None
    # the same recipe with its fits two at a time in forked children (simsup.fit_workers): the same asset, bit for bit
    cfg2p = json.loads(json.dumps(cfg2))
    cfg2p["simsup"]["fit_workers"] = 2
    path2p, _ = simsup.train(cfg2p, "tshirt", tmp_path / "b2", progress=False, data=str(data))
    w2p = read_asset(path2p.read_bytes())
    for key in ("lp.0.weight", "lp.1.weight", "dec.0.weight", "dec.1.weight", "blend_shapes"):
        assert np.array_equal(np.asarray(w2p[key]), np.asarray(w[key])), key
    # the tiers distilled from it (pleat-train simsup-tiers): one by one from run b, side by side from run b2 (its
    # config says fit_workers 2); the same small and medium (the mean of two small students) either way
    for run, out in (("b", "t1"), ("b2", "t2")):
        reps = simsup.distill_tiers(tmp_path / run, str(data), ["small", "medium"], tmp_path / out, iterations=20,
                                    progress=False, teacher_frames=30)
        assert [r["asset"].split("_")[-1] for r in reps] == ["small.pleat", "medium.pleat"]
    for name in ("small", "medium"):
        a = read_asset((tmp_path / "t1" / f"tshirt_{name}.pleat").read_bytes())
        b = read_asset((tmp_path / "t2" / f"tshirt_{name}.pleat").read_bytes())
        for key in ("lp.0.weight", "dec.0.weight", "blend_shapes"):
            assert np.array_equal(np.asarray(a[key]), np.asarray(b[key])), (name, key)
    # the opt-in second round of students (simsup.students; CHANGELOG.md, "Training"): the students' mean teaches two small students in turn,
    # packed at twice the small sizes
    cfg3 = json.loads(json.dumps(cfg2p))
    cfg3["simsup"].update({"second_students": 2, "second_student_tier": "small"})
    path3, summary3 = simsup.train(cfg3, "tshirt", tmp_path / "c", progress=False, data=str(data))
    fit3 = summary3["fit"]
    assert fit3["tier"] == "2xsmall" and fit3["ensemble_of"] == ["small", "small"]
    assert fit3["lp_hidden"] == [256, 256] and fit3["dec_hidden"] == [256]
    assert fit3["latent"] == sum(m["latent"] for m in fit3["members"])
    assert fit3["students_of"]["ensemble_of"] == ["member", "member"]                    # taught by the students
    assert fit3["students_of"]["students_of"]["ensemble_of"] == ["member", "member"]     # whom the fit taught
    w3 = read_asset(path3.read_bytes())
    assert w3["lp.0.weight"].shape[0] == 256 and np.isfinite(w3["blend_shapes"]).all()


def test_window_noise_perturbs_inputs_and_start_latent_by_the_stated_amounts():
    """core.window_loss's opt-in regulariser: f_LP sees its input rows moved by input_noise × x_std and its starting
    latent by latent_noise × z_std (both in normalised units), the targets stay clean, and noise=None is the plain
    loss bit for bit."""
    L, F, S, T = 3, 5, 4, 12
    seen = []

    class Recorder(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.register_buffer("x_std", torch.full((L + F,), 2.0))
            self.w = torch.nn.Parameter(torch.zeros(()))

        def forward(self, z_prev, rows):
            seen.append((z_prev.detach().clone(), rows.detach().clone()))
            return z_prev * 0 + self.w, z_prev

    gen = torch.Generator().manual_seed(0)
    seqs = [{"static": np.zeros((T, L + F)), "z": np.ones((T, L))} for _ in range(S)]
    lengths, static, target = core.padded_sequences(seqs)
    z_mean, z_std = torch.zeros(L), torch.full((L,), 0.5)
    pred = Recorder()
    args = (pred, z_mean, z_std, lengths, static, target, 256, 1)
    clean = core.window_loss(*args, torch.Generator().manual_seed(1)).item()
    assert core.window_loss(*args, torch.Generator().manual_seed(1), noise=None).item() == clean
    seen.clear()
    noisy = core.window_loss(*args, gen, noise=(0.1, 0.2)).item()
    z0, rows = seen[0]
    assert abs(float(rows.std()) - 0.1 * 2.0) < 0.02                 # input rows: 0.1 × x_std
    assert abs(float((z0 - z0.round()).std()) - 0.2 * 0.5) < 0.01      # start latent (1 or 0): 0.2 × z_std
    assert noisy == pytest.approx(clean, rel=1e-6)       # the targets are not perturbed


def _random_member(setup, spec, seed):
    """A fitted-looking member: random weights and its own normalisation of the shared inputs."""
    from pleat.train import distill
    from pleat.train.model import InferenceBlock
    rng = np.random.default_rng(seed)
    torch.manual_seed(seed)
    shim = distill._shim(setup, spec.latent, spec.blend, spec.lp_hidden, spec.dec_hidden, spec.activation, setup.L)
    F = setup.input_count - setup.L
    norms = {"x_mean": np.concatenate([rng.normal(size=spec.latent), rng.normal(size=F)]),
             "x_std": np.concatenate([rng.uniform(0.5, 2, spec.latent), rng.uniform(0.5, 2, F)]),
             "z_mean": rng.normal(size=spec.latent), "z_std": rng.uniform(0.5, 2, spec.latent)}
    norms["z_min"], norms["z_max"] = norms["z_mean"] - 1.0, norms["z_mean"] + 1.0   # the guard does clamp
    lp = core.LatentPredictor(shim, norms)
    block = InferenceBlock(shim.cfg["model"], setup.N, free_mask=setup.free_mask)
    with torch.no_grad():
        block.blend_shapes.normal_(0.0, 0.01)
    return lp.eval(), block.eval(), norms


def test_an_ensemble_packed_as_one_network_is_the_mean_of_its_members(tiny_setup):
    """pleat.train.ensemble: two members with different normalisations, as one block-diagonal network of the summed
    widths, free-run from a reset over the same rows: the garment is the members' mean (float32 rounding)."""
    from pleat.eval.tiers import Tier
    from pleat.train import ensemble
    setup = tiny_setup
    member = Tier("m", vertices=setup.N, latent=4, blend=5, lp_hidden=(8, 8), dec_hidden=(6,))
    pair = Tier("p", vertices=setup.N, latent=8, blend=10, lp_hidden=(16, 16), dec_hidden=(12,))
    members = [_random_member(setup, member, s) for s in (1, 2)]
    lp, block, norms, _ = ensemble.combine(members, setup, pair)
    rows = np.random.default_rng(3).normal(size=(12, setup.input_count - setup.L)) * 2.0

    def run(lp_, block_, L):
        z, out = torch.zeros(L), []
        with torch.no_grad():
            for r in rows:
                _, z = lp_(z, torch.as_tensor(np.concatenate([np.zeros(L), r]), dtype=torch.float32))
                out.append(block_.displacement(z))
        return torch.stack(out)

    mean = 0.5 * (run(members[0][0], members[0][1], 4) + run(members[1][0], members[1][1], 4))
    got = run(lp, block, 8)
    assert float(mean.abs().max()) > 1e-3                                   # the members do deform the garment
    assert float((got - mean).abs().max()) < 1e-5 * float(mean.abs().max()) + 1e-7
    with pytest.raises(ValueError):                                          # widths that do not add up
        ensemble.combine(members, setup, Tier("q", vertices=setup.N, latent=8, blend=10, lp_hidden=(32, 16),
                                              dec_hidden=(12,)))


@pytest.mark.parametrize("argv", [["simsup-contact"], ["simsup-ensemble", "--members", "one"],
                                  ["contact-candidates"]])
def test_simsup_commands_missing_inputs_are_usage_errors(argv, tmp_path, capsys):
    """pleat-train's simsup commands without what they need end as a usage error (status 2) that names it."""
    from pleat.train import cli
    with pytest.raises(SystemExit) as e:
        cli.main(argv + ["--out", str(tmp_path)])
    assert e.value.code == 2
    assert ("--data" if argv[0] != "simsup-ensemble" else "--members") in capsys.readouterr().err


def test_simsup_tiers_names_what_it_lacks(tmp_path, capsys):
    """simsup-tiers needs no --data (the tiers can learn the model on unsimulated motion alone), but a run to distil
    from: none in --out is an input error naming the checkpoint; --from-asset without its --garment a usage error."""
    from pleat.train import cli
    assert cli.main(["simsup-tiers", "--out", str(tmp_path)]) == 1
    assert "simsup.pt" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        cli.main(["simsup-tiers", "--out", str(tmp_path), "--from-asset", "assets/tshirt.pleat"])
    assert e.value.code == 2 and "--garment" in capsys.readouterr().err


def test_contact_candidates_are_the_body_vertices_nearest_in_the_frames(tiny_setup, tmp_path):
    """contact.candidate_vertices: per garment vertex its rest-nearest body vertex, then the body vertices nearest to
    it in the sequences' frames, most often first (only where it is within the radius), then further rest neighbours
    — checked against the whole body posed by its own forward kinematics (pleat.eval.scene.posed_body), and the
    table written to a run folder is what the run's assets are packed with."""
    from scipy.spatial import cKDTree

    from pleat.eval import scene as S
    setup = tiny_setup
    clips = simsup._clips("train", 30.0, setup.body)
    clip = simdata.cut(clips[sorted(clips)[0]], 0, 12)
    beta = np.zeros(setup.B)
    beta[1] = -1.0
    s = simdata.sequence(setup, clip, beta, np.array(simdata.ga.MATERIAL_DEFAULT))
    s["disp"] = np.zeros((clip.num_frames, setup.N, 3))
    s["disp"][:, :, 1] = -0.004                                   # the garment 4 mm lower than its skin
    found = contact.candidate_vertices(setup, [s], 6, stride=1, radius_m=0.02)
    table = found.table
    body_v, _ = S.posed_body(setup.body, clip, beta)
    A = simdata.blend_matrices(setup, s["M"])
    x = np.einsum("tnab,tnb->tna", A[..., :3], setup.shaped(beta)[None] + s["disp"]) + A[..., 3]
    counts = [dict() for _ in range(setup.N)]
    for t in range(len(x)):
        d, j = cKDTree(body_v[t]).query(x[t])
        for i in np.flatnonzero(d < 0.02):
            counts[i][j[i]] = counts[i].get(j[i], 0) + 1
    _, own = cKDTree(setup.body.v_template).query(setup.template)
    assert np.array_equal(table[:, 0], own)
    checked = 0
    for i, c in enumerate(counts):
        ranked = sorted(c.values(), reverse=True)
        if len(ranked) >= 2 and ranked[0] > ranked[1]:            # a clear favourite (no tie to order)
            top = max(c, key=c.get)
            assert top == table[i, 0] or top == table[i, 1], i
            checked += 1
        assert len(set(table[i])) == 6 and (table[i] >= 0).all()
    assert checked > setup.N // 10
    assert np.array_equal(found.near, np.array([len(c) > 0 for c in counts]))     # met the body in some frame
    assert 0 < found.near.sum() < setup.N and found.source == "simulated frames"
    written = simsup.write_contact_candidates(tmp_path / simsup.CANDIDATES_FILE, setup, [s], 6)
    back = simsup.run_contact_candidates(tmp_path)
    assert np.array_equal(back.table, written.table) and np.array_equal(back.near, written.near)
    assert back.source == written.source


def test_contact_candidates_from_an_asset_are_where_its_own_garment_meets_the_body(tiny_setup):
    """contact.candidates_from_asset (pleat-train contact-candidates --from-asset): the frames are the asset's own
    garment as the C runtime makes it with body contact off, so a vertex is near_in_motion exactly where that garment
    comes within the radius of the posed body; first candidates are the rest-nearest body vertices; META's source
    names the asset."""
    from scipy.spatial import cKDTree

    from pleat import runtime
    from pleat.eval import scene as S
    body = tiny_setup.body
    clips = simsup._clips("validation", 30.0, body)
    clip = simdata.cut(clips[sorted(clips)[0]], 0, 8)
    beta = np.zeros(body.shapedirs.shape[-1])
    found = contact.candidates_from_asset("assets/tshirt.pleat", body, [clip], [beta], 4, stride=2, radius_m=0.01)
    _, w = S.read_weights("assets/tshirt.pleat")
    body_v, _ = S.posed_body(body, clip, beta)
    rotations = S.clip_rotations_for(clip, w["joint_names"])
    near = np.zeros(len(w["template"]), bool)
    with runtime.Context() as ctx:
        inst = ctx.create_instance(ctx.load_asset(Path("assets/tshirt.pleat").read_bytes()), body_contact=False)
        for t in range(clip.num_frames):
            x, _ = inst.step(rotations[t], clip.root_translation[t], clip.root_rotation[t], 1.0 / clip.fps)
            if t % 2 == 0:
                near |= cKDTree(body_v[t]).query(x)[0] < 0.01
        inst.close()
    assert np.array_equal(found.near, near) and 0 < near.sum() < len(near)
    assert np.array_equal(found.table[:, 0], cKDTree(body.v_template).query(w["template"])[1])
    assert "the asset's own garment" in found.source


def test_a_blender_plan_keeps_the_bodies_and_windows_at_the_one_material_blender_has():
    """Blender's cloth has one material: its plan is Pleat's plan (same clips, variants, windows and β draws) with
    every segment at the default material; Pleat's own plan varies the material."""
    from types import SimpleNamespace

    from pleat import garment_asset as ga
    from pleat.train import settings
    cfg = dict(settings.defaults()["simsup"])
    clips = [SimpleNamespace(name=f"c{k}", num_frames=T) for k, T in enumerate((200, 240))]    # the plan reads these
    cfg["variants"] = ["original"]
    own = simdata.plan_segments(clips, dict(cfg, teacher="pleat"), 10, 3)
    blender = simdata.plan_segments(clips, dict(cfg, teacher="blender"), 10, 3)
    assert [(s.clip, s.variant, s.start, s.frames, s.beta) for s in own] == \
        [(s.clip, s.variant, s.start, s.frames, s.beta) for s in blender]
    assert all(s.material == tuple(ga.MATERIAL_DEFAULT) for s in blender)
    assert any(s.material != tuple(ga.MATERIAL_DEFAULT) for s in own)


def _rest_clips(frames):
    """Clips at rest of the given lengths, named a, b, c, ...: the plan reads names and lengths, variants need Clips."""
    from pleat.motion.clip import identity_clip
    return [identity_clip(T, name=chr(ord("a") + k)) for k, T in enumerate(frames)]


def test_the_default_variants_plan_the_segments_they_planned_before_blend_and_noise():
    """Adding variants changed no plan without them: the default five on two clips give the plan the planner gave
    before "blend" and "noise" existed (its first windows, its last β and a material, recorded from it), with no
    partner."""
    from pleat.train import settings
    cfg = dict(settings.defaults()["simsup"], segment_frames=12, repeats=1)
    assert cfg["variants"] == ["original", "mirrored", "fast", "slow", "collar"]
    plan = simdata.plan_segments(_rest_clips((40, 57)), cfg, 3, 5)
    assert len(plan) == 120 and all(s.partner == "" and s.clip_names == (s.clip,) for s in plan)
    assert [(s.clip, s.variant, s.start, s.frames) for s in plan[:12]] == [
        ("a", "original", 12, 12), ("a", "mirrored", 24, 12), ("a", "fast", 12, 12), ("a", "slow", 30, 12),
        ("a", "collar", 6, 12), ("b", "original", 24, 12), ("b", "mirrored", 6, 12), ("b", "fast", 0, 12),
        ("b", "slow", 54, 12), ("b", "collar", 36, 12), ("a", "original", 0, 12), ("a", "mirrored", 18, 12)]
    np.testing.assert_allclose(plan[8].material, [0.6941375977, 23799.8880658, 27903.75961796, 0.0010559221057],
                               rtol=1e-9)
    assert (plan[-1].clip, plan[-1].variant, plan[-1].start) == ("b", "collar", 30)    # the end of the draws
    np.testing.assert_allclose(plan[-1].beta, [0.18332781835, -0.47866838397, -1.27231900511], rtol=1e-9)


def test_blend_segments_hold_the_seam_into_the_next_clip_and_rebuild_from_their_names():
    """"blend": each clip cross-fades into the next clip by name (the last into the first), every window holds the
    whole cross-fade, windows of a long clip vary, and the segment names its partner, so segment_clip and an
    exported dataset's segment list rebuild it."""
    from dataclasses import asdict

    from pleat.train import settings
    clips = _rest_clips((40, 157, 60))
    by_name = {c.name: c for c in clips}
    cfg = dict(settings.defaults()["simsup"], segment_frames=30, repeats=2, variants=["blend"])
    plan = simdata.plan_segments(clips, cfg, 3, 1)
    assert {(s.clip, s.partner) for s in plan} == {("a", "b"), ("b", "c"), ("c", "a")}
    for s in plan:
        first, end = simdata.blend_seam(by_name[s.clip], by_name[s.partner])
        assert s.start <= first and end <= s.start + s.frames and s.frames == 30
        assert simdata.segment_clip(by_name, s).num_frames == 30
        assert simdata.Segment(**asdict(s)) == s and s.clip_names == (s.clip, s.partner)
    assert len({s.start for s in plan if s.clip == "b"}) > 1
    old = {k: v for k, v in asdict(plan[0]).items() if k != "partner"}     # an export from before "blend"
    assert simdata.Segment(**old).partner == ""
    assert simdata.blend_partner(["only"], "only") == "only"


@pytest.mark.parametrize("frames,cover,expected", [
    (100, None, [0, 15, 30, 45, 60]),            # the windows every variant but "blend" has (70 is not a step)
    (100, (60, 68), [41, 56]),                   # may start at 38..60: two steps, centred
    (100, (0, 8), [0]),
    (100, (92, 100), [70]),
    (20, (10, 18), [0]),                         # a clip shorter than the window: all of it
])
def test_window_starts_cover_what_they_must(frames, cover, expected):
    """Half-overlapping 30-frame windows; given a span to cover, only windows holding it whole, centred in where
    they can start."""
    starts = simdata.window_starts(frames, min(30, frames), cover)
    assert starts == expected
    for s in starts:
        assert 0 <= s <= max(frames - 30, 0)
        if cover is not None:
            assert s <= cover[0] and cover[1] <= s + min(30, frames)


def test_an_exported_blend_segment_comes_back_with_its_partner_and_leaves_with_either_source(tiny_setup, tmp_path):
    """A "blend" segment in an export (export_dataset / import_dataset) rebuilds its X_c rows from its clip and its
    partner; leaving out either clip's motion folder drops it, and a motion folder without the partner is refused
    naming it."""
    from pleat.cli import InputError
    setup = tiny_setup
    clips = simsup._clips("train", setup.cfg["fps"], setup.body)
    pairs = [(n, simdata.blend_partner(clips, n)) for n in sorted(clips)]
    pairs = [(n, p) for n, p in pairs if simsup.source_of(n) != simsup.source_of(p)]
    if not pairs:
        pytest.skip("the training clips here come from one motion folder")
    name, partner = pairs[0]
    frames = 20
    played = simdata.variant_clip(clips[name], "blend", clips[partner])
    start = simdata.window_starts(played.num_frames, frames, simdata.blend_seam(clips[name], clips[partner]))[0]
    seg = simdata.Segment(name, "blend", start, frames, tuple(np.zeros(setup.B)),
                          tuple(simdata.ga.MATERIAL_DEFAULT), partner)
    path = tmp_path / "data.npz"
    simsup.export_dataset(path, [(seg, None)], [{"disp": np.zeros((frames, setup.N, 3))}], [])
    done, seqs, _ = simsup.import_dataset(path, setup, clips, {}, 6)
    assert [d[0] for d in done] == [seg] and seqs[0]["static"].shape == (frames, setup.input_count)
    expected = simdata.sequence(setup, simdata.segment_clip(clips, seg), np.array(seg.beta), np.array(seg.material))
    np.testing.assert_array_equal(seqs[0]["static"], expected["static"])
    for source in (simsup.source_of(name), simsup.source_of(partner)):
        assert simsup.import_dataset(path, setup, clips, {}, 6, leave_out={source})[0] == []
    with pytest.raises(InputError, match=partner):
        simsup.import_dataset(path, setup, {n: c for n, c in clips.items() if n != partner}, {}, 6)


def test_teacher_only_sequences_are_new_unsimulated_frames_of_the_training_motion(tiny_setup):
    """A tier's extra data: X_c rows of training-clip segments at new β and materials (another plan seed), at
    least the frames asked for, with the latent block zero as a simulated sequence's rows have it."""
    setup = tiny_setup
    clips = simsup._clips("train", setup.cfg["fps"], setup.body)
    seqs = simsup.teacher_only_sequences(setup, clips, 200, seed=0)
    frames = sum(len(s["static"]) for s in seqs)
    assert 200 <= frames < 200 + setup.cfg["simsup"]["segment_frames"]
    assert all(s["static"].shape[1] == setup.input_count and not s["static"][:, :setup.L].any() for s in seqs)
    assert "disp" not in seqs[0]                               # nothing was simulated
    betas = np.array([s["beta"] for s in seqs])
    assert len(np.unique(betas.round(6), axis=0)) > 1          # new bodies, not only the mean one
    # another plan than the simulated one (plan_segments at the run's own seed), so not the same (β, window)s
    simulated = simdata.plan_segments(list(clips.values()), setup.cfg["simsup"], setup.B, setup.cfg["seed"])
    first_sim = {tuple(np.round(s.beta, 6)) for s in simulated[:len(seqs)] if any(s.beta)}
    assert not first_sim & {tuple(b) for b in betas.round(6) if b.any()}


def test_a_runs_validation_simulations_are_the_ones_pleat_eval_reads_for_its_asset(tiny_setup):
    """The recipe simulates its validation clips at the default material as an asset stores it (float32), so the
    cache entry is the one pleat-eval's reference of the packed asset looks up (β = 0, the first 60 frames): a suite
    after training simulates nothing twice."""
    from pleat import garment_asset as ga
    from pleat.asset import read_asset, write_asset
    from pleat.eval import scene as S
    from pleat.eval.reference import cache_entry
    from pleat.garment import Garment
    setup = tiny_setup
    stored = read_asset(write_asset(None, ga.weights_from_garment(setup.garment, setup.body)))
    val = simsup._clips("validation", 30.0, setup.body)
    name = sorted(val)[0]
    seg = simdata.Segment(name, "original", 0, min(60, val[name].num_frames), tuple(np.zeros(setup.B)),
                          simsup.validation_material())
    train_key = cache_entry(Garment.build(**simdata.garment_arrays(setup)), setup.body,
                            simdata.segment_clip({name: val[name]}, seg), np.array(seg.beta), np.array(seg.material),
                            seg.frames)[1]
    eval_key = cache_entry(S.garment_from_asset(stored), setup.body, S.load_motion(name, setup.body, S.EVAL_FPS, 60),
                           np.zeros(len(stored["shape_blend"])), np.asarray(stored["material_default"], np.float64),
                           60)[1]
    assert train_key == eval_key
