"""Fits averaged and packed as one network: the large tier as the mean of two `member` fits (or students), the medium
tier as the mean of two small students.

    x = LBS(T + G_S(β) + ½ (D_a f_dec,a(z_a) + D_b f_dec,b(z_b))),   z_m = f_LP,m(z_m, X_c)   (m = a, b)

Both members read the same inputs. f_LP of the pair is one MLP of twice the widths with block-diagonal weights: the
latents side by side (z = (z_a, z_b)), the hidden units side by side, the input columns shared. f_dec likewise, and
the blend shapes are both sets, each halved. So the average runs on the runtime as it is, at exactly the cost of
the doubled sizes (member 64 / 3×256 / 2×256 → large 128 / 3×512 / 2×512), and the normalisation, the latent guard
and the network rate keep working per component.

Why: at 25k simulated frames one fit at the large sizes overfits its training clips (docs/training.md: it is less
accurate on held-out motion than a member-sized fit of the same recipe), while two fits from different seeds make partly
independent errors on motion unlike their training clips; their mean removes part of those. A member's own
normalisation of the shared inputs is folded into its first layer, so members need not share it.
"""
import json
from pathlib import Path

import numpy as np
import torch

from pleat.train import core, runfolder
from pleat.train.model import InferenceBlock, linear_layers
from pleat.train.shim import model_shim


def _block_diagonal(mats):
    rows, cols = sum(m.shape[0] for m in mats), sum(m.shape[1] for m in mats)
    out = torch.zeros(rows, cols, dtype=mats[0].dtype)
    r = c = 0
    for m in mats:
        out[r:r + m.shape[0], c:c + m.shape[1]] = m
        r, c = r + m.shape[0], c + m.shape[1]
    return out


def _first_layer(members, x_mean, x_std, L):
    """The pair's first f_LP layer on the combined input (z_a, z_b, shared columns) normalised by (x_mean, x_std):
    each member's weights on its own latent block, and on the shared columns re-expressed for the combined
    normalisation: x_m = (x_c · s_c + μ_c − μ_m) / s_m, so W' = W · s_c / s_m and b' = b + W (μ_c − μ_m) / s_m."""
    weights, biases, offset = [], [], 0
    shared_mean, shared_std = x_mean[L:], x_std[L:]
    for lp, norms in members:
        lin = linear_layers(lp.lp)[0]
        W, b = lin.weight.detach().double(), lin.bias.detach().double()
        Lm = len(norms["z_mean"])
        m_mean, m_std = torch.as_tensor(norms["x_mean"][Lm:]), torch.as_tensor(norms["x_std"][Lm:])
        W_shared = W[:, Lm:] * (shared_std / m_std)[None]
        b = b + W[:, Lm:] @ ((shared_mean - m_mean) / m_std)
        W_latent = torch.zeros(W.shape[0], L, dtype=W.dtype)
        W_latent[:, offset:offset + Lm] = W[:, :Lm]
        weights.append(torch.cat([W_latent, W_shared], 1))
        biases.append(b)
        offset += Lm
    return torch.cat(weights, 0), torch.cat(biases, 0)


@torch.no_grad()
def combine(members, setup, spec):
    """members: [(lp, block, norms)] of fits with the same depths and activation (e.g. two member fits).
    spec: the pleat.eval.tiers.Tier of the result (its widths must be the members' summed). Returns
    (lp, block, norms, shim) whose garment is the members' mean."""
    L = sum(len(n["z_mean"]) for _, _, n in members)
    D = sum(b.blend_shapes.shape[0] for _, b, _ in members)
    first = members[0][2]
    La = len(first["z_mean"])
    norms = {"x_mean": np.concatenate([n["x_mean"][:len(n["z_mean"])] for _, _, n in members] +
                                      [first["x_mean"][La:]]),
             "x_std": np.concatenate([n["x_std"][:len(n["z_mean"])] for _, _, n in members] + [first["x_std"][La:]])}
    for k in ("z_mean", "z_std", "z_min", "z_max"):
        norms[k] = np.concatenate([np.asarray(n[k], np.float64) for _, _, n in members])
    shim = model_shim(setup, L, D, spec.lp_hidden, spec.dec_hidden, spec.activation, setup.L)
    lp = core.LatentPredictor(shim, norms)
    block = InferenceBlock(shim.cfg["model"], setup.N, free_mask=setup.free_mask)
    lp_layers, dec_layers = linear_layers(lp.lp), linear_layers(block.decoder)
    member_lp = [linear_layers(m[0].lp) for m in members]
    member_dec = [linear_layers(m[1].decoder) for m in members]
    if len(lp_layers) != len(member_lp[0]) or len(dec_layers) != len(member_dec[0]):
        raise ValueError("ensemble: the members' depths differ from the tier's")
    W, b = _first_layer([(m[0], m[2]) for m in members], torch.as_tensor(norms["x_mean"]),
                        torch.as_tensor(norms["x_std"]), L)
    if W.shape != lp_layers[0].weight.shape:
        raise ValueError(f"ensemble: first layer {tuple(W.shape)} does not fit the tier's "
                         f"{tuple(lp_layers[0].weight.shape)}")
    lp_layers[0].weight.copy_(W)
    lp_layers[0].bias.copy_(b)
    for target, sources in ((lp_layers[1:], [ls[1:] for ls in member_lp]), (dec_layers, member_dec)):
        for i, lin in enumerate(target):
            Wi = _block_diagonal([ls[i].weight.detach() for ls in sources])
            if Wi.shape != lin.weight.shape:
                raise ValueError(f"ensemble: layer {tuple(Wi.shape)} does not fit the tier's {tuple(lin.weight.shape)}")
            lin.weight.copy_(Wi)
            lin.bias.copy_(torch.cat([ls[i].bias.detach() for ls in sources]))
    share = 1.0 / len(members)
    block.blend_shapes.copy_(torch.cat([share * m[1].blend_shapes.detach() for m in members], 0))
    block.blend_shapes.requires_grad_(False)
    return lp.eval(), block.eval(), norms, shim


