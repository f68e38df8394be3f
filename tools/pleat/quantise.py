"""Post-training int8 quantisation of an asset's networks (asset 1.3, docs/asset-format.md "int8 networks").

Weights: symmetric, per output channel: scale_r = max_c |W[r, c]| / 127, W_q = round(W / scale_r) in -127..127.
Activations: per layer, one scale for the layer's input, s = range / levels, where range is the largest |value| (or
a percentile of them) that layer's input takes over a calibration set run through the float network: f_LP's
normalised inputs, its hidden activations, then the latent as the guard clamps it (the decoder's input) and the
decoder's hidden activations. levels: ReLU networks get ranged inputs (pleat.reference.mlp.int8_input_bounds: 2047
for a network's first layer, 255 for its hidden layers, whose inputs are never negative); other networks 127. The calibration inputs are X_c rows the caller has (an npz of rows, e.g. from
`collect_inputs` over training clips), or else random rows in the normalised space (each input ~ N(0, 1), the
distribution the normalisation stats give them in training).

    pleat-quantise collect ASSET.pleat --clips CLIP ... --out calibration.npz   # X_c rows of clips, for
    pleat-pack WEIGHTS --int8 --calibration calibration.npz --out OUT.pleat
    pleat-quantise finetune ASSET.pleat --out OUT.pleat       # quantisation-aware fine-tune, then int8
                                                              # (pleat.train.qat; needs PyTorch)

The command line is pleat.quantise_cli.
"""
import numpy as np

from pleat.reference.latent_guard import latent_guard
from pleat.reference.mlp import activation, int8_input_bounds, layers

CALIBRATION_KEY = "x_c"       # the npz key of the calibration rows: raw X_c [M, I] (before the normalisation)
RANDOM_ROWS = 4096


def require_float(weights):
    """Refuses weights whose networks are int8 already (ValueError)."""
    if np.asarray(weights["lp.0.weight"]).dtype == np.int8:
        raise ValueError("the networks are int8 already: quantise the float asset they came from")


def normalised_inputs(weights, x_c=None, count=RANDOM_ROWS, seed=0):
    """f_LP's normalised inputs [M, I] for calibration: (x_c - x_mean) / x_std of the given raw rows, or `count`
    random rows ~ N(0, 1) (what the normalisation makes of the training inputs, on average)."""
    mean = np.asarray(weights["x_mean"], np.float64)
    std = np.asarray(weights["x_std"], np.float64)
    if x_c is not None:
        x_c = np.asarray(x_c, np.float64)
        if x_c.ndim != 2 or x_c.shape[1] != len(mean) or len(x_c) == 0:
            raise ValueError(f"calibration rows: expected [M, {len(mean)}], got {x_c.shape}")
        return (x_c - mean) / std
    return np.random.default_rng(seed).standard_normal((count, len(mean)))


def input_ranges(x, ws, bs, act, percentile):
    """The range of each layer's input (largest |value|, or its percentile) as the float network runs x."""
    ranges = []
    h = x
    for i, (w, b) in enumerate(zip(ws, bs)):
        a = np.abs(h)
        ranges.append(float(np.max(a) if percentile >= 100.0 else np.percentile(a, percentile)))
        h = h @ w.T + b
        if i + 1 < len(ws):
            h = activation(h, act)
    return ranges, h


def _quantise_layer(w, input_range, levels):
    """(W_q int8, weight_scale [out] f32, input_scale [1] f32) of a float layer, its input's range and the quantised
    input's largest value."""
    w = np.asarray(w, np.float32)
    peak = np.max(np.abs(w), axis=1)
    scale = np.where(peak > 0, peak / np.float32(127.0), np.float32(1.0)).astype(np.float32)   # a zero row: any
    q = np.clip(np.rint(w / scale[:, None]), -127, 127).astype(np.int8)
    return q, scale, np.array([input_scale(input_range, levels)], np.float32)


def input_scale(input_range, levels=127):
    """A layer's input scale for an input range: range / levels, levels the quantised input's largest value (a
    constant-zero input: any scale whose 1/s is finite)."""
    tiny = np.float32(np.finfo(np.float32).tiny) * 4096
    return np.float32(max(np.float32(input_range) / np.float32(levels), tiny))


def ranged_inputs_possible(weights):
    """True where both networks are ReLU, whose hidden inputs are never negative (the ranged-inputs scheme)."""
    return all(str(weights.get(f"{p}_activation", "relu")) == "relu" for p in ("lp", "dec"))


