"""Stage 2 (paper 3.3): Φ frozen, its latents recorded on rollouts, f_LP fitted on X_c with MSE while fed its own
predictions inside a window; the recorded sequences, their normalisation and the free-running validation."""
import time
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from pleat import fileio
from pleat.train import sources
from pleat.train.config import Budget, batched_path
from pleat.train.data import Window, sample_window, to_t
from pleat.train.ddp import device_for, dist_info, stop_everywhere, wrap_ddp
from pleat.train.models import LatentPredictor
from pleat.train.run import Run
from pleat.train.stage1 import load_stage1


def padded_sequences(seqs, dev="cpu"):
    """Recorded sequences padded into tensors, so a batch is gathered with two index tensors, not a Python loop:
    lengths [S], static [S, T, ·] (X_c without its latent block), target [S, T+1, L] with target[:, 0] = Z_0 = 0 and
    target[:, j+1] = Z_j."""
    lengths = torch.as_tensor([len(q["z"]) for q in seqs], device=dev)
    T, L = int(lengths.max()), seqs[0]["z"].shape[1]
    static = torch.zeros(len(seqs), T, seqs[0]["static"].shape[1], device=dev)
    target = torch.zeros(len(seqs), T + 1, L, device=dev)
    for i, q in enumerate(seqs):
        static[i, :len(q["z"])] = to_t(q["static"], dev)
        target[i, 1:len(q["z"]) + 1] = to_t(q["z"], dev)
    return lengths, static, target


def window_loss(predictor, z_mean, z_std, lengths, static, target, batch, window, gen, dev="cpu", weights=None,
                noise=None):
    """Stage 2's loss on one batch of windows: each starts at a recorded Z_{j-1} (zero at a sequence start) and is
    fed the predictor's own (clamped) predictions; MSE on the normalised latent, averaged over the window.
    weights [L] (mean 1), if given, weigh the latent components (e.g. by how much displacement each one carries).
    noise (input, latent), if given: Gaussian noise in normalised units (× the inputs' x_std, × z_std) added to every
    input row and to each window's starting latent, so f_LP learns a smoother map and to pull a perturbed latent back
    (a regulariser against motion unlike the training clips; targets stay clean)."""
    idx = torch.randint(len(lengths), (batch,), generator=gen).to(dev)
    n = lengths[idx]
    starts = (torch.rand(batch, generator=gen).to(dev) * (n - window).clamp_min(0).add(1)).long()
    z_prev = target[idx, starts]
    input_noise, latent_noise = noise or (0.0, 0.0)
    if latent_noise > 0.0:
        z_prev = z_prev + latent_noise * z_std * torch.randn(z_prev.shape, generator=gen).to(dev)
    loss = 0.0
    for k in range(window):
        j = torch.minimum(starts + k, n - 1)
        rows = static[idx, j]
        if input_noise > 0.0:
            rows = rows + input_noise * predictor.x_std * torch.randn(rows.shape, generator=gen).to(dev)
        y, z_prev = predictor(z_prev, rows)
        sq = (y - (target[idx, j + 1] - z_mean) / z_std) ** 2
        loss = loss + (sq.mean() if weights is None else (sq * weights).mean())
    return loss / window


@torch.no_grad()
def record_latents(setup, model, clips, count, frames, rng, deadline=None):
    """Frozen-Φ rollouts: per sequence the X_c rows (latent block zero) and Φ's latent for each predicted frame.
    Past `deadline` (time.time()) no further sequence is started once two are recorded."""
    if batched_path(setup.cfg["stage1"]):      # several sequences rolled together (batching.py)
        from pleat.train import batching
        return batching.record_latents(setup, model, clips, count, frames, rng, deadline,
                                       setup.cfg["stage2"]["record_group"])
    seqs = []
    for _ in range(count):
        if deadline is not None and len(seqs) >= 2 and time.time() > deadline:
            break
        # clips shorter than the sequence are skipped (sample_window), unless every clip is
        length = min(frames + 3, max(len(c.rotations) for c in clips))
        win, beta, mat, mat01 = sample_window(setup, [c for c in clips if len(c.rotations) >= 4] or clips, rng,
                                              length)
        window = Window(setup, win, beta, mat, mat01)
        zs = []
        for f in range(3, len(win["dt"])):
            node, edges, body, recv = window.features(f)
            z, disp = model(node, edges, body, recv, setup.levels)
            window.advance(f, disp)
            zs.append(z.cpu().numpy())
        static = setup.static_inputs(win, beta, mat)[3:]  # row i ↔ frame i + 3
        seqs.append({"static": static.astype(np.float64), "z": np.array(zs, np.float64)})
    return seqs


