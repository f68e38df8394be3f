"""Quality tiers by distillation from the stage-1 teacher Φ (docs/pareto.md).

A tier is a smaller inference block Ψ' = f_LP' → f_dec' → D' blend shapes trained to reproduce the stage-1 teacher:
the paper's stage 2 generalised from "f_LP on Φ's own latent" to "a whole smaller block on Φ's garment".

    pleat-distill --teacher RUN_DIR --tier xsmall small medium --out assets/ --fp16 \
        [--recording out/tiers/teacher_rollouts.npz]      # → assets/<garment>_<tier>.pleat

1. Record Φ rollouts (no gradients) over training clips with random β and material, as stage 2 does
   (`core.record_latents`): per frame the X_c row and Φ's latent Z, and from Z the teacher's garment displacement
   d = Σ_j f_dec(Z)_j D_j in the rest frame (before skinning) [N, 3].
2. Blend shapes: the top-D' principal directions of the recorded displacements (uncentred SVD, so that zero weights
   still mean LBS), scaled by their RMS coefficient, D'_k = σ_k v_k. A tier on a coarser mesh (its own remesh of the
   same garment, `pleat.garment`) gets the displacements transferred first by barycentric interpolation at the
   closest point of the teacher's mesh.
3. Latent Z' = the top-L' PCA coefficients c_k / σ_k (unit RMS). f_dec': Z' → the D' coefficients (MSE weighted by
   σ², i.e. the displacement error in m²). f_LP': X_c (latent block = its own previous Z', Z'_0 = 0) → Z', trained
   exactly as stage 2 trains f_LP (normalised targets, windows fed their own clamped predictions), with the
   asset's normalisation and clamp baked in (`core.LatentPredictor`).
4. Packed by the training pack code (`core.network_weights` → `garment_asset.weights_from_garment` → `write_asset`).
"""
import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import torch

from pleat.cli import add_quiet, command
from pleat.fileio import save_npz, write_text
from pleat.train import core, sources
from pleat.train.model import InferenceBlock
from pleat.train.runfolder import pack_tier  # noqa: F401  (pleat.train.distill.pack_tier: its callers' name)
from pleat.train.shim import model_shim as _shim


# ---- recording -------------------------------------------------------------------------------------------------
@torch.no_grad()
def teacher_displacements(block, z):
    """Φ's garment displacement [T, N, 3] (rest frame, before skinning) for latents z [T, L]."""
    return block.displacement(torch.as_tensor(np.asarray(z), dtype=torch.float32)).numpy().astype(np.float64)


def record(run_dir, sequences, frames, seed=0, split="train", reuse_stage2=True, progress=False):
    """Teacher rollouts: list of {"static": X_c rows [T, I] (latent block zero), "z": [T, L], "disp": [T, N, 3]}.
    With `reuse_stage2`, the teacher run's own stage-2 recording (stage2_latents.npz, same rollouts) is used first."""
    model, setup, cfg, _ = core.load_stage1(run_dir)
    seqs = []
    p = Path(run_dir) / "stage2_latents.npz"
    if reuse_stage2 and p.exists() and split == "train":
        with np.load(p, allow_pickle=True) as d:
            seqs = [dict(s) for s in d["train"]][:sequences]
    if len(seqs) < sequences:
        clips = sources.clips(split, cfg["fps"], cfg["clips"]["train_limit"] if split == "train"
                              else cfg["clips"]["validation_limit"] or None, cfg["clips"]["frames_limit"] or None,
                              setup.body)
        rng = np.random.default_rng([seed, 7, 0 if split == "train" else 1])
        t0 = time.time()
        seqs += core.record_latents(setup, model, clips, sequences - len(seqs), frames, rng)
        if progress:
            print(f"recorded {split}: {len(seqs)} sequences in {time.time() - t0:.0f} s", file=sys.stderr)
    for s in seqs:
        s["disp"] = teacher_displacements(model.block, s["z"])
    return seqs, setup, model


