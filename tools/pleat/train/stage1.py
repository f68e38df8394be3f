"""Stage 1 (paper 3.2): Φ on the physics losses of equation 4, rolled out autoregressively for 1 → `rollout_max`
steps; per window or through the batched path (pleat.train.batching); validation, the LBS-relative loss scale and
loading a trained Φ."""
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from pleat.train import sources
from pleat.train.config import (LOSS_TERMS, Budget, autocast_bf16, batched_path, data_workers, loss_weights,
                                make_optimizer, searches_on_device, rollout_steps, run_fraction, weighted)
from pleat.train.data import Setup, Window, physics_clips, sample_window
from pleat.train.ddp import device_for, dist_info, stop_everywhere, wrap_ddp
from pleat.train.models import Stage1Model
from pleat.train.run import Run, _rng_state


def start_physics_run(cfg, garment, device):
    """What a run on the physics losses (stage 1, the ablation) starts from on this rank: (rank, world, device,
    setup, clips), with torch seeded by the run's seed before the setup and any model are built."""
    rank, world = dist_info()
    dev = device_for(device, rank)
    torch.manual_seed(cfg["seed"])
    setup = Setup(cfg, garment, dev)
    return rank, world, dev, setup, physics_clips(cfg, setup.body)


def train_stage1(cfg, garment, out, resume=False, device="auto", progress=True, max_minutes=None):
    rank, world, dev, setup, clips = start_physics_run(cfg, garment, device)
    model = Stage1Model(setup).to(dev)
    c1 = cfg["stage1"]
    bf16 = autocast_bf16(c1, dev)       # before anything runs: true where the device lacks bf16 is an error
    opt = make_optimizer(model, c1["lr"], c1["blend_lr_scale"])
    run = Run(out, "stage1", cfg, rank)
    start, elapsed = run.restore(model, opt) if resume else (0, 0.0)
    if start == 0:
        run.log({"iteration": 0, "validation": validate_stage1(setup, model, cfg)})
    budget = Budget(max_minutes, elapsed)
    rng = np.random.default_rng([cfg["seed"], rank, start])
    batched = batched_path(c1)
    if batched:     # K windows per iteration through one graph (batching.py; the same losses, tested)
        from pleat.train import batching
        net = batching.BatchedStage1(model, bf16=bf16)
        ddp = wrap_ddp(batching.compiled(net) if c1["compile"] else net, world, dev)
        source = batching.WindowSource(setup, clips, rng, c1["windows_per_iteration"],
                                       workers=data_workers(c1), drop_trees=searches_on_device(c1))
    else:
        ddp = wrap_ddp(model, world, dev)
    bar = tqdm(range(start, c1["iterations"]), disable=not progress or rank != 0, desc="stage1")
    it = start - 1
    for it in bar:
        s = run_fraction(c1, it, budget.elapsed(), budget.budget_s)
        steps = rollout_steps(c1, it, s)
        w = loss_weights(c1, it, s)
        if batched:
            s_next = run_fraction(c1, it + 1, budget.elapsed(), budget.budget_s)
            objective, rec = batching.stage1_iteration(setup, ddp, source, c1, steps, w,
                                                       rollout_steps(c1, it + 1, s_next))
            opt.zero_grad()
            objective.backward()
        else:
            win, beta, mat, mat01 = sample_window(setup, clips, rng, steps + 3)
            scale = 1.0
            if c1["loss_norm"] == "lbs":
                scale, _ = lbs_scale(setup, win, beta, mat, mat01, steps, w, c1["loss_norm_floor"])
            loss, terms = rollout_loss(setup, ddp, Window(setup, win, beta, mat, mat01), steps, w)
            opt.zero_grad()
            (loss / scale).backward()
            rec = {"loss": loss.item(), "lbs_scale": scale, "ratio": loss.item() / scale, **terms}
        gn = torch.nn.utils.clip_grad_norm_(model.parameters(), c1["grad_clip"])
        opt.step()
        rec = {"iteration": it + 1, **rec, "steps": steps, "grad_norm": float(gn), "fraction": s,
               **{f"w_{k}": v for k, v in w.items()}, **({"autocast_bf16": True} if bf16 else {})}
        run.log(rec)
        bar.set_postfix(loss=f"{rec['loss']:.4g}", ratio=f"{rec['ratio']:.3g}", steps=steps)
        stop = stop_everywhere(world, budget.spent(), dev)
        if (it + 1) % c1["checkpoint_every"] == 0 or it + 1 == c1["iterations"] or stop:
            run.checkpoint({"model": model.state_dict(), "optimizer": opt.state_dict(), "iteration": it + 1,
                            "config": cfg, "garment": garment, "rng": _rng_state(), "elapsed_s": budget.elapsed()})
        every = c1["validation_every"]
        if every and (it + 1) % every == 0 and not stop and it + 1 != c1["iterations"]:
            run.log({"iteration": it + 1, "validation": validate_stage1(setup, model, cfg)})
        if stop:
            run.log_stopped(it + 1, max_minutes, budget)
            break
    if batched:
        source.close()
    val = validate_stage1(setup, model, cfg)
    run.log({"iteration": it + 1, "validation": val})
    return model, setup, val