def normalisation(setup, seqs):
    L = setup.L
    z = np.concatenate([s["z"] for s in seqs])
    z_mean, z_std = z.mean(0), z.std(0)
    z_std = np.where(z_std > 1e-6, z_std, 1.0)
    x = np.concatenate([s["static"] for s in seqs])
    prev = np.concatenate([np.concatenate([np.zeros((1, L)), s["z"][:-1]]) for s in seqs])
    x[:, :L] = prev
    x_mean, x_std = x.mean(0), x.std(0)
    x_std = np.where(x_std > 1e-6, x_std, 1.0)
    # material: already mapped to [0, 1] by X_c assembly; the paper keeps it there (no mean/std)
    x_mean[-4:], x_std[-4:] = 0.0, 1.0
    return {"x_mean": x_mean, "x_std": x_std, "z_mean": z_mean, "z_std": z_std,
            "z_min": z.min(0), "z_max": z.max(0)}


def train_stage2(cfg, out, resume=False, device="auto", progress=True, max_minutes=None):
    rank, world = dist_info()
    dev = device_for(device, rank)
    stage2_cfg = cfg["stage2"]
    phi, setup, cfg, _ = load_stage1(out, dev)
    cfg = dict(cfg, stage2=stage2_cfg)      # Φ's config from its checkpoint, stage 2's from this run (--set works)
    c2 = cfg["stage2"]
    run = Run(out, "stage2", cfg, rank)
    rng = np.random.default_rng([cfg["seed"], 2, rank])
    data_path = Path(out) / "stage2_latents.npz"
    train_clips = sources.clips("train", cfg["fps"], cfg["clips"]["train_limit"] or None,
                                cfg["clips"]["frames_limit"] or None, setup.body)
    val_clips = sources.clips("validation", cfg["fps"], cfg["clips"]["validation_limit"] or None,
                              cfg["clips"]["frames_limit"] or None, setup.body)
    t_rec = time.time()
    if resume and data_path.exists():
        with np.load(data_path, allow_pickle=True) as d:
            seqs, val = list(d["train"]), list(d["validation"])
    else:
        # recording rolls Φ (the slow network) frame by frame: with a time budget it gets at most
        # `record_budget_share` of it, so that f_LP still trains
        share = c2["record_budget_share"]
        deadline = None if not max_minutes else t_rec + 60.0 * max_minutes * share
        seqs = record_latents(setup, phi, train_clips, c2["sequences"], c2["sequence_frames"], rng,
                              None if deadline is None else deadline - 0.2 * 60.0 * max_minutes * share)
        val = record_latents(setup, phi, val_clips, max(1, len(seqs) // 4), c2["sequence_frames"], rng, deadline)
        if rank == 0:
            fileio.save_npz(data_path, train=np.array(seqs, dtype=object), validation=np.array(val, dtype=object))
    run.log({"iteration": 0, "recorded_sequences": len(seqs), "recorded_frames": sum(len(q["z"]) for q in seqs),
             "record_time_s": time.time() - t_rec})
    norms = normalisation(setup, seqs)
    model = LatentPredictor(setup, norms).to(dev)
    opt = torch.optim.Adam(model.parameters(), lr=c2["lr"])
    start, elapsed = 0, time.time() - t_rec
    if resume:
        start, elapsed = run.restore(model, opt, elapsed)
    budget = Budget(max_minutes, elapsed)
    ddp = wrap_ddp(model, world, dev)
    lengths, static, target = padded_sequences(seqs, dev)
    W = c2["window"]
    gen = torch.Generator(device="cpu").manual_seed(int(cfg["seed"]) * 1000 + 2 + rank)
    bar = tqdm(range(start, c2["iterations"]), disable=not progress or rank != 0, desc="stage2")
    it = start - 1
    for it in bar:
        loss = window_loss(ddp, model.z_mean, model.z_std, lengths, static, target, c2["batch"], W, gen, dev)
        opt.zero_grad()
        loss.backward()
        opt.step()
        run.log({"iteration": it + 1, "loss": loss.item()})
        bar.set_postfix(loss=f"{loss.item():.4g}")
        stop = stop_everywhere(world, budget.spent(), dev)
        if (it + 1) % c2["checkpoint_every"] == 0 or it + 1 == c2["iterations"] or stop:
            run.checkpoint({"model": model.state_dict(), "optimizer": opt.state_dict(), "iteration": it + 1,
                            "norms": norms, "config": cfg, "elapsed_s": budget.elapsed()})
        if stop:
            run.log_stopped(it + 1, max_minutes, budget)
            break
    val_metrics = validate_stage2(model, val, dev)
    run.log({"iteration": it + 1, "validation": val_metrics})
    return model, val_metrics


@torch.no_grad()
def validate_stage2(model, seqs, dev):
    """Free-running rollouts from Z_0 = 0 on held-out clips: MSE of the normalised latent, and the same for the
    constant predictor z_mean (what 'no information' scores) as a yardstick."""
    err, base = [], []
    for s in seqs:
        z = torch.zeros(model.z_mean.shape, device=dev)
        gt = to_t(s["z"], dev)
        for k, row in enumerate(to_t(s["static"], dev)):
            y, z = model(z, row)
            g = (gt[k] - model.z_mean) / model.z_std
            err.append(float(((y - g) ** 2).mean()))
            base.append(float((g ** 2).mean()))
    return {"mse_normalised": float(np.mean(err)), "mse_constant_mean": float(np.mean(base)), "frames": len(err)}