# ---- mesh transfer ---------------------------------------------------------------------------------------------
def barycentric_transfer(src_vertices, src_faces, points):
    """Sparse [M, N] matrix P with P @ f ≈ f at `points`: barycentric interpolation at the closest point of the
    source mesh (rows sum to 1). Closest points by gpytoolbox's AABB query (libigl), a base dependency."""
    import gpytoolbox
    import scipy.sparse as sp
    v = np.asarray(src_vertices, np.float64)
    f = np.asarray(src_faces, np.int64)
    p = np.asarray(points, np.float64)
    _, tri, bary = gpytoolbox.squared_distance(p, v, f.astype(np.int32), use_cpp=True)
    faces = f[np.asarray(tri, np.int64)]
    bary = np.clip(np.asarray(bary, np.float64), 0.0, None)
    bary /= bary.sum(1, keepdims=True)
    rows = np.repeat(np.arange(len(points)), 3)
    return sp.csr_matrix((bary.ravel(), (rows, faces.ravel())), shape=(len(points), len(src_vertices)))


def transfer(seqs, P):
    out = []
    for s in seqs:
        d = s["disp"]
        moved = np.stack([P @ d[:, :, c].T for c in range(3)], -1).transpose(1, 0, 2)   # [T, M, 3]
        out.append(dict(s, disp=moved))
    return out


# ---- the tier -------------------------------------------------------------------------------------------------
def principal_shapes(seqs, D, free_mask=None):
    """Top-D uncentred principal directions of the displacements: blend shapes [D, N, 3] = σ_k v_k and σ [D].
    From the 3N × 3N Gram matrix, summed over chunks of frames: with teacher-only frames (simsup.distill_tiers) the
    frames outnumber 3N thirtyfold, and an SVD of them all at once holds several copies of a 2.4 GB matrix."""
    mask = None if free_mask is None else np.repeat(np.asarray(free_mask, np.float64), 3)[None]
    gram, rows, chunk, pending = 0.0, 0, [], 0
    for k, s in enumerate(seqs):
        chunk.append(s["disp"].reshape(len(s["disp"]), -1))
        pending += len(chunk[-1])
        if pending >= 4096 or k == len(seqs) - 1:
            X = np.concatenate(chunk)
            X = X * mask if mask is not None else X
            gram, rows, chunk, pending = gram + X.T @ X, rows + len(X), [], 0
    evals, V = np.linalg.eigh(gram)
    order = np.argsort(evals)[::-1]
    S, Vt = np.sqrt(np.maximum(evals[order], 0.0)), V[:, order].T
    # directions the teacher never uses (beyond the data's rank) would only add noise targets for f_LP'
    D = max(1, min(D, int(np.sum(S > 1e-6 * S[0]))))
    sigma = np.maximum(S[:D] / np.sqrt(rows), 1e-9)
    shapes = (sigma[:, None] * Vt[:D]).reshape(D, -1, 3)
    energy = float((S[:D] ** 2).sum() / max((S ** 2).sum(), 1e-30))
    return shapes, sigma, Vt[:D], energy


def coefficients(s, Vt, sigma):
    """A sequence's displacements as blend-shape coefficients [T, D], unit RMS over the data."""
    return s["disp"].reshape(len(s["disp"]), -1) @ Vt.T / sigma


def velocity_scale(seqs, Vt, sigma, K):
    """RMS frame-to-frame change of the first K coefficients over the sequences [K] (what the latent's velocity
    components are divided by, so that they have unit RMS like the others)."""
    d = np.concatenate([np.diff(coefficients(s, Vt, sigma)[:, :K], axis=0) for s in seqs if len(s["disp"]) > 1])
    return np.maximum(np.sqrt((d ** 2).mean(0)), 1e-9)


def tier_sequences(seqs, Vt, sigma, L, teacher_L, velocity=None):
    """Per sequence: X_c rows with the tier's latent block (zero), targets z' (first L coefficients), c (all D).
    velocity (K, scale [K]): K more latent components after the L, the change of the first K coefficients since the
    previous frame divided by `scale` (zero at a sequence's first frame, which follows a reset). The coefficients
    alone say where the cloth is, not where it is going: f_LP, which sees only its own previous latent and the
    pose, cannot tell a skirt swinging out from one swinging back once the body holds still; with the change in its
    state it can (docs/training.md, "Sudden stops")."""
    out = []
    for s in seqs:
        coeff = coefficients(s, Vt, sigma)          # [T, D]
        z = coeff[:, :L]
        if velocity is not None:
            K, scale = velocity
            dz = np.diff(coeff[:, :K], axis=0, prepend=coeff[:1, :K]) / scale
            z = np.concatenate([z, dz], 1)
        static = np.concatenate([np.zeros((len(coeff), z.shape[1])), s["static"][:, teacher_L:]], 1)
        out.append({"static": static, "z": z, "c": coeff})
    return out


