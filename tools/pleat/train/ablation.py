"""The ablation (paper 4.3): f_LP → f_dec → D trained together on stage 1's physics losses, with X_c normalised by
statistics of the training poses."""
import numpy as np
import torch
from tqdm import tqdm

from pleat.train.config import (LOSS_TERMS, Budget, batched_path, data_workers, loss_weights, make_optimizer,
                                searches_on_device, rollout_steps, run_fraction)
from pleat.train.data import Window, sample_window, to_t
from pleat.train.ddp import stop_everywhere, wrap_ddp
from pleat.train.models import AblationModel
from pleat.train.run import Run
from pleat.train.stage1 import lbs_scale, rollout_loss, start_physics_run


def pose_statistics(setup, clips, rng, samples=8):
    rows = []
    for _ in range(samples):
        clip = clips[rng.integers(len(clips))]
        beta = setup.sample_beta(rng)
        mat, _ = setup.sample_material(rng)
        win = setup.pose_window(clip, 0, len(clip.rotations), beta)
        rows.append(setup.static_inputs(win, beta, mat)[2:])
    x = np.concatenate(rows)
    mean, std = x.mean(0), x.std(0)
    std = np.where(std > 1e-6, std, 1.0)
    mean[:setup.L], std[:setup.L] = 0.0, 1.0
    mean[-4:], std[-4:] = 0.0, 1.0
    L = setup.L
    return {"x_mean": mean, "x_std": std, "z_mean": np.zeros(L), "z_std": np.ones(L),
            "z_min": np.full(L, -1e3), "z_max": np.full(L, 1e3)}


def window_loss(setup, model, win, beta, mat, mat01, c1, steps, w, z_lo, z_hi):
    """One window of the per-window path: the rollout loss of f_LP → f_dec → D from Z = 0 and its terms, the loss
    divided by the window's LBS loss (stage1.loss_norm = "lbs"); widens [z_lo, z_hi] to every latent the rollout
    reaches (the range the asset stores)."""
    static = to_t(setup.static_inputs(win, beta, mat), setup.device)
    zbox = [torch.zeros(setup.L, device=setup.device)]

    def predictor(f):
        z, disp = model(zbox[0], static[f])
        zbox[0] = z
        with torch.no_grad():
            zn = z.detach().cpu().numpy()
            np.minimum(z_lo, zn, out=z_lo)
            np.maximum(z_hi, zn, out=z_hi)
        return disp

    scale = 1.0
    if c1["loss_norm"] == "lbs":
        scale, _ = lbs_scale(setup, win, beta, mat, mat01, steps, w, c1["loss_norm_floor"])
    l, terms = rollout_loss(setup, None, Window(setup, win, beta, mat, mat01), steps, w, predictor)
    return l / scale, terms


def train_ablation(cfg, garment, out, resume=False, device="auto", progress=True, max_minutes=None):
    rank, world, dev, setup, clips = start_physics_run(cfg, garment, device)
    rng = np.random.default_rng([cfg["seed"], 3, rank])
    norms = pose_statistics(setup, clips, rng)
    model = AblationModel(setup, norms).to(dev)
    ca, c1 = cfg["ablation"], cfg["stage1"]
    opt = make_optimizer(model, ca["lr"], c1["blend_lr_scale"])
    run = Run(out, "ablation", cfg, rank)
    start, elapsed = run.restore(model, opt) if resume else (0, 0.0)
    budget = Budget(max_minutes, elapsed)
    ddp = wrap_ddp(model, world, dev)
    z_lo = np.full(setup.L, np.inf)
    z_hi = np.full(setup.L, -np.inf)
    sched = dict(c1, iterations=ca["iterations"])
    batched = batched_path(c1)
    if batched:     # the batch's windows through the model together (batching.py; the same losses, tested)
        from pleat.train import batching
        source = batching.WindowSource(setup, clips, rng, ca["batch"], static=True, workers=data_workers(c1),
                                       drop_trees=searches_on_device(c1))
    bar = tqdm(range(start, ca["iterations"]), disable=not progress or rank != 0, desc="ablation")
    for it in bar:
        s = run_fraction(sched, it, budget.elapsed(), budget.budget_s)
        steps = rollout_steps(sched, it, s)
        w = loss_weights(sched, it, s)
        loss = 0.0
        acc = {k: 0.0 for k in LOSS_TERMS}
        if batched:
            s_next = run_fraction(sched, it + 1, budget.elapsed(), budget.budget_s)
            loss, acc = batching.ablation_iteration(setup, ddp, source, c1, steps, w, z_lo, z_hi,
                                                    rollout_steps(sched, it + 1, s_next))
            acc.pop("loss")
        for _ in range(0 if batched else ca["batch"]):
            win, beta, mat, mat01 = sample_window(setup, clips, rng, steps + 3)
            l, terms = window_loss(setup, ddp, win, beta, mat, mat01, c1, steps, w, z_lo, z_hi)
            loss = loss + l / ca["batch"]
            for k in LOSS_TERMS:
                acc[k] += terms[k] / ca["batch"]
        opt.zero_grad()
        loss.backward()
        torch.nn.utils.clip_grad_norm_(model.parameters(), c1["grad_clip"])
        opt.step()
        run.log({"iteration": it + 1, "loss": loss.item(), "steps": steps, "fraction": s, **acc})
        bar.set_postfix(loss=f"{loss.item():.4g}")
        stop = stop_everywhere(world, budget.spent(), dev)
        if (it + 1) % ca["checkpoint_every"] == 0 or it + 1 == ca["iterations"] or stop:
            run.checkpoint({"model": model.state_dict(), "optimizer": opt.state_dict(), "iteration": it + 1,
                            "config": cfg, "garment": garment, "z_min": z_lo, "z_max": z_hi,
                            "elapsed_s": budget.elapsed()})
        if stop:
            run.log_stopped(it + 1, max_minutes, budget)
            break
    if batched:
        source.close()
    return model, setup
