"""Quantisation-aware fine-tuning of an asset's networks for int8 (docs/performance.md, "int8 networks").

    pleat-quantise finetune assets/tshirt.pleat --out OUT_int8.pleat [--frames 20000] [--iterations 1000]

Post-training quantisation (pleat.quantise) rounds each weight and each layer's input to 127 steps of its range and
leaves the network to cope. Here the network learns to: its f_LP and f_dec run with the int8 arithmetic in the
forward pass (each layer's input quantised with its calibrated scale, each weight row with its own scale, both
rounded half to even and clamped to ±127 as the kernels do) and straight-through gradients (Bengio et al. 2013:
rounding passes the gradient unchanged, a clamp stops it), while the teacher is the float asset itself:

- data: X_c of `frames` frames of training motion that nobody simulated (the training clips and their variants at
  sampled β and materials, as pleat.train.simdata plans segments), with the float model's own latents in the latent
  block: the float model's free run from a reset, which the runtime does;
- loss: windows of `window` frames that start from the float model's latent, run the int8 model free for the window
  (its own latents fed back, as the runtime does) and compare the garment displacement it decodes with the float
  model's over every vertex: the mean vertex distance (objective "distance", the default: what
  bench/int8_accuracy.py reports) or the squared error per coordinate ("mse", Σ_d Δc_d B_d through the blend shapes'
  Gram matrix);
- scales: each layer's input scale starts as the `percentile` of |value| its input takes on the calibration rows
  (random normalised rows, pleat-pack's default, or the float model's own X_c rows on the motion) and is then learnt
  with the weights (learn_scales, LSQ: Esser et al. 2020), or else measured again every `recalibrate` iterations on
  the weights being tuned; the written asset stores the scales the network was tuned with.

Writes the int8 asset (networks int8, blend shapes as the input asset had them) with META recording the fine-tune,
and OUT's calibration rows beside it (OUT.calibration.npz). Needs PyTorch.
"""
import json
import time
from pathlib import Path

import numpy as np
import torch

from pleat import asset as pa
from pleat import quantise as pq
from pleat.reference.latent_guard import latent_guard
from pleat.reference.mlp import SYMMETRIC_INPUT, int8_input_bounds, layers


# ---- the int8 arithmetic with straight-through gradients ----------------------------------------------------------
def _ste_round(x):
    return x + (torch.round(x) - x).detach()        # torch.round: half to even, as rint


def fake_quant_weight(weight):
    """The weight as its int8 rows dequantised (per output row, max|w| / 127), differentiable."""
    w_scale = weight.detach().abs().amax(1, keepdim=True).clamp_min(1e-30) / 127.0
    return _ste_round(torch.clamp(weight / w_scale, -127.0, 127.0)) * w_scale


def fake_quant_layer(h, weight_q, bias, input_scale, bounds=SYMMETRIC_INPUT):
    """One int8 layer as pleat.reference.mlp.int8_layer computes it, differentiable: the input quantised with
    `input_scale` within `bounds` (pleat.reference.mlp.int8_input_bounds), times the dequantised int8 weight
    (fake_quant_weight), plus the bias."""
    q = _ste_round(torch.clamp(h / input_scale, float(bounds[0]), float(bounds[1])))
    return (q * input_scale) @ weight_q.T + bias


class Network(torch.nn.Module):
    """An asset's f_LP or f_dec as float parameters, run float or with the int8 arithmetic."""

    def __init__(self, weights, prefix, act, ranged=False):
        super().__init__()
        self.ranged = bool(ranged)
        ws, bs = layers(weights, prefix)
        self.w = torch.nn.ParameterList([torch.nn.Parameter(torch.as_tensor(np.asarray(w, np.float32))) for w in ws])
        self.b = torch.nn.ParameterList([torch.nn.Parameter(torch.as_tensor(np.asarray(b, np.float32))) for b in bs])
        self.act = act
        self.register_buffer("input_scales", torch.ones(len(ws)))
        self.log_scales = None          # learnt input scales (finetune's learn_scales): log s per layer

    def activation(self, h):
        return torch.relu(h) if self.act == "relu" else torch.nn.functional.silu(h)

    def quantised(self):
        """The int8 weights, dequantised, for the forward passes of one iteration (forward's `int8`)."""
        return [fake_quant_weight(w) for w in self.w]

    def forward(self, h, int8=None):
        """Float, or with the int8 arithmetic given `int8` = quantised()."""
        for i, (w, b) in enumerate(zip(self.w, self.b)):
            s = self.input_scales[i] if self.log_scales is None else self.log_scales[i].exp()
            h = (fake_quant_layer(h, int8[i], b, s, int8_input_bounds(i, self.ranged)) if int8 is not None
                 else h @ w.T + b)
            if i + 1 < len(self.w):
                h = self.activation(h)
        return h

    def export(self, weights, prefix):
        for i, (w, b) in enumerate(zip(self.w, self.b)):
            weights[f"{prefix}.{i}.weight"] = w.detach().numpy().astype(np.float32)
            weights[f"{prefix}.{i}.bias"] = b.detach().numpy().astype(np.float32)