def rollout_loss(setup, model, window, steps, w, predictor=None):
    setup.energies.collision_weight = w["collision"]
    total, acc = 0.0, {k: 0.0 for k in LOSS_TERMS}
    for i in range(steps):
        f = 3 + i
        if predictor is None:
            node, edges, body, recv = window.features(f)
            _, disp = model(node, edges, body, recv, setup.levels)
        else:
            disp = predictor(f)
        window.advance(f, disp)
        terms = window.losses(f)
        total = total + weighted(terms, w)
        for k in LOSS_TERMS:
            acc[k] += float(terms[k].detach()) / steps
    return total / steps, acc


# nonnegative terms: the gravity term is work relative to the previous state and may be negative
_SCALE_TERMS = ("bending", "stretching", "inertia", "friction", "collision")


@torch.no_grad()
def lbs_scale(setup, win, beta, mat, mat01, steps, w, floor):
    """The LBS-only loss of the same window (the garment following LBS of the shaped template, zero network),
    from its nonnegative terms, at least `floor`: dividing a window's loss by it makes every window's loss read
    as 'relative to LBS', so one extreme window (10⁵ J of LBS stretching) cannot dominate an iteration."""
    window = Window(setup, win, beta, mat, mat01)
    zero = torch.zeros(setup.N, 3, device=setup.device)
    _, terms = rollout_loss(setup, None, window, steps, w, lambda f: zero)
    return max(sum(w[k] * terms[k] for k in _SCALE_TERMS), float(floor)), terms


@torch.no_grad()
def validate_stage1(setup, model, cfg):
    clips = sources.clips("validation", cfg["fps"], cfg["clips"]["validation_limit"] or None,
                          cfg["clips"]["frames_limit"] or None, setup.body)
    rng = np.random.default_rng(12345)
    c1 = cfg["stage1"]
    w = loss_weights(c1, c1["iterations"] - 1)
    losses, ratios, terms, lbs_terms = [], [], {k: [] for k in LOSS_TERMS}, {k: [] for k in LOSS_TERMS}
    if batched_path(c1):
        from pleat.train import batching
        losses, ratios, terms, lbs_terms = batching.validate_stage1(setup, model, clips, rng, w, c1)
    for _ in range(0 if batched_path(c1) else c1["validation_windows"]):
        win, beta, mat, mat01 = sample_window(setup, clips, rng, c1["rollout_max"] + 3)
        scale, tl = lbs_scale(setup, win, beta, mat, mat01, c1["rollout_max"], w, c1["loss_norm_floor"])
        loss, t = rollout_loss(setup, model, Window(setup, win, beta, mat, mat01), c1["rollout_max"], w)
        losses.append(float(loss))
        ratios.append(float(loss) / scale)
        for k in LOSS_TERMS:
            terms[k].append(t[k])
            lbs_terms[k].append(tl[k])
    # mean and median: a few extreme windows (LBS of a cartwheel) dominate the mean; `ratio` is each window's loss
    # over the LBS-only loss of the same window (< 1: better than LBS by the physics of equation 4)
    return {"loss": float(np.mean(losses)), "loss_median": float(np.median(losses)), "windows": len(losses),
            "ratio_mean": float(np.mean(ratios)), "ratio_median": float(np.median(ratios)),
            **{k: float(np.mean(v)) for k, v in terms.items()},
            **{f"lbs_{k}": float(np.mean(v)) for k, v in lbs_terms.items()}}


def load_stage1(out, device="cpu"):
    state = torch.load(Path(out) / "stage1.pt", weights_only=False)
    cfg = state["config"]
    setup = Setup(cfg, state["garment"], device)
    model = Stage1Model(setup).to(device)
    model.load_state_dict(state["model"])
    model.eval()
    return model, setup, cfg, state
