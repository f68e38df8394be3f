"""A simsup run folder's files (docs/training.md, "Recipes"): simsup.pt (the fitted model), simsup_summary.json, the
body-contact candidates and the packed <garment>.pleat; and how any fit becomes a packed tier asset (pack_tier).

The recipes that write run folders (pleat.train.simsup, the ensemble, distillation) and the tools that read them all
come here for the files, so that none of them needs another for its I/O.
"""
import json
from pathlib import Path

import numpy as np
import torch

from pleat import fileio
from pleat import garment_asset as ga
from pleat.train import core, settings
from pleat.train.shim import model_shim


def pack_tier(path, lp, block, norms, shim, garment, setup, report, fps, fp16=True, teacher=None, model=None,
              training=None, onnx=False, contact_candidates=None):
    """Write the tier with the training pack code (network_weights → weights_from_garment → write_asset);
    contact_candidates: the body contact's candidates from simulated frames, (table, near) as read_candidates gives
    them (weights_from_garment)."""
    from pleat.asset import write_asset
    net = core.network_weights(shim, lp.lp, block, norms, fps)
    meta = {"model": model or f"pleat tier {report['tier']}: inference block distilled from the stage-1 teacher",
            "tier": report["tier"], "distillation": {k: v for k, v in report.items()},
            "teacher": str(teacher) if teacher else None,
            "training": dict({"preset": setup.cfg["preset"]}, **(training or {}))}
    weights = ga.weights_from_garment(garment, setup.body, net, metadata=meta, name=setup.name,
                                      contact=ga.tier_contact(report["tier"]), contact_candidates=contact_candidates)
    write_asset(str(path), weights, fp16=fp16, onnx=onnx)
    return weights


def write_run(out, setup, cfg, garment, lp, block, norms, shim, report, summary, contact_tuned=False, **state):
    """A simsup run folder's files from its model: simsup.pt (what load_model reads, plus `state`),
    simsup_summary.json and the packed <garment>.pleat (fp16 / ONNX sections as cfg's simsup section says, META with
    the summary). Returns the asset's path."""
    c = settings.complete(cfg)["simsup"]      # a stored config (simsup-contact) may predate some keys
    fileio.save_torch(out / "simsup.pt", dict({"lp": lp.state_dict(), "block": block.state_dict(), "norms": norms,
                                               "report": report, "config": cfg, "garment": garment}, **state))
    fileio.write_text(out / "simsup_summary.json", json.dumps(summary, indent=1, default=str))
    path = out / f"{setup.name}.pleat"
    tier_name = report.get("tier") or c["tier"]        # a second round of students: "<n>x<tier>"
    pack_tier(path, lp, block, norms, shim, setup.garment, setup, dict(report, tier=tier_name), cfg["fps"],
              fp16=c["fp16"], teacher="reference simulator", model=model_name(report, contact=contact_tuned),
              training=summary, onnx=c["onnx"], contact_candidates=run_contact_candidates(out))
    return path


CANDIDATES_FILE = "contact_candidates.npz"


def run_contact_candidates(out):
    """The run folder's body-contact candidates from simulated frames (write_contact_candidates) as
    pleat.garment_asset.read_candidates gives them, or None."""
    path = Path(out) / CANDIDATES_FILE
    return ga.read_candidates(path) if path.is_file() else None


def model_name(report, contact=False):
    """The asset META's model line of a simsup fit (report: distill's, or the ensemble's)."""
    members = report.get("ensemble_of")
    fitted = "networks distilled from a fit" if report.get("students_of") else "fits"
    what = (f"the mean of {len(members)} {members[0]} {fitted} to the reference simulator, packed as one network"
            if members else "inference block fitted to the reference simulator")
    return f"pleat simulator-supervised: {what}" + (", contact-aware fine-tune" if contact else "")


def load_model(run_dir):
    """(lp, block, norms, shim, setup) of a simsup run (simsup.pt)."""
    from pleat.eval.tiers import tier
    state = torch.load(Path(run_dir) / "simsup.pt", weights_only=False)
    cfg = settings.complete(state["config"])      # a run folder written before a key existed reads its default
    setup = core.Setup(cfg, state["garment"], "cpu")
    spec = tier(state.get("report", {}).get("tier") or cfg["simsup"]["tier"])   # a second round: "<n>x<tier>"
    L, D = state["norms"]["z_mean"].shape[0], state["block"]["blend_shapes"].shape[0]
    shim = model_shim(setup, L, D, spec.lp_hidden, spec.dec_hidden, spec.activation, setup.L)
    lp = core.LatentPredictor(shim, state["norms"])
    lp.load_state_dict(state["lp"])
    from pleat.train.model import InferenceBlock
    block = InferenceBlock(shim.cfg["model"], setup.N, free_mask=setup.free_mask)
    block.load_state_dict(state["block"])
    return lp.eval(), block.eval(), state["norms"], shim, setup