class Model(torch.nn.Module):
    """f_LP → latent guard → f_dec of an asset, the runtime's order (pleat.reference.instance). ranged: the int8
    layers' inputs quantised as pleat.quantise does with ranged inputs (None: wherever the networks allow it)."""

    def __init__(self, weights, ranged=None):
        super().__init__()
        self.ranged = pq.ranged_inputs_possible(weights) if ranged is None else bool(ranged)
        self.lp = Network(weights, "lp", str(weights.get("lp_activation", "relu")), self.ranged)
        self.dec = Network(weights, "dec", str(weights.get("dec_activation", "relu")), self.ranged)
        for k in ("x_mean", "x_std", "z_mean", "z_std", "z_min", "z_max"):
            self.register_buffer(k, torch.as_tensor(np.asarray(weights[k], np.float32)))
        self.L = int(self.z_mean.shape[0])

    def step(self, z_prev, static, int8=None):
        """(the latent Z_t, the decoder's blend-shape coefficients) of one frame for a batch: z_prev [B, L], static
        [B, I] (X_c with any latent block, replaced by z_prev); int8: (lp, dec) quantised weights, None = float."""
        x = torch.cat([z_prev, static[:, self.L:]], 1)
        y = self.lp((x - self.x_mean) / self.x_std, None if int8 is None else int8[0])
        z = torch.minimum(torch.maximum(y * self.z_std + self.z_mean, self.z_min), self.z_max)
        return z, self.dec(z, None if int8 is None else int8[1])

    @torch.no_grad()
    def free_run(self, static):
        """The float model from a reset over X_c rows [T, I]: (latents [T, L], coefficients [T, D])."""
        z = torch.zeros(1, self.L)
        zs, cs = [], []
        for row in static:
            z, c = self.step(z, row[None])
            zs.append(z[0])
            cs.append(c[0])
        return torch.stack(zs), torch.stack(cs)

    @torch.no_grad()
    def calibrate(self, x_norm, percentile):
        """Every layer's input scale from normalised f_LP inputs [M, I] (pleat.quantise's ranges, same rule)."""
        ws = {p: [w.numpy().astype(np.float64) for w in net.w] for p, net in (("lp", self.lp), ("dec", self.dec))}
        bs = {p: [b.numpy().astype(np.float64) for b in net.b] for p, net in (("lp", self.lp), ("dec", self.dec))}
        lp_ranges, y = pq.input_ranges(x_norm, ws["lp"], bs["lp"], self.lp.act, percentile)
        z = latent_guard(y, *(getattr(self, k).numpy() for k in ("z_mean", "z_std", "z_min", "z_max")))
        dec_ranges, _ = pq.input_ranges(z, ws["dec"], bs["dec"], self.dec.act, percentile)
        for net, ranges in ((self.lp, lp_ranges), (self.dec, dec_ranges)):
            net.input_scales.copy_(torch.as_tensor([float(pq.input_scale(r, pq.input_levels(i, net.ranged)))
                                                    for i, r in enumerate(ranges)]))


