"""The simulator-supervised recipe: `pleat-train simsup` (docs/training.md, "Recipes").

    pleat-train simsup --preset default --garment tshirt --out out/train/simsup --max-minutes 110 --workers 2

1. Simulate (`pleat.train.simdata`): training-clip segments at sampled β and material on `workers` processes, through
   the simulation cache, for `simsup.simulate_share` of the budget; the validation clips at β = 0 and the default
   material (pleat-eval's setting) are simulated too, for the verdict only.
2. Fit the compact latent space and the blend shapes to the un-skinned simulated frames, and the latent predictor
   on them, at the shipped sizes (L = D = 128, f_dec 2×512, f_LP 3×512): `pleat.train.distill.distill` with the
   simulator as the teacher (principal blend shapes, f_dec, then f_LP fed its own predictions as in stage 2).
3. Pack, with the recipe, the data and the CPU time in META, and print a plain verdict against LBS-only on the
   validation clips (posed mean vertex error against the simulator, in mm).
Every step resumes: the simulations are cached, the fitted model is checkpointed (simsup.pt).
"""
import functools
import json
import sys
import time
from pathlib import Path

import numpy as np
import torch

from pleat import fileio
from pleat.train import core, distill, forkpool, simdata, sources, tasks
from pleat.train.runfolder import (CANDIDATES_FILE, load_model, model_name, run_contact_candidates,  # noqa: F401
                                   write_run)
from pleat.train.shim import model_shim


def _clips(split, fps, body, required=True):
    """{split name: the pleat.motion Clip at `fps`, named by its split name} for the training or validation clips
    that the motion folder has (pleat.motion.split.available: the missing ones are left out with one warning; none
    is an error unless not `required`)."""
    from dataclasses import replace

    from pleat.motion import load_clip
    from pleat.motion.split import available
    return {n: replace(load_clip(n, body=body).resample(fps), name=n)
            for n in available(split, required=required)}


def source_of(clip_name):
    """The motion folder a clip of the split comes from (deepmimic_github/humanoid3d_jog → deepmimic_github)."""
    return clip_name.split("/")[0]


def split_clips(cfg, body):
    """(training clips, validation clips) of the split that are there, at cfg's fps, without the training clips of
    the motion folders in simsup.exclude_sources."""
    leave_out = set(cfg["simsup"]["exclude_sources"])
    train = {n: c for n, c in _clips("train", cfg["fps"], body).items() if source_of(n) not in leave_out}
    return train, _clips("validation", cfg["fps"], body)


def run_data(setup, data, clips=None):
    """A run's exported data (load_datasets) as the run's settings take it: without the left-out motion folders'
    segments, simsup.data_segments of them (thinned_data). clips: (training, validation) clips, default
    split_clips."""
    train_clips, val_clips = clips or split_clips(setup.cfg, setup.body)
    c = setup.cfg["simsup"]
    return thinned_data(load_datasets(setup, data, train_clips, val_clips, c["validation_frames"],
                                      set(c["exclude_sources"])), c["data_segments"])


def thinned_data(loaded, count):
    """load_datasets' result with `count` of its training segments, evenly spaced through it (0: all): an export is
    in plan order, clip after clip, so evenly spaced segments keep every clip's share — the same data, less of it
    (e.g. a control of the same size as a run that left a source out)."""
    done, seqs, val, sim_cpu, val_cpu = loaded
    if not count or count >= len(seqs):
        return loaded
    keep = np.unique(np.round(np.linspace(0, len(seqs) - 1, int(count))).astype(np.int64))
    return [done[k] for k in keep], [seqs[k] for k in keep], val, sim_cpu, val_cpu


def load_datasets(setup, data, train_clips, val_clips, validation_frames, leave_out=()):
    """Several exported datasets ("a.npz,b.npz") as one: (done, training sequences, the first file's validation
    sequences, simulation CPU s summed, validation CPU s) — the CPU times from each file's .json when present.
    leave_out: motion folders whose training segments are dropped (simsup.exclude_sources)."""
    done, seqs, val, sim_cpu, val_cpu = [], [], None, 0.0, 0.0
    for part in str(data).split(","):
        d, q, v = import_dataset(part, setup, train_clips, val_clips, validation_frames, leave_out)
        done, seqs, val = done + d, seqs + q, val or v
        info = Path(part).with_suffix(".json")
        prev = json.loads(info.read_text()) if info.exists() else {}
        sim_cpu += prev.get("simulation_cpu_s", 0.0)
        val_cpu = val_cpu or prev.get("validation_cpu_s", 0.0)
    return done, seqs, val, sim_cpu, val_cpu


@torch.no_grad()
def free_run(lp, static, setup_latent):
    """The model from a reset (Z_0 = 0, as the runtime runs it) over a sequence's X_c rows [T, I]: (the rows with
    the model's own latent block in place of the `setup_latent`-wide one they were assembled with, the latents it
    predicts [T, L])."""
    L = int(lp.z_mean.shape[0])
    rows = np.concatenate([np.zeros((len(static), L)), static[:, setup_latent:]], 1)
    z = torch.zeros(L)
    zs = []
    for row in torch.as_tensor(rows, dtype=torch.float32):
        _, z = lp(z, row)
        zs.append(z)
    return rows, torch.stack(zs)