def train_decoder(block, seqs, sigma, iterations, lr, batch, gen, noise=0.05, dev="cpu"):
    """f_dec': Z' → coefficients, MSE weighted by σ² (the displacement error). Inputs get a little noise so the
    decoder is smooth around f_LP's imperfect predictions."""
    z = torch.as_tensor(np.concatenate([s["z"] for s in seqs]), dtype=torch.float32, device=dev)
    c = torch.as_tensor(np.concatenate([s["c"] for s in seqs]), dtype=torch.float32, device=dev)
    w2 = torch.as_tensor(sigma ** 2 / (sigma ** 2).sum(), dtype=torch.float32, device=dev)
    opt = torch.optim.Adam(block.decoder.parameters(), lr=lr)
    loss = torch.zeros(())
    for _ in range(iterations):
        idx = torch.randint(len(z), (batch,), generator=gen).to(dev)
        zi = z[idx] + noise * torch.randn(batch, z.shape[1], generator=gen).to(dev)
        loss = (((block.decoder(zi) - c[idx]) ** 2) * w2).sum(-1).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
    return float(loss.detach())


def train_predictor(lp, seqs, iterations, lr, batch, window, gen, dev="cpu", weights=None, deadline=None, noise=None):
    """f_LP' exactly as stage 2 trains f_LP: windows starting at a recorded Z'_{j-1} (Z'_0 = 0 at a sequence start),
    fed their own clamped predictions, MSE on the normalised latent. Cosine learning rate to 5 % of lr. With a
    `deadline` (time.time()), the iteration count is cut after 20 timed iterations to what fits before it, and the
    cosine follows the cut count, so a budget-stopped fit still anneals. noise: (input, latent) for
    core.window_loss."""
    import math
    lengths, static, target = core.padded_sequences(seqs, dev)
    opt = torch.optim.Adam(lp.parameters(), lr=lr)
    loss = torch.zeros(())
    total, it, t0 = int(iterations), 0, time.time()
    while it < total:
        for group in opt.param_groups:
            group["lr"] = lr * (0.05 + 0.95 * 0.5 * (1.0 + math.cos(math.pi * it / total)))
        loss = core.window_loss(lp, lp.z_mean, lp.z_std, lengths, static, target, batch, window, gen, dev,
                                weights, noise)
        opt.zero_grad()
        loss.backward()
        opt.step()
        it += 1
        if deadline is not None and it == 20:
            per_it = (time.time() - t0) / 20.0
            total = max(it, min(total, it + int((deadline - time.time()) / max(per_it, 1e-6))))
    return float(loss.detach())


@torch.no_grad()
def free_running_error(lp, block, seqs, disp_seqs):
    """Free-running rollouts from Z'_0 = 0 (what the runtime does): RMS displacement error against the teacher (mm),
    and the same for zero displacement (LBS) and for the exact projection onto the tier's blend shapes."""
    err, zero, proj = [], [], []
    B = block.exported_blend_shapes().reshape(block.blend_shapes.shape[0], -1).double()
    for s, d in zip(seqs, disp_seqs):
        z = torch.zeros(lp.z_mean.shape)
        teacher = torch.as_tensor(d["disp"].reshape(len(d["disp"]), -1))
        for k, row in enumerate(torch.as_tensor(s["static"], dtype=torch.float32)):
            _, z = lp(z, row)
            pred = block.decoder(z).double() @ B
            err.append(float(((pred - teacher[k]) ** 2).mean()))
            zero.append(float((teacher[k] ** 2).mean()))
        c = torch.as_tensor(s["c"])
        proj.extend((((c @ B) - teacher) ** 2).mean(1).tolist())
    mm = lambda v: float(np.sqrt(np.mean(v)) * 1000.0)
    return {"rms_mm": mm(err), "rms_zero_mm": mm(zero), "rms_projection_mm": mm(proj), "frames": len(err)}


@torch.no_grad()
def own_stage2_error(run_dir, seqs):
    """The teacher run's own inference block (stage-2 f_LP → f_dec → D, what `large` ships) scored like a tier:
    free-running RMS displacement error against Φ on the same rollouts."""
    model, setup, _, _ = core.load_stage1(run_dir)
    s2 = torch.load(Path(run_dir) / "stage2.pt", weights_only=False)
    lp = core.LatentPredictor(setup, s2["norms"])
    lp.load_state_dict(s2["model"])
    block = model.block
    own = [{"static": s["static"],
            "c": block.decoder(torch.as_tensor(np.asarray(s["z"]), dtype=torch.float32)).double().numpy()}
           for s in seqs]
    return free_running_error(lp, block, own, seqs)