# ---- data ----------------------------------------------------------------------------------------------------------
def motion_rows(weights, frames, seed=0):
    """X_c rows (latent block zero) of about `frames` frames of training motion, as sequences [T, I]: the training
    clips and their variants at sampled β and materials (pleat.train.simdata.plan_segments with the default
    preset's settings)."""
    from pleat.body import BodyModel
    from pleat.reference.input_assembly import assemble_inputs
    from pleat.train import settings, simdata
    from pleat.train.simsup import _clips
    cfg = settings.complete(settings.read_preset("default"))
    body = BodyModel.load(None)
    clips = _clips("train", cfg["fps"], body)
    B = int(np.asarray(weights["joint_shapedirs"]).shape[0])
    out, total = [], 0
    for seg in simdata.plan_segments(list(clips.values()), cfg["simsup"], B, seed + 2000):
        if total >= frames:
            break
        clip = simdata.segment_clip(clips, seg)
        T = clip.num_frames
        x = assemble_inputs(weights, clip.local_rotations, clip.root_translation, clip.root_rotation,
                            np.full(T, 1.0 / clip.fps), np.array(seg.beta), np.array(seg.material))
        out.append(torch.as_tensor(x, dtype=torch.float32))
        total += T
    return out


def _window_loss(model, seqs, teacher, chosen, window, gram, blend=None, smoothness=0.0):
    """Mean over windows of the squared displacement error per coordinate (m²) of the int8 model run free for
    `window` frames from the float model's latent, against the float model; given `blend` [D, 3N], the mean
    per-vertex distance (m) instead, the measure bench/int8_accuracy.py reports, plus `smoothness` times the mean
    per-vertex length of the error's second difference over frames (m): quantisation noise that changes from frame
    to frame is what adds jitter (pleat.eval.metrics: the vertices' accelerations against the reference's)."""
    z = torch.stack([teacher[k][0][t - 1] if t > 0 else torch.zeros(model.L) for k, t in chosen])
    int8 = (model.lp.quantised(), model.dec.quantised())
    loss, rough, errors = 0.0, 0.0, []
    for j in range(window):
        static = torch.stack([seqs[k][t + j] for k, t in chosen])
        target = torch.stack([teacher[k][1][t + j] for k, t in chosen])
        z, c = model.step(z, static, int8)
        d = c - target
        if blend is None:
            loss = loss + ((d @ gram) * d).sum(1).mean()
            continue
        e = (d @ blend).reshape(len(d), -1, 3)
        loss = loss + (e.pow(2).sum(-1) + 1e-12).sqrt().mean()
        if smoothness > 0:
            errors = (errors + [e])[-3:]
            if len(errors) == 3:
                second = errors[2] - 2 * errors[1] + errors[0]
                rough = rough + (second.pow(2).sum(-1) + 1e-12).sqrt().mean()
    if smoothness > 0 and window > 2:
        return loss / window + smoothness * rough / (window - 2)
    return loss / window


