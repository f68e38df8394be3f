"""Packing a run into a .pleat asset: the trained f_LP, f_dec and blend shapes with their normalisation, the
garment and body, and META saying how it was trained (preset, config, sources, hardware, final losses)."""
import json
from pathlib import Path

import numpy as np
import torch

from pleat import garment_asset as ga
from pleat.fileio import save_npz
from pleat.train import sources
from pleat.train.ablation import pose_statistics
from pleat.train.data import Setup, physics_clips
from pleat.train.model import mlp_to_weights
from pleat.train.models import AblationModel, LatentPredictor, Stage1Model
from pleat.train.run import hardware


def network_weights(setup, lp_seq, block, norms, fps):
    act = setup.cfg["model"]["activation"]
    net = {k: np.asarray(v, np.float32) for k, v in norms.items()}
    net.update(mlp_to_weights(lp_seq, "lp"))
    net.update(mlp_to_weights(block.decoder, "dec"))
    net["blend_shapes"] = block.exported_blend_shapes().cpu().numpy().astype(np.float32)
    net["lp_activation"] = act
    net["dec_activation"] = act
    net["train_fps"] = np.float32(fps)
    return net


def final_losses(out, stage):
    p = Path(out) / f"metrics_{stage}.jsonl"
    if not p.exists():
        return None
    recs = [json.loads(line) for line in p.read_text().splitlines() if line.strip()]
    train = [r for r in recs if "loss" in r]
    val = [r["validation"] for r in recs if "validation" in r]
    tail = train[-10:]
    return {"first_loss": train[0]["loss"] if train else None,
            "final_loss_mean_last10": float(np.mean([r["loss"] for r in tail])) if tail else None,
            "iterations": train[-1]["iteration"] if train else 0,
            "wall_time_s": train[-1]["time_s"] if train else None,
            "validation": val[-1] if val else None,
            "stopped_by_time_budget": any("stopped" in r for r in recs)}


def pack(out, model_kind="two-stage", path=None, fp16=False, onnx=False):
    from pleat.asset import write_asset
    out = Path(out)
    if model_kind == "two-stage":
        s1 = torch.load(out / "stage1.pt", weights_only=False)
        s2 = torch.load(out / "stage2.pt", weights_only=False)
        cfg = s1["config"]
        setup = Setup(cfg, s1["garment"], "cpu")
        stage1 = Stage1Model(setup)
        stage1.load_state_dict(s1["model"])
        lp = LatentPredictor(setup, s2["norms"])
        lp.load_state_dict(s2["model"])
        net = network_weights(setup, lp.lp, stage1.block, s2["norms"], cfg["fps"])
        stages = ("stage1", "stage2")
    else:
        sa = torch.load(out / "ablation.pt", weights_only=False)
        cfg = sa["config"]
        setup = Setup(cfg, sa["garment"], "cpu")
        norms = pose_statistics(setup, physics_clips(cfg, setup.body), np.random.default_rng([cfg["seed"], 3, 0]))
        model = AblationModel(setup, norms)
        model.load_state_dict(sa["model"])
        norms = {k: getattr(model.lp, k).numpy() for k in ("x_mean", "x_std", "z_mean", "z_std")}
        norms["z_min"], norms["z_max"] = sa["z_min"], sa["z_max"]
        net = network_weights(setup, model.lp.lp, model.block, norms, cfg["fps"])
        stages = ("ablation",)
    meta = {"model": f"pleat {model_kind} (paper sections 3.2-3.3)" if model_kind == "two-stage"
            else "ablation: inference block trained alone on the physics losses (paper 4.3)",
            "training": {"preset": cfg["preset"], "config": cfg, "sources": sources.used,
                         "hardware": hardware(), "losses": {s: final_losses(out, s) for s in stages}}}
    meta["training"]["wall_time_s"] = sum((meta["training"]["losses"][s] or {}).get("wall_time_s") or 0.0
                                          for s in stages)
    weights = ga.weights_from_garment(setup.garment, setup.body, net, metadata=meta, name=setup.name)
    target = Path(path) if path else out / f"{setup.name}{'' if model_kind == 'two-stage' else '_ablation'}.pleat"
    write_asset(str(target), weights, fp16=fp16, onnx=onnx)
    save_npz(out / f"{target.stem}_weights.npz", **{k: np.asarray(v) for k, v in weights.items()})
    return target, weights
