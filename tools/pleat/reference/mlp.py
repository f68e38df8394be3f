"""The two MLPs (latent predictor f_LP and decoder f_dec): hidden layers with the activation, last layer linear."""
import numpy as np


def activation(x, name):
    if name == "relu":
        return np.maximum(x, 0.0)
    if name == "silu":
        return x / (1.0 + np.exp(-x))
    raise ValueError(f"unknown activation {name!r}")


def mlp(x, weights, biases, activation_name):
    """x [..., in]; weights[i] [out, in] (torch Linear layout); biases[i] [out]."""
    h = np.asarray(x, np.float64)
    for i, (w, b) in enumerate(zip(weights, biases)):
        h = h @ np.asarray(w, np.float64).T + np.asarray(b, np.float64)
        if i + 1 < len(weights):
            h = activation(h, activation_name)
    return h


def layers(asset, prefix):
    """(weights, biases) of 'lp' or 'dec' from an asset/weights dict."""
    count = 0
    while f"{prefix}.{count}.weight" in asset:
        count += 1
    return ([np.asarray(asset[f"{prefix}.{i}.weight"], np.float64) for i in range(count)],
            [np.asarray(asset[f"{prefix}.{i}.bias"], np.float64) for i in range(count)])


# ---- int8 networks (asset 1.3, docs/asset-format.md "int8 networks"; sdk/src/jobs/mlp_int8.c) ----
# The same arithmetic as the C kernels, operation for operation in float32, so the results are the C bits: the input
# quantised per layer, integer × int8 products summed exactly (int64 here, int32 there: no sum comes near 2³¹), the
# sum dequantised with two float32 roundings, then the bias. With ReLU every value is the C value; with SiLU numpy's
# exp may differ from the C library's by an ulp, which can move a quantised input by one step.
#
# Where a layer's input is quantised to: the first 1.3 int8 assets quantise every layer's input to −127..127
# (SYMMETRIC_INPUT). With the header's ranged-inputs flag each input takes the range its values have: a network's first
# layer (the normalised inputs, the latent; either sign, and most of the int8 error where it had 8 bits) 12 bits,
# −2047..2047 (FIRST_INPUT), and each hidden layer (a ReLU output, never negative) 0..255 (HIDDEN_INPUT), twice the
# steps the symmetric scheme gives it over the same range.
SYMMETRIC_INPUT = (-127, 127)
FIRST_INPUT = (-2047, 2047)
HIDDEN_INPUT = (0, 255)


def int8_input_bounds(layer_index, ranged):
    """(lowest, highest) quantised value of an int8 layer's input: SYMMETRIC_INPUT, or with ranged inputs
    FIRST_INPUT for layer 0 and HIDDEN_INPUT after it."""
    if not ranged:
        return SYMMETRIC_INPUT
    return FIRST_INPUT if layer_index == 0 else HIDDEN_INPUT


def quantise(x, inv_scale, bounds=SYMMETRIC_INPUT):
    """q = round_half_even(clamp(x · inv_scale, lo, hi)) as int64 (a NaN gives lo, as fmaxf / _mm256_max_ps)."""
    v = np.asarray(x, np.float32) * np.float32(inv_scale)
    v = np.fmin(np.fmax(v, np.float32(bounds[0])), np.float32(bounds[1]))
    return np.rint(v).astype(np.int64)


def int8_layers(asset, prefix):
    """The int8 layers of 'lp' or 'dec' as dicts (weight int8 [out, in], weight_scale [out], input_scale, bias,
    input_bounds), or None where the asset's networks are not int8."""
    if np.asarray(asset.get(f"{prefix}.0.weight")).dtype != np.int8:
        return None
    count = 0
    while f"{prefix}.{count}.weight" in asset:
        count += 1
    ranged = bool(asset.get("int8_ranged_inputs", False))
    return [dict(weight=np.asarray(asset[f"{prefix}.{i}.weight"], np.int8),
                 weight_scale=np.asarray(asset[f"{prefix}.{i}.weight_scale"], np.float32).reshape(-1),
                 input_scale=np.float32(np.asarray(asset[f"{prefix}.{i}.input_scale"]).reshape(-1)[0]),
                 bias=np.asarray(asset[f"{prefix}.{i}.bias"], np.float32),
                 input_bounds=int8_input_bounds(i, ranged)) for i in range(count)]


def int8_layer(x, layer):
    """One int8 Linear layer on float32 x [..., in] → float32 [..., out] (plMatVecInt8_Scalar). A hidden layer's
    unsigned input is the C kernels' q − 128 plus the row's 128 · Σ w: the same integer sum as q · w here."""
    inv = np.float32(1.0) / layer["input_scale"]
    q = quantise(x, inv, layer.get("input_bounds", SYMMETRIC_INPUT))
    acc = q @ layer["weight"].astype(np.int64).T
    scale = layer["weight_scale"] * layer["input_scale"]                  # float32 · float32, one rounding
    return (acc.astype(np.float32) * scale).astype(np.float32) + layer["bias"]


def mlp_int8(x, layers_int8, activation_name):
    """x [..., in] (taken as float32, as the runtime holds it) through int8 layers; hidden layers with the
    activation (float32), the last linear. Returns float32."""
    h = np.asarray(x, np.float32)
    for i, layer in enumerate(layers_int8):
        h = int8_layer(h, layer)
        if i + 1 < len(layers_int8):
            h = activation(h, activation_name).astype(np.float32)
    return h