@torch.no_grad()
def displacements(block, z, dtype=torch.float32):
    """The blend-shape displacement [T, N, 3] (rest frame) for latents z [T, L], summed in `dtype`."""
    return torch.einsum("td,dnc->tnc", block.decoder(z).to(dtype), block.exported_blend_shapes().to(dtype))


@torch.no_grad()
def posed_errors(lp, block, seqs, setup_latent):
    """Free-running from a reset on sequences with their skinning "A" and simulated "positions": mean per-vertex
    distance to the simulation (mm) of the model and of LBS-only, per sequence."""
    out = []
    for s in seqs:
        _, z = free_run(lp, s["static"], setup_latent)
        A = torch.as_tensor(s["A"])
        shaped = torch.as_tensor(s["shaped"])
        x_sim = torch.as_tensor(s["positions"], dtype=torch.float64)
        x = torch.einsum("tnab,tnb->tna", A[..., :3], shaped + displacements(block, z, torch.float64)) + A[..., 3]
        lbs = torch.einsum("tnab,nb->tna", A[..., :3], shaped) + A[..., 3]
        out.append({"clip": s.get("name", ""), "pleat_mm": 1e3 * float((x - x_sim).norm(dim=-1).mean()),
                    "lbs_mm": 1e3 * float((lbs - x_sim).norm(dim=-1).mean())})
    return out


def validation_material():
    """The default material as a packed asset stores it (float32, CONF): what pleat-eval simulates the asset's
    validation clips at, so the run's validation simulations are the very ones (the same cache entries) that
    pleat-eval and pleat-eval-suite read for the asset it packs."""
    return tuple(float(np.float32(v)) for v in simdata.ga.MATERIAL_DEFAULT)


def validation_sequences(setup, clips, frames, workers, cache_dir, log, runner=None):
    """pleat-eval's validation setting (β = 0, the default material as the asset stores it, the first `frames`
    frames) on every validation clip, simulated through the same cache (misses as tasks of `runner`, default
    `workers` local processes), as sequences with what posed_errors needs."""
    beta = np.zeros(setup.B)
    mat = validation_material()
    segs = [simdata.Segment(n, "original", 0, min(frames, c.num_frames), tuple(beta), mat) for n, c in clips.items()]
    done, cpu_s = simdata.simulate_segments(setup, segs, workers, cache_dir, log=log, runner=runner)
    seqs = []
    for seg, path in done:
        with np.load(path, allow_pickle=False) as z:
            seqs.append(_validation_sequence(setup, clips[seg.clip], z["positions"][:seg.frames]))
    return seqs, cpu_s