def distill(teacher_seqs, setup, spec, val_seqs=None, garment=None, seed=0, iterations=3000, dec_iterations=2000,
            lr=1e-3, batch=64, window=8, progress=False, device="cpu", weight_by_energy=False, deadline=None,
            noise=None, latent_velocity=0):
    """Train one tier. spec: pleat.eval.tiers.Tier (latent, blend, lp_hidden, dec_hidden, activation). garment:
    None for the teacher's mesh, else a coarser garment of the same shape (its displacements are transferred).
    latent_velocity K > 0: the latent has K more components, the change of the K largest coefficients since the
    previous frame (tier_sequences), so the network's latent is spec.latent + K wide.
    Returns (lp, block, norms, shim, garment, report)."""
    torch.manual_seed(seed)
    gen = torch.Generator().manual_seed(seed)
    t0 = time.time()
    teacher_L = setup.L
    free_mask = setup.free_mask
    if garment is not None:
        P = barycentric_transfer(setup.template, setup.faces, sources.field(garment, "template"))
        teacher_seqs = transfer(teacher_seqs, P)
        val_seqs = transfer(val_seqs, P) if val_seqs else val_seqs
        N = len(sources.field(garment, "template"))
        free_mask = np.ones(N, np.float32)
        pinned = sources.field(garment, "pinned", None)
        if pinned is not None and len(pinned):
            free_mask[np.asarray(pinned, np.int64)] = 0.0
    else:
        garment = setup.garment
    L, D = spec.latent, spec.blend
    shapes, sigma, Vt, energy = principal_shapes(teacher_seqs, D, free_mask)
    D = len(sigma)
    L = min(L, D)
    K = min(int(latent_velocity), L)
    velocity = (K, velocity_scale(teacher_seqs, Vt, sigma, K)) if K > 0 else None
    shim = _shim(setup, L + K, D, spec.lp_hidden, spec.dec_hidden, spec.activation, teacher_L)
    train = tier_sequences(teacher_seqs, Vt, sigma, L, teacher_L, velocity)
    norms = core.normalisation(shim, train)
    lp = core.LatentPredictor(shim, norms)
    block = InferenceBlock(shim.cfg["model"], len(free_mask), free_mask=free_mask)
    with torch.no_grad():
        block.blend_shapes.copy_(torch.as_tensor(shapes, dtype=torch.float32))
    block.blend_shapes.requires_grad_(False)
    dec_loss = train_decoder(block.to(device), train, sigma, dec_iterations, lr, batch * 4, gen, dev=device)
    # weight_by_energy: each latent component's error counts by the displacement it carries (σ², mean 1), so f_LP
    # spends its capacity on the large shapes rather than equally on the small, noisy ones
    w = None
    if weight_by_energy:      # a velocity component counts as its coefficient does
        energy_w = sigma[:L] ** 2 / np.mean(sigma[:L] ** 2)
        w = torch.as_tensor(np.concatenate([energy_w, energy_w[:K]]), dtype=torch.float32, device=device)
    lp_loss = train_predictor(lp.to(device), train, iterations, lr, batch, window, gen, dev=device, weights=w,
                              deadline=deadline, noise=noise)
    lp, block = lp.cpu(), block.cpu()
    report = {"tier": spec.name, "vertices": len(free_mask), "latent": L + K, "latent_velocity": K, "blend": D,
              "lp_hidden": list(spec.lp_hidden), "dec_hidden": list(spec.dec_hidden),
              "pca_energy": energy, "decoder_loss": dec_loss, "predictor_loss": lp_loss,
              "train_frames": int(sum(len(s["z"]) for s in train)), "train_time_s": time.time() - t0}
    report["train"] = free_running_error(lp, block, train[:4], teacher_seqs[:4])
    if val_seqs:
        val = tier_sequences(val_seqs, Vt, sigma, L, teacher_L, velocity)
        report["validation"] = free_running_error(lp, block, val, val_seqs)
    if progress:
        print(json.dumps(report), file=sys.stderr)
    return lp, block, norms, shim, garment, report