def finetune(weights, frames=20000, iterations=1000, window=16, batch=32, lr=5e-6, percentile=100.0,
             recalibrate=500, seed=0, log=None, calibration="random", learn_scales=True, scale_lr=1e-3,
             objective="distance", ranged=None, smoothness=0.0):
    """The fine-tuned float networks (a copy of `weights` with new lp.* / dec.*), the normalised calibration rows
    [M, I] their int8 scales come from, and a report. calibration: "motion", the float model's own X_c rows on the
    motion; "random", pleat-pack's default (pleat.quantise.normalised_inputs: rows ~ N(0, 1))."""
    torch.manual_seed(seed)
    gen = torch.Generator().manual_seed(seed)
    t0 = time.time()
    model = Model(weights, ranged)
    seqs = motion_rows(weights, frames, seed)
    teacher = [model.free_run(s) for s in seqs]               # (latents, coefficients) of the float model
    # X_c with the float model's latent before each frame, as the runtime holds it: the calibration rows
    rows = torch.cat([torch.cat([torch.cat([torch.zeros(1, model.L), z[:-1]]), s[:, model.L:]], 1)
                      for s, (z, _) in zip(seqs, teacher)])
    x_norm = ((rows - model.x_mean) / model.x_std).double().numpy()
    if calibration == "random":
        x_norm = pq.normalised_inputs(weights)
    model.calibrate(x_norm, percentile)
    blend = torch.as_tensor(np.asarray(weights["blend_shapes"], np.float32)).reshape(len(model.dec.b[-1]), -1)
    gram = blend @ blend.T / blend.shape[1]                    # Σ_d Δc_d B_d, squared, per coordinate: Δc G Δcᵀ
    starts = [(k, t) for k, s in enumerate(seqs) for t in range(0, len(s) - window + 1)]
    weights_params = [p for net in (model.lp, model.dec) for p in list(net.w) + list(net.b)]
    groups = [{"params": weights_params, "lr": lr}]
    if learn_scales:     # LSQ (Esser et al. 2020): each layer's input scale learnt with the weights, from calibration's
        for net in (model.lp, model.dec):
            net.log_scales = torch.nn.Parameter(net.input_scales.log().clone())
        groups.append({"params": [model.lp.log_scales, model.dec.log_scales], "lr": scale_lr})
        recalibrate = 0
    opt = torch.optim.Adam(groups)
    report = {"frames": int(len(rows)), "sequences": len(seqs), "iterations": iterations, "window": window,
              "batch": batch, "lr": lr, "percentile": percentile, "calibration": calibration,
              "learn_scales": bool(learn_scales), "objective": objective, "ranged": model.ranged, "smoothness": float(smoothness),
              "losses": []}
    # a fixed set of windows to say where the fine-tune started and ended
    held = [starts[int(i)] for i in torch.randint(len(starts), (256,), generator=torch.Generator().manual_seed(99))]
    with torch.no_grad():
        report["rms_before_mm"] = 1e3 * float(_window_loss(model, seqs, teacher, held, window, gram)) ** 0.5
    for it in range(iterations):
        if it and recalibrate and it % recalibrate == 0:
            model.calibrate(x_norm, percentile)
        pick = torch.randint(len(starts), (batch,), generator=gen)
        loss = _window_loss(model, seqs, teacher, [starts[int(i)] for i in pick], window, gram,
                            blend if objective == "distance" else None, smoothness)
        opt.zero_grad()
        loss.backward()
        opt.step()
        if it % 100 == 0 or it + 1 == iterations:
            rms_mm = 1e3 * (float(loss.detach()) if objective == "distance" else float(loss.detach()) ** 0.5)
            report["losses"].append([it, rms_mm])
            if log:
                log(f"qat: iteration {it}: {'mean distance' if objective == 'distance' else 'displacement RMS'} "
                    f"against the float model {rms_mm:.3f} mm "
                    f"({time.time() - t0:.0f} s)")
    if learn_scales:
        for net in (model.lp, model.dec):
            net.input_scales.copy_(net.log_scales.detach().exp())
            net.log_scales = None
        report["input_scales"] = {"lp": model.lp.input_scales.tolist(), "dec": model.dec.input_scales.tolist()}
    else:
        model.calibrate(x_norm, percentile)      # the scales the packer will give these weights
    with torch.no_grad():
        report["rms_after_mm"] = 1e3 * float(_window_loss(model, seqs, teacher, held, window, gram)) ** 0.5
    if log:
        log(f"qat: on 256 fixed windows {report['rms_before_mm']:.3f} → {report['rms_after_mm']:.3f} mm")
    out = dict(weights)
    model.lp.export(out, "lp")
    model.dec.export(out, "dec")
    report["time_s"] = time.time() - t0
    return out, x_norm, report


def write(weights, tuned, x_norm, report, path, percentile=100.0):
    """The int8 asset of the tuned networks (pleat.quantise on the same calibration rows), blend shapes as the float
    asset stores them, META recording the fine-tune; the raw calibration rows to PATH.calibration.npz."""
    from pleat.fileio import save_npz
    quantised, record = pq.quantise(tuned, x_norm, percentile, ranged=report.get("ranged"))
    for prefix, scales in (report.get("input_scales") or {}).items():    # learnt scales replace calibrated ones
        for i, v in enumerate(scales):
            quantised[f"{prefix}.{i}.input_scale"] = np.array([v], np.float32)
    record["calibration"] = ("X_c of the float model's own rollouts on unsimulated training motion (pleat.train.qat)"
                             if report.get("calibration") == "motion" else "random normalised inputs ~ N(0, 1)")
    meta = json.loads(str(tuned.get("metadata_json") or "{}"))
    meta["int8"] = record
    meta["int8_finetune"] = {k: v for k, v in report.items() if k != "losses"}
    meta["int8_finetune"]["final_rms_mm"] = report["losses"][-1][1] if report["losses"] else None
    quantised["metadata_json"] = json.dumps(meta, sort_keys=True)
    fp16 = np.asarray(weights["blend_shapes"]).dtype == np.float16
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    pa.write_asset(str(path), quantised, fp16=fp16)
    raw = x_norm * np.asarray(weights["x_std"], np.float64) + np.asarray(weights["x_mean"], np.float64)
    save_npz(str(Path(path).with_suffix(".calibration.npz")), **{pq.CALIBRATION_KEY: raw.astype(np.float32)})
    return path