def mean_of_fits(fits, setup, spec, member_tier, **extra):
    """fits: pleat.train.distill.distill results (lp, block, norms, shim, garment, report) at the tier
    `member_tier`: their mean at `spec`'s sizes (combine) with its report (report, `extra` added).
    Returns (lp, block, norms, shim, report)."""
    lp, block, norms, shim = combine([(f[0], f[1], f[2]) for f in fits], setup, spec)
    return lp, block, norms, shim, report(spec, setup.N, norms, block, [member_tier] * len(fits),
                                          [f[5] for f in fits], **extra)


def report(spec, vertices, norms, block, member_tiers, member_reports, **extra):
    """The fit report of a packed ensemble (simsup_summary.json's "fit", the asset META's "distillation"): its sizes,
    what its members are, and their own fit reports."""
    return dict({"tier": spec.name, "vertices": vertices, "latent": len(norms["z_mean"]),
                 "blend": int(block.blend_shapes.shape[0]), "lp_hidden": list(spec.lp_hidden),
                 "dec_hidden": list(spec.dec_hidden), "ensemble_of": list(member_tiers),
                 "members": list(member_reports)}, **extra)


def ensemble_run(member_dirs, out, tier_name="large"):
    """Members = simsup run folders (simsup.pt): their mean packed at `tier_name`'s sizes into a simsup run folder
    `out` (simsup.pt, simsup_summary.json, <garment>.pleat), so `pleat-train simsup-contact --out OUT` and
    `simsup-tiers` work on it as on a single fit. Returns the asset's path."""
    from pleat.eval.tiers import tier
    loaded = [runfolder.load_model(d) for d in member_dirs]
    setup = loaded[0][4]
    spec = tier(tier_name)
    lp, block, norms, shim = combine([(m[0], m[1], m[2]) for m in loaded], setup, spec)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cfg = json.loads(json.dumps(setup.cfg))
    cfg["simsup"]["tier"] = tier_name
    summaries = [json.loads((Path(d) / "simsup_summary.json").read_text()) for d in member_dirs]
    # members distilled from one teacher (simsup-tiers --keep-runs) say so in the asset's model line, and the
    # teacher's data and CPU time count in the summary (what the asset's META records)
    teachers = {s.get("teacher") for s in summaries}
    teacher = teachers.pop() if len(teachers) == 1 and None not in teachers else None
    students = {"students_of": {"teacher_run": teacher}} if teacher else {}
    fit = report(spec, setup.N, norms, block, [m[3].cfg["simsup"]["tier"] for m in loaded],
                 [s.get("fit", {}) for s in summaries], member_runs=[str(d) for d in member_dirs], **students)
    cpu_h = sum(s.get("cpu_hours", 0.0) for s in summaries) - sum(s.get("simulation_cpu_h", 0.0) for s in summaries[1:])
    base = summaries[0]
    if teacher and (Path(teacher) / "simsup_summary.json").is_file():
        base = json.loads((Path(teacher) / "simsup_summary.json").read_text())
        cpu_h += base.get("cpu_hours", 0.0)
        base = dict(base, teacher=teacher, teacher_only_frames=summaries[0].get("teacher_only_frames"),
                    teacher_model=base.get("fit"), teacher_validation=base.pop("validation", None))
    summary = dict(base, recipe="simulator-supervised ensemble" + (" of students" if teacher else ""),
                   members=[str(d) for d in member_dirs], cpu_hours=cpu_h, fit=fit)
    for k in ("contact", "contact_rounds", "validation_before_contact"):
        summary.pop(k, None)
    return runfolder.write_run(out, setup, cfg, setup.garment_spec, lp, block, norms, shim, fit, summary)