def build_parser():
    ap = argparse.ArgumentParser(prog="pleat-distill", description=__doc__.split("\n\n")[0])
    ap.add_argument("--teacher", required=True, help="stage-1 run directory (stage1.pt)")
    ap.add_argument("--tier", nargs="*", default=[], help="tier names (pleat.eval.tiers); none: only record")
    ap.add_argument("--out", required=True, help="output folder (<garment>_<tier>.pleat)")
    ap.add_argument("--sequences", type=int, default=24, help="teacher rollouts recorded for training")
    ap.add_argument("--frames", type=int, default=90, help="frames per recorded rollout")
    ap.add_argument("--val-sequences", type=int, default=4, help="teacher rollouts recorded for validation")
    ap.add_argument("--iterations", type=int, default=3000, help="training iterations of f_LP'")
    ap.add_argument("--dec-iterations", type=int, default=2000, help="training iterations of f_dec'")
    ap.add_argument("--seed", type=int, default=0, help="seed of the rollouts and the training")
    ap.add_argument("--fp16", action="store_true", help="store the tier assets' weights as fp16")
    ap.add_argument("--no-reuse-stage2", action="store_true", help="record fresh rollouts even if the run has some")
    ap.add_argument("--recording", default=None,
                    help="npz of teacher rollouts: loaded if it exists, else recorded and saved there")
    ap.add_argument("--report", default=None, help="write the distillation reports to this JSON file")
    ap.add_argument("--threads", type=int, default=1, help="torch CPU threads")
    add_quiet(ap)
    return ap


@command("pleat-distill")
def main(argv=None):
    from pleat.eval import tiers as tiers_mod
    args = build_parser().parse_args(argv)
    progress = not args.quiet
    core.set_threads(args.threads)
    rec = Path(args.recording) if args.recording else None
    if rec is not None and rec.is_file():
        with np.load(rec, allow_pickle=True) as d:
            seqs, val = [dict(s) for s in d["train"]], [dict(s) for s in d["validation"]]
        _, setup, _, _ = core.load_stage1(args.teacher)
    else:
        seqs, setup, _ = record(args.teacher, args.sequences, args.frames, args.seed, "train",
                                not args.no_reuse_stage2, progress=progress)
        val, _, _ = record(args.teacher, args.val_sequences, args.frames, args.seed, "validation", False,
                           progress=progress)
        if rec is not None:
            rec.parent.mkdir(parents=True, exist_ok=True)
            save_npz(rec, train=np.array(seqs, dtype=object), validation=np.array(val, dtype=object))
    reports = []
    if (Path(args.teacher) / "stage2.pt").is_file():
        rep = {"tier": "large (the teacher run's own stage 2)", "validation": own_stage2_error(args.teacher, val)}
        print(f"large: validation {rep['validation']}", file=sys.stderr)
        reports.append(rep)
    if not args.tier:
        if args.report:
            write_text(args.report, json.dumps(reports, indent=1))
        return 0
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name in args.tier:
        spec = tiers_mod.tier(name)
        garment = None
        if spec.vertices and spec.vertices < setup.N * 0.8:
            garment = sources.garment(setup.name if setup.name in ("tshirt", "tank_top", "long_sleeve", "pants",
                                                                   "dress") else "tshirt", setup.body, spec.vertices)
        if spec.mean_of:     # two students at the member tier's sizes, packed as one network
            from pleat.train import ensemble
            pair = [distill(seqs, setup, tiers_mod.tier(spec.mean_of), val, None, args.seed + k, args.iterations,
                            args.dec_iterations, progress=progress) for k in range(2)]
            lp, block, norms, shim, rep = ensemble.mean_of_fits(pair, setup, spec, spec.mean_of)
            g = setup.garment
        else:
            lp, block, norms, shim, g, rep = distill(seqs, setup, spec, val, garment, args.seed, args.iterations,
                                                     args.dec_iterations, progress=progress)
        path = out / f"{setup.name}_{name}.pleat"
        pack_tier(path, lp, block, norms, shim, g, setup, rep, setup.cfg["fps"], args.fp16, args.teacher)
        rep["asset"] = str(path)
        reports.append(rep)
        print(f"{name}: {path} ({path.stat().st_size / 1024:.0f} KiB) validation "
              f"{rep.get('validation')}", file=sys.stderr)
    if args.report:
        write_text(args.report, json.dumps(reports, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