def export_dataset(path, done, seqs, val, components=256):
    """The simulated data in a portable npz (what a many-core machine sends back): the segments, the training
    displacements as their top-`components` principal coefficients (float16) and basis, the validation positions
    in full. X_c rows are not stored: they follow from the segments."""
    X = np.concatenate([s["disp"].reshape(len(s["disp"]), -1) for s in seqs])
    _, S, Vt = np.linalg.svd(X, full_matrices=False)
    # keep the file under 16 MB (what a device run may send back): ≤ 6 M float16 coefficients
    K = min(components, len(S), max(16, int(6e6 // len(X))))
    coeff = X @ Vt[:K].T
    resid = float(np.sqrt(max((S[K:] ** 2).sum(), 0.0) / X.size)) * 1e3
    lengths = [len(s["disp"]) for s in seqs]
    segs = [dict(seg.__dict__) for seg, _ in done]
    vals = {f"val_positions_{i}": np.asarray(v["positions"], np.float32) for i, v in enumerate(val)}
    fileio.save_npz(path, compressed=True, segments=json.dumps(segs), lengths=np.array(lengths),
                    basis=Vt[:K].astype(np.float32), coefficients=coeff.astype(np.float16), residual_rms_mm=resid)
    fileio.save_npz(_val_path(path), compressed=True, val_segments=json.dumps([v["name"] for v in val]), **vals)
    return resid


def import_dataset(path, setup, train_clips, val_clips, validation_frames, leave_out=()):
    """Inverse of export_dataset: (done [(segment, None)], training sequences, validation sequences), without the
    training segments of the motion folders in `leave_out`."""
    with np.load(path, allow_pickle=False) as z:
        segs = [simdata.Segment(**{k: (tuple(v) if isinstance(v, list) else v) for k, v in d.items()})
                for d in json.loads(str(z["segments"]))]
        disp = z["coefficients"].astype(np.float64) @ z["basis"].astype(np.float64)
        lengths = z["lengths"]
    with np.load(_val_path(path), allow_pickle=False) as z:
        names = json.loads(str(z["val_segments"]))
        val_pos = [z[f"val_positions_{i}"] for i in range(len(names))]
    keep = [all(source_of(n) not in leave_out for n in seg.clip_names) for seg in segs]
    gone = sorted({n for seg, k in zip(segs, keep) if k for n in seg.clip_names if n not in train_clips} |
                  set(names) - set(val_clips))
    if gone:       # simulated on clips this motion folder lacks: their X_c rows cannot be rebuilt
        from pleat.cli import InputError
        raise InputError(path, f"was simulated on clips that are not in the motion folder: {', '.join(gone)}")
    seqs, o = [], 0
    for seg, T, k in zip(segs, lengths, keep):
        o += T
        if not k:
            continue
        clip = simdata.segment_clip(train_clips, seg)
        s = simdata.sequence(setup, clip, np.array(seg.beta), np.array(seg.material))
        s["disp"] = disp[o - T:o].reshape(T, setup.N, 3)
        seqs.append(s)
    val = [_validation_sequence(setup, val_clips[n], pos) for n, pos in zip(names, val_pos)]
    return [(s, None) for s, k in zip(segs, keep) if k], seqs, val


def _val_path(path):
    return Path(path).with_name(Path(path).stem + "_validation.npz")


def _validation_sequence(setup, clip, pos):
    beta, mat = np.zeros(setup.B), np.array(validation_material())
    clip = simdata.cut(clip, 0, len(pos))
    s = simdata.sequence(setup, clip, beta, mat, pos)
    s.update(A=simdata.blend_matrices(setup, s["M"]), shaped=setup.shaped(beta), positions=pos, name=clip.name)
    return s


def train(cfg, garment, out, workers=2, max_minutes=None, device="auto", progress=True, cache_dir=None,
          data=None, export=None, user_sims=None, user_only=False, runner=None):
    """The recipe above; returns (asset path, summary). `runner` (pleat.train.tasks) runs the simulations and the
    fits; default this machine: `workers` processes for the simulations, simsup.fit_workers forked fits."""
    from pleat.eval.reference import DEFAULT_CACHE, check_teacher
    from pleat.eval.tiers import tier
    from pleat.cli import InputError
    t_start = time.time()
    c = cfg["simsup"]
    out = Path(out)
    cache_dir = Path(cache_dir or DEFAULT_CACHE)
    if user_only and not user_sims:
        raise InputError(None, "--user-sim-only needs at least one --user-sim training simulation")
    try:
        check_teacher(c["teacher"])
    except ValueError as exc:
        raise InputError(None, f"simsup.teacher: {exc}") from None
    setup = core.Setup(cfg, garment, "cpu")
    budget_s = 60.0 * max_minutes if max_minutes else None

    # 1. inputs, all read and checked before the run folder is written (a bad input leaves nothing behind): the
    # user's own simulations first, since they are the likeliest to be wrong, then the split's clips that are there
    user_train, user_val, user_info = user_simulations(setup, user_sims, cfg["fps"], None, progress)
    if user_only and not user_train:
        raise InputError(None, "--user-sim-only needs at least one --user-sim training simulation (all given have "
                               "role=validation)")
    # --user-sim-only trains on no clip of the split, and validates on the split's clips only without a user
    # validation simulation (then on those that are there, if any)
    train_clips = {} if user_only else split_clips(cfg, setup.body)[0]
    if c["exclude_sources"] and not train_clips and not user_train:
        raise InputError(None, "simsup.exclude_sources leaves no training clip "
                               f"({', '.join(sorted(c['exclude_sources']))})")
    val_clips = {} if user_only and user_val else _clips("validation", cfg["fps"], setup.body, required=not user_only)
    if c["validation_limit"]:
        val_clips = dict(list(val_clips.items())[:int(c["validation_limit"])])
    loaded = run_data(setup, data, (train_clips, val_clips)) if data else None
    run = core.Run(out, "simsup", cfg, 0)
    for info in user_info:
        run.log({"user_simulation": info})

    def log(rec):
        run.log(rec)
        if progress and "segment" in rec and rec["segment"] % 10 == 0:
            print(f"simsup: segment {rec['segment']} {rec['clip']} ({rec['variant']}) {rec['cpu_s']} CPU s",
                  file=sys.stderr)

    # 2. data
    segments = simdata.plan_segments(list(train_clips.values()), c, setup.B, cfg["seed"]) if train_clips else []
    # skip_segments: a second machine continues the same plan where the first stopped
    segments = segments[c["skip_segments"]:]
    segments = segments[:c["max_segments"]] if c["max_segments"] else segments
    if data:
        done, seqs, val, sim_cpu, val_cpu = loaded
    else:
        val, val_cpu = [], 0.0
        if not c["skip_validation"]:    # a second data machine need not simulate the validation clips again
            val, val_cpu = validation_sequences(setup, val_clips, c["validation_frames"], workers, cache_dir, log,
                                                runner)
        deadline = None if budget_s is None else t_start + c["simulate_share"] * budget_s
        done, sim_cpu = simdata.simulate_segments(setup, segments, workers, cache_dir, deadline, log, runner)
        seqs = simdata.load_sequences(setup, done, train_clips)
    if export:
        resid = export_dataset(export, done, seqs, val)
        fileio.write_text(Path(export).with_suffix(".json"), json.dumps(
            {"simulation_cpu_s": sim_cpu, "validation_cpu_s": val_cpu, "residual_rms_mm": resid,
             "segments": len(seqs), "frames": int(sum(len(s["disp"]) for s in seqs)),
             "wall_s": time.time() - t_start, "hardware": core.hardware()}))
        if c["export_only"]:
            return None, None
    seqs, val = seqs + user_train, val + user_val
    frames = int(sum(len(s["disp"]) for s in seqs))
    if c["contact_candidates"] > 1 and seqs:  # the top tier's body contact, from where the cloth was
        write_contact_candidates(out / CANDIDATES_FILE, setup, seqs, c["contact_candidates"], progress=progress)
    run.log({"data": {"segments": len(seqs), "frames": frames, "planned_segments": len(segments),
                      "simulation_cpu_s": sim_cpu, "validation_cpu_s": val_cpu, "wall_s": time.time() - t_start}})
    if progress:
        print(f"simsup: {len(seqs)} segments, {frames} frames simulated ({sim_cpu / 3600:.2f} CPU h)", file=sys.stderr)

    # 3. fit: one model at simsup.tier, or (ensemble_members > 1) that many fits at simsup.member_tier from
    # consecutive seeds, averaged into one network at simsup.tier's sizes (pleat.train.ensemble)
    spec = tier(c["tier"])
    dev = core.device_for(device, 0)
    t_fit = time.time()
    members = c["ensemble_members"]
    students = c["students"]
    second = c["second_students"] if students > 0 else 0
    fit_deadline = None if budget_s is None else t_start + 0.85 * budget_s
    # the first fit, the students and the second round of students share the fitting budget equally
    rounds = 1 + (students > 0) + (second > 0)
    first_deadline = None if fit_deadline is None else t_fit + (fit_deadline - t_fit) / rounds
    fitter = fit_runner(c, dev, runner)
    workers = fitter.workers
    member = tier(c["member_tier"]) if members > 1 else spec
    fits = fitter.run([functools.partial(
        fit_model, seqs, setup, member, val, cfg["seed"] + k, forkpool.deadline(t_fit, first_deadline, k, members,
                                                                                workers),
        progress and workers <= 1 and fitter.name == "local", dev) for k in range(members)])
    if members > 1:
        from pleat.train import ensemble
        lp, block, norms, shim, report = ensemble.mean_of_fits(fits, setup, spec, c["member_tier"])
    else:
        lp, block, norms, shim, _, report = fits[0]
    if students > 0:      # 2b. the fit teaches students on more motion than was simulated; their mean replaces it
        end = None if fit_deadline is None else t_fit + (fit_deadline - t_fit) * 2 / rounds
        lp, block, norms, shim, report = self_distil(lp, block, setup, seqs, val, train_clips, students, report,
                                                     end, progress, runner=runner)
    if second > 0:        # 2c. (opt-in) their mean teaches a second round of smaller students (docs/training.md)
        lp, block, norms, shim, report = self_distil(lp, block, setup, seqs, val, train_clips, second, report,
                                                     fit_deadline, progress, student_tier=c["second_student_tier"],
                                                     runner=runner)
    fit_s = time.time() - t_fit
    val_err = posed_errors(lp, block, val, setup.L)
    # 4. pack
    cpu_h = (sim_cpu + val_cpu) / 3600.0 + fit_s * max(1, torch.get_num_threads()) / 3600.0
    summary = {"recipe": "simulator-supervised", "simulator": c["teacher"], "segments": len(seqs), "frames": frames,
               "clips": sorted(train_clips), "variants": list(c["variants"]),
               "simulation_cpu_h": sim_cpu / 3600.0, "fit_wall_s": fit_s, "cpu_hours": cpu_h,
               "wall_s": time.time() - t_start, "hardware": core.hardware(), "fit": report,
               "validation": val_err, "user_simulations": user_info}
    path = write_run(out, setup, cfg, garment, lp, block, norms, shim, report, summary)
    run.log({"summary": summary})
    if c["contact_iterations"] > 0:      # the last step: the contact-aware fine-tune (rewrites the asset
        path, _ = contact_tune(out, None, progress=progress, settings=c, sequences=(seqs, val),   # and says the verdict)
                               deadline=None if budget_s is None else t_start + budget_s)
    else:
        print(verdict(val_err))
    return path, summary


def write_contact_candidates(path, setup, seqs, count, stride=3, progress=False):
    """Each garment vertex's body-contact candidates, chosen from the simulated frames of `seqs`
    (pleat.train.contact.candidate_vertices), to `path` (a run folder's CANDIDATES_FILE: every asset the run packs
    afterwards uses them; or any npz for pleat-pack --contact-candidates-from). Returns the ContactCandidates."""
    from pleat.train import contact
    t0 = time.time()
    found = contact.candidate_vertices(setup, seqs, int(count), stride=int(stride))
    save_contact_candidates(path, found)
    if progress:
        print(f"simsup: {count} contact candidates per vertex from {len(seqs)} simulated sequences "
              f"({time.time() - t0:.0f} s) -> {path}", file=sys.stderr)
    return found


def save_contact_candidates(path, found):
    """A candidates file (pleat-pack --contact-candidates-from, a run folder's CANDIDATES_FILE): the table under
    'candidate_vertices', the vertices that met the body in the frames under 'near_in_motion' and where the frames
    came from under 'source' (pleat.garment_asset.read_candidates reads it)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fileio.save_npz(path, candidate_vertices=found.table, near_in_motion=found.near, source=np.array(found.source))


def user_simulations(setup, specs, fps, log=None, progress=True):
    """The user's own offline simulations (--user-sim: PC2 or npz caches with their motions, pleat.train.pointcache)
    as (training sequences, validation sequences, infos), all read and checked before anything is simulated."""
    if not specs:
        return [], [], []
    from pleat.train import pointcache
    train_seqs, val_seqs, infos = pointcache.user_sequences(setup, specs, fps, log)
    if progress:
        for info in infos:
            print(f"simsup: {pointcache.info_line(info)}", file=sys.stderr)
    return train_seqs, val_seqs, infos


def verdict(rows):
    """One plain line: better or worse than LBS-only on the validation clips, by how much."""
    if not rows:
        return "verdict: no validation clip was simulated"
    p = float(np.mean([r["pleat_mm"] for r in rows]))
    lbs = float(np.mean([r["lbs_mm"] for r in rows]))
    worse = [r["clip"].split("/")[-1] for r in rows if r["pleat_mm"] > r["lbs_mm"]]
    word = "BETTER" if p < lbs else "WORSE"
    tail = f"; worse than LBS-only on {', '.join(worse)}" if worse else "; better on every clip"
    return (f"verdict: {word} than LBS-only on {len(rows)} validation clips: {p:.1f} mm against {lbs:.1f} mm "
            f"(ratio {p / lbs:.2f}){tail}")


# ---- tiers distilled from a simulator-supervised model ------------------------------------------------------------
def teacher_sequences(lp, block, seqs, setup_latent):
    """The model's own free-running garment (from a reset, as the runtime runs it) on each sequence's X_c rows:
    sequences {"static", "disp"} with the model's displacement as the target a tier learns."""
    return [{"static": s["static"],
             "disp": displacements(block, free_run(lp, s["static"], setup_latent)[1]).double().numpy()}
            for s in seqs]


def teacher_only_sequences(setup, train_clips, frames, seed):
    """X_c rows (latent block zero) of about `frames` more training frames that were never simulated: segments
    planned as the simulated ones are (simdata.plan_segments) at another seed, so new β, materials and windows of
    the same clips and variants. A tier learns the teacher's garment, and the teacher labels any motion for the
    price of a rollout, so a tier needs not stop at the frames the simulator could afford (docs/training.md)."""
    c = setup.cfg["simsup"]
    out, total = [], 0
    if not train_clips:            # --user-sim-only: no clip of the split to label
        return out
    for seg in simdata.plan_segments(list(train_clips.values()), c, setup.B, int(seed) + 1000):
        if total >= frames:
            break
        clip = simdata.segment_clip(train_clips, seg)
        out.append(simdata.sequence(setup, clip, np.array(seg.beta), np.array(seg.material)))
        total += len(out[-1]["static"])
    return out


def teacher_data(lp, block, setup, seqs, val, train_clips, teacher_frames, seed):
    """What a student learns: the model's own garment on the simulated training sequences plus `teacher_frames`
    frames of unsimulated training motion (teacher_only_sequences at `seed`), and on the validation sequences."""
    if teacher_frames > 0:
        seqs = seqs + teacher_only_sequences(setup, train_clips, teacher_frames, seed)
    return teacher_sequences(lp, block, seqs, setup.L), teacher_sequences(lp, block, val, setup.L)


def fit_student(teacher, teacher_val, setup, spec, seed, iterations, garment=None, deadline=None):
    """One smaller (or equal) inference block distilled from a simsup model's garment (teacher_data), with the run's
    settings: distill.distill weighting the latent by energy, without the fit's f_LP noise."""
    c = setup.cfg["simsup"]
    return distill.distill(teacher, setup, spec, teacher_val, garment, seed, iterations, c["dec_iterations"],
                           c["lr"], c["batch"], c["window"], False, weight_by_energy=True, deadline=deadline,
                           latent_velocity=c["latent_velocity"])


def fit_model(seqs, setup, spec, val, seed, deadline, progress, device):
    """One fit of the model at `spec`'s sizes to simulated sequences, with the run's settings (a task: see
    pleat.train.tasks)."""
    c = setup.cfg["simsup"]
    return distill.distill(seqs, setup, spec, val, None, seed, c["iterations"], c["dec_iterations"], c["lr"],
                           c["batch"], c["window"], progress, device=device, weight_by_energy=c["weight_by_energy"],
                           deadline=deadline, noise=(c["input_noise"], c["latent_noise"]),
                           latent_velocity=c["latent_velocity"])


def fit_workers(c, device):
    """How many independent fits run side by side (simsup.fit_workers, forked children, pleat.train.forkpool): on the
    CPU only, since a GPU serves one fit at a time better."""
    return c["fit_workers"] if str(device) == "cpu" else 1


def fit_runner(c, device, runner=None):
    """Where the independent fits run: `runner` when given (pleat.train.tasks), else fit_workers forked children."""
    return runner if runner is not None and str(device) == "cpu" else tasks.Local(fit_workers(c, device))


def student_fit(lp, block, setup, seqs, val, train_clips, member, frames, seed, deadline, label=None):
    """One student (a task): the model's garment on the simulated sequences and `frames` frames of unsimulated
    motion at `seed` (teacher_data), fitted at `member`'s sizes."""
    teacher, teacher_val = teacher_data(lp, block, setup, seqs, val, train_clips, frames, seed)
    fit = fit_student(teacher, teacher_val, setup, member, seed, setup.cfg["simsup"]["iterations"],
                      deadline=deadline)
    if label:
        print(label, file=sys.stderr)
    return fit


def self_distil(lp, block, setup, seqs, val, train_clips, count, report, deadline=None, progress=False,
                student_tier=None, runner=None):
    """The fitted model teaches `count` fits at simsup.member_tier (simsup.tier when one), each on the simulated
    sequences plus simsup.tier_teacher_frames frames of unsimulated training motion at its own seed; their mean
    (pleat.train.ensemble) replaces the model. Why: the teacher labels any motion for the price of a rollout, and
    students fitted to its smooth garment on 2.5× the motion are more accurate against the simulator than the
    teacher (CHANGELOG.md, "Training"). With `student_tier` the students have that tier's sizes and their
    mean is packed at `count` times them (tiers.packed), as the second round of students does. Returns
    (lp, block, norms, shim, report); `report` is the teacher's fit report, kept in the new one."""
    from pleat.eval.tiers import packed, tier
    from pleat.train import ensemble
    c, seed = setup.cfg["simsup"], int(setup.cfg["seed"])
    if student_tier:
        member, spec = tier(student_tier), packed(student_tier, count)
    else:
        spec = tier(c["tier"])
        member = tier(c["member_tier"]) if count > 1 else spec
    frames = c["tier_teacher_frames"]
    t0 = time.time()
    fitter = fit_runner(c, "cpu", runner)
    fits = fitter.run([functools.partial(
        student_fit, lp, block, setup, seqs, val, train_clips, member, frames, seed + k,
        forkpool.deadline(t0, deadline, k, count, fitter.workers),
        f"simsup: student {k + 1} of {count} ({member.name})" if progress else None) for k in range(count)])
    extra = {"students_of": report, "teacher_only_frames": frames}
    if count == 1:
        return fits[0][0], fits[0][1], fits[0][2], fits[0][3], dict(fits[0][5], **extra)
    return ensemble.mean_of_fits(fits, setup, spec, member.name, **extra)


def tier_fit(lp, block, setup, seqs, val, train_clips, teacher_frames, name, seed, iterations, garment,
             teacher=None):
    """One student of the tier ladder (a task): the model's garment (`teacher`, or teacher_data at `seed`) fitted
    at tier `name`'s sizes on `garment` (None: the model's mesh)."""
    from pleat.eval.tiers import tier
    teacher = teacher or teacher_data(lp, block, setup, seqs, val, train_clips, teacher_frames, seed)
    t1 = time.time()
    fit = fit_student(*teacher, setup, tier(name), seed, iterations, garment)
    fit[5]["fit_wall_s"] = time.time() - t1
    return fit


def distill_tiers(run_dir, data, tiers, out_dir, iterations=None, progress=True, teacher_frames=None, seed=None,
                  keep_runs=False, workers=None, runner=None):
    """Each tier of `tiers` (pleat.eval.tiers names) distilled from the simsup model in `run_dir` on the training
    sequences of `data` (exported datasets) and `teacher_frames` more frames of unsimulated training motion
    (teacher_only_sequences; default simsup.tier_teacher_frames, else none): the tier learns the model's own
    garment, as the tiers learnt Φ's in the two-stage recipe. Writes OUT_DIR/<garment>_<tier>.pleat; returns the
    reports. With `keep_runs`, each tier on the teacher's mesh is also written as a simsup run folder
    OUT_DIR/<tier>_run (float32 weights), which `simsup-ensemble` and `simsup-contact` take. The fit's f_LP noise
    (simsup.input_noise) is not used here: a tier learns the teacher's own smooth garment, and with the noise the
    distilled small tier came out 0.9 mm worse (docs/training.md). `workers`: fits side by side (default: the run's
    simsup.fit_workers); `runner` (pleat.train.tasks) instead runs the fits and the validation simulations."""
    from pleat.eval.tiers import tier
    lp, block, _, _, setup = load_model(run_dir)
    cfg, c = setup.cfg, setup.cfg["simsup"]
    train_clips, val_clips = split_clips(cfg, setup.body)
    teacher_frames = int(c["tier_teacher_frames"] if teacher_frames is None else teacher_frames)
    if data:
        _, seqs, val, _, _ = run_data(setup, data)
    else:       # no simulated training data: the tiers learn the model on unsimulated motion only
        from pleat.cli import InputError
        from pleat.eval.reference import DEFAULT_CACHE
        if teacher_frames <= 0:
            raise InputError(run_dir, "without --data the tiers need simsup.tier_teacher_frames > 0 (the motion "
                                      "the model labels for them)")
        seqs = []
        val, _ = validation_sequences(setup, val_clips, c["validation_frames"], workers or c["fit_workers"],
                                      DEFAULT_CACHE, log=None, runner=runner)
    t0 = time.time()
    seed = cfg["seed"] if seed is None else seed
    fitter = tasks.Local(fit_workers(c, "cpu") if workers is None else max(1, int(workers))) if runner is None \
        else runner
    # forked fits share the teacher's garment at the run's seed, computed once here; a task computes its own
    # (gigabytes are cheaper to recompute than to send)
    shared = None
    if fitter.name == "local":
        shared = teacher_data(lp, block, setup, seqs, val, train_clips, teacher_frames, seed)
        if progress:
            print(f"simsup tiers: teacher rollouts on {len(shared[0])} sequences ({len(seqs)} simulated) in "
                  f"{time.time() - t0:.0f} s", file=sys.stderr)
    reports = []
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)

    def garment_of(spec):
        """None: the teacher's mesh; else the tier's own coarser remesh of the garment."""
        return sources.garment(setup.name, setup.body, spec.vertices) if (
            spec.vertices and spec.vertices < setup.N * 0.8) else None

    # Every student the tiers need, once (medium's first member is the small tier itself), fitted side by side
    # (simsup.fit_workers, pleat.train.forkpool): independent and seeded, so the same networks as one by one.
    wanted = []
    for name in tiers:
        spec = tier(name)
        for key in ([(spec.mean_of, seed + k) for k in range(2)] if spec.mean_of else [(name, seed)]):
            if key not in wanted:
                wanted.append(key)

    # each tier's mesh once (a coarser one is a remesh), before the forks
    garments = {name: garment_of(tier(name)) for name in dict.fromkeys([*tiers, *(n for n, _ in wanted)])}

    fitted = dict(zip(wanted, fitter.run([functools.partial(
        tier_fit, lp, block, setup, seqs, val, train_clips, teacher_frames, name, s, iterations or c["iterations"],
        garments[name], shared if s == seed else None) for name, s in wanted])))

    def student(spec, s):
        return fitted[spec.name, s]

    for name in tiers:
        spec = tier(name)
        garment = garments[name]
        if spec.mean_of:        # two students at the member tier's sizes, packed as one network (pleat.train.ensemble)
            from pleat.train import ensemble
            pair = [student(tier(spec.mean_of), seed + k) for k in range(2)]
            tlp, tblock, norms, shim, rep = ensemble.mean_of_fits(
                pair, setup, spec, spec.mean_of, students_of={"teacher_run": str(run_dir)},
                teacher_only_frames=teacher_frames, fit_wall_s=sum(f[5]["fit_wall_s"] for f in pair))
            g = setup.garment
        else:
            tlp, tblock, norms, shim, g, rep = student(spec, seed)
            rep = dict(rep)
        if garment is None:
            rep["simulator_validation"] = posed_errors(tlp, tblock, val, setup.L)
        path = out_dir / f"{setup.name}_{name}.pleat"
        what = (f"the mean of two {spec.mean_of} inference blocks distilled from the simulator-supervised model, "
                f"packed as one network" if spec.mean_of else
                "inference block distilled from the simulator-supervised model")
        distill.pack_tier(path, tlp, tblock, norms, shim, g, setup, rep, cfg["fps"], fp16=True,
                          teacher=f"simulator-supervised model {run_dir}", model=f"pleat tier {name}: {what}")
        rep["asset"] = str(path)
        if keep_runs and g is setup.garment:
            run_cfg = json.loads(json.dumps(cfg))
            run_cfg["simsup"]["tier"] = name
            summary = {"recipe": "distilled from a simulator-supervised model", "teacher": str(run_dir),
                       "teacher_only_frames": teacher_frames, "seed": seed,
                       "cpu_hours": rep["fit_wall_s"] / 3600.0, "fit": rep,
                       "validation": rep.get("simulator_validation")}
            run = out_dir / f"{name}_run"
            run.mkdir(exist_ok=True)
            write_run(run, setup, run_cfg, setup.garment_spec, tlp, tblock, norms, shim, rep, summary)
            rep["run"] = str(run)
        reports.append(rep)
        if progress:
            print(f"simsup tiers: {name} → {path} in {rep['fit_wall_s']:.0f} s", file=sys.stderr)
    return reports


# ---- contact-aware fine-tune ---------------------------------------------------------------------------------------
def own_latents(lp, seqs, setup_latent):
    """Per sequence: X_c rows with the model's latent block and the model's own free-running latents from a reset
    (where the runtime's latent is at each frame): what the fine-tune's windows start from."""
    out = []
    for s in seqs:
        rows, z = free_run(lp, s["static"], setup_latent)
        out.append({"static": rows, "z": z.double().numpy()})
    return out


# The fine-tune asked for on a run that had none (its simsup.contact_iterations 0): the shipped recipe's length.
RETUNE_ITERATIONS = 1500


def contact_tune(run_dir, data, iterations=None, progress=True, settings=None, sequences=None, deadline=None):
    """pleat.train.contact on the simsup model in `run_dir`, on the sequences of `data`; rewrites simsup.pt (the
    fitted model is kept as simsup_fit.pt) and the packed asset, and prints the verdict again. `iterations`: default
    the run's simsup.contact_iterations, RETUNE_ITERATIONS where that is 0; `settings`: contact_* values that win
    over the run's own (checked ones: settings.parse_set)."""
    from pleat.train import contact
    run_dir = Path(run_dir)
    lp, block, norms, shim, setup = load_model(run_dir)
    cfg = setup.cfg
    # the contact_* settings of this call (--set simsup.contact_weight=…) win over the run's own
    c = dict(cfg["simsup"], **{k: v for k, v in (settings or {}).items() if k.startswith("contact_")})
    if sequences is None:
        _, seqs, val, _, _ = run_data(setup, data)
    else:
        seqs, val = sequences
    before = posed_errors(lp, block, val, setup.L)
    t0 = time.time()
    tensors = contact.prepare(setup, seqs)
    train = own_latents(lp, seqs, setup.L)
    run = core.Run(run_dir, "contact", cfg, 0)
    if progress:
        print(f"contact: {len(seqs)} sequences prepared in {time.time() - t0:.0f} s", file=sys.stderr)

    def log(rec):
        run.log(rec)
        if progress:
            print(f"contact: {rec}", file=sys.stderr)
    rep = contact.finetune(lp, block, train, tensors, iterations or c["contact_iterations"] or RETUNE_ITERATIONS,
                           lr=c["contact_lr"], w_contact=c["contact_weight"], eps_m=c["contact_eps_m"], log=log,
                           deadline=deadline, w_strain=c["contact_strain_weight"])
    after = posed_errors(lp, block, val, setup.L)
    state = torch.load(run_dir / "simsup.pt", weights_only=False)
    if not (run_dir / "simsup_fit.pt").exists():
        fileio.save_torch(run_dir / "simsup_fit.pt", state)
    summary = json.loads((run_dir / "simsup_summary.json").read_text())
    summary.setdefault("contact_rounds", []).append(rep)
    summary.update(contact=rep, validation_before_contact=summary.get("validation_before_contact", before),
                   validation=after,
                   cpu_hours=summary["cpu_hours"] + rep["time_s"] * max(1, torch.get_num_threads()) / 3600.0)
    path = write_run(run_dir, setup, state["config"], state["garment"], lp, block, state["norms"], shim,
                     state["report"], summary, contact_tuned=True, contact=rep)
    print(verdict(after))
    return path, rep


def run_from_asset(asset, garment, cfg, run_dir):
    """A simsup run folder (simsup.pt, simsup_summary.json) rebuilt from a packed simulator-supervised asset, so a
    model trained elsewhere (its checkpoint not at hand) can be fine-tuned here. Weights come back at the asset's
    precision (fp16 matrices)."""
    from pleat.eval import scene as S
    from pleat.eval.tiers import tier
    from pleat.train.model import InferenceBlock, linear_layers
    _, w = S.read_weights(asset)
    meta = json.loads(w.get("metadata_json") or "{}")
    setup = core.Setup(cfg, garment, "cpu")
    spec = tier(cfg["simsup"]["tier"])
    norms = {k: np.asarray(w[k], np.float64) for k in ("x_mean", "x_std", "z_mean", "z_std", "z_min", "z_max")}
    L, D = len(norms["z_mean"]), int(w["blend_shapes"].shape[0])
    shim = model_shim(setup, L, D, spec.lp_hidden, spec.dec_hidden, spec.activation, setup.L)
    lp = core.LatentPredictor(shim, norms)
    block = InferenceBlock(shim.cfg["model"], setup.N, free_mask=setup.free_mask)
    with torch.no_grad():
        for prefix, seq in (("lp", lp.lp), ("dec", block.decoder)):
            for i, lin in enumerate(linear_layers(seq)):
                lin.weight.copy_(torch.as_tensor(np.asarray(w[f"{prefix}.{i}.weight"], np.float32)))
                lin.bias.copy_(torch.as_tensor(np.asarray(w[f"{prefix}.{i}.bias"], np.float32)))
        block.blend_shapes.copy_(torch.as_tensor(np.asarray(w["blend_shapes"], np.float32)))
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    training = meta.get("training", {})
    report = dict(meta.get("distillation", {}), source_asset=str(asset))
    fileio.save_torch(run_dir / "simsup.pt", {"lp": lp.state_dict(), "block": block.state_dict(), "norms": norms,
                                              "report": report, "config": cfg, "garment": garment})
    fileio.write_text(run_dir / "simsup_summary.json", json.dumps(dict(training, source_asset=str(asset)), indent=1,
                                                                  default=str))
    return run_dir