def input_levels(layer_index, ranged):
    """The quantised input's largest value of int8 layer `layer_index` (127, or with ranged inputs 2047 / 255)."""
    return int8_input_bounds(layer_index, ranged)[1]


def quantise(weights, x=None, percentile=100.0, ranged=None):
    """The weights dict with int8 networks: every lp.i / dec.i weight int8 with its weight_scale and input_scale
    (pleat.asset writes them as LPWi i8, LPSi, LPAi). x: normalised calibration inputs [M, I] (normalised_inputs;
    None = random). ranged: each input quantised to the range its values have (docs/asset-format.md "int8
    networks"); None = wherever the networks allow it (ReLU). Everything else is copied unchanged. Also returns the
    calibration record for META."""
    require_float(weights)
    if ranged is None:
        ranged = ranged_inputs_possible(weights)
    elif ranged and not ranged_inputs_possible(weights):
        raise ValueError("ranged int8 inputs need ReLU networks (hidden inputs never negative)")
    if x is None:
        x = normalised_inputs(weights)
    out = dict(weights)
    out["int8_ranged_inputs"] = bool(ranged)
    record = {"rows": int(len(x)), "percentile": float(percentile), "inputs": "ranged" if ranged else "symmetric",
              "input_ranges": {}}
    lp_w, lp_b = layers(weights, "lp")
    dec_w, dec_b = layers(weights, "dec")
    lp_ranges, y = input_ranges(np.asarray(x, np.float64), lp_w, lp_b, str(weights.get("lp_activation", "relu")),
                                 percentile)
    z = latent_guard(y, weights["z_mean"], weights["z_std"], weights["z_min"], weights["z_max"])
    dec_ranges, _ = input_ranges(z, dec_w, dec_b, str(weights.get("dec_activation", "relu")), percentile)
    for prefix, ws, ranges in (("lp", lp_w, lp_ranges), ("dec", dec_w, dec_ranges)):
        for i, (w, r) in enumerate(zip(ws, ranges)):
            q, s, a = _quantise_layer(w, r, input_levels(i, ranged))
            out[f"{prefix}.{i}.weight"] = q
            out[f"{prefix}.{i}.weight_scale"] = s
            out[f"{prefix}.{i}.input_scale"] = a
        record["input_ranges"][prefix] = [round(r, 6) for r in ranges]
    return out, record


def quantise_blend_shapes(weights):
    """The weights dict with int8 blend shapes (asset 1.4, docs/asset-format.md "int8 blend shapes"): per shape j a
    scale s_j = max |D_j| / 127 (1 for an all-zero shape) and D_j as round(D_j / s_j) in -127..127, under
    'blend_shapes_int8' and 'blend_shape_scales'; 'blend_shapes' becomes the values the runtime reads
    (pleat.asset.blend_shape_values). Returns it and a record for META: the shapes' largest and mean element error
    (m)."""
    from pleat.asset import blend_shape_values
    d = np.asarray(weights["blend_shapes"], np.float32)
    peak = np.abs(d).reshape(len(d), -1).max(axis=1)
    scales = np.where(peak > 0.0, peak / np.float32(127.0), np.float32(1.0)).astype(np.float32)
    q = np.clip(np.rint(d / scales[:, None, None]), -127, 127).astype(np.int8)
    out = dict(weights, blend_shapes_int8=q, blend_shape_scales=scales)
    out["blend_shapes"] = blend_shape_values(q, scales)
    error = np.abs(out["blend_shapes"].astype(np.float64) - d)
    return out, {"scales": "one per shape, max |D_j| / 127", "max_element_error_m": float(error.max()),
                 "mean_element_error_m": float(error.mean())}


def collect_inputs(weights, clips, max_frames=None, body=None):
    """Raw X_c rows [M, I] of the float networks stepping through clips (the numpy reference runtime at 30 fps, β = 0):
    the inputs the networks see in use, for calibration."""
    from pleat.body import BodyModel
    from pleat.eval import scene as S
    from pleat.reference.instance import Instance
    body = body or BodyModel.load(None)
    rows = []
    for name in clips:
        clip = S.load_motion(name, body, S.EVAL_FPS, max_frames)
        rot = S.clip_rotations_for(clip, weights["joint_names"])
        inst = Instance(weights)
        for t in range(len(rot)):
            inst.step(rot[t], clip.root_translation[t], clip.root_rotation[t], 1.0 / clip.fps)
            if inst.x_c is not None:
                rows.append(np.asarray(inst.x_c, np.float32))
    return np.stack(rows)
