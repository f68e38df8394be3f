"""A bound on how far the network can ever move a vertex away from the LBS-only garment, from the asset alone.

The runtime clamps the latent to [z_min, z_max] (the latent guard) before the decoder, so the blend weights
w = f_dec(Z) lie in the box that interval arithmetic propagates through the decoder layers. The learned displacement
of vertex i is then |Σ_j w_j D_j[i]| ≤ Σ_j max(|w_lo_j|, |w_hi_j|) · |D_j[i]|. Skinning multiplies a displacement by
Σ_k s_k R_k, a convex combination of rotations whose spectral norm is at most 1, so the same number bounds the distance
between the runtime's vertex and the LBS-only vertex in world space, for any pose, β, material, dt or history.
"""
import numpy as np

SILU_MIN_AT = -1.2784645427610738      # argmin of x·sigmoid(x)


def _silu(x):
    return x / (1.0 + np.exp(-x))


def _activation_interval(lo, hi, name):
    if name == "relu":
        return np.maximum(lo, 0.0), np.maximum(hi, 0.0)
    if name == "silu":
        a, b = _silu(lo), _silu(hi)
        low = np.where((lo <= SILU_MIN_AT) & (hi >= SILU_MIN_AT), _silu(SILU_MIN_AT), np.minimum(a, b))
        return low, np.maximum(a, b)
    raise ValueError(f"unknown activation {name!r}")


def mlp_interval(lo, hi, layers, activation):
    """Interval bound propagation of [lo, hi] through [(weight [out, in], bias [out]), ...] (last layer linear)."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    for i, (w, b) in enumerate(layers):
        w = np.asarray(w, np.float64)
        c, r = 0.5 * (lo + hi), 0.5 * (hi - lo)
        c, r = w @ c + np.asarray(b, np.float64), np.abs(w) @ r
        lo, hi = c - r, c + r
        if i + 1 < len(layers):
            lo, hi = _activation_interval(lo, hi, activation)
    return lo, hi


def decoder_layers(weights):
    layers, i = [], 0
    while f"dec.{i}.weight" in weights:
        layers.append((weights[f"dec.{i}.weight"], weights[f"dec.{i}.bias"]))
        i += 1
    return layers


def blend_weight_interval(weights):
    """[w_lo, w_hi] over every latent the guard lets through."""
    return mlp_interval(weights["z_min"], weights["z_max"], decoder_layers(weights),
                        str(weights.get("dec_activation", "relu")))


def displacement_bound_m(weights):
    """Per-vertex bound [N] (m) on ‖runtime vertex − LBS-only vertex‖, valid for every frame."""
    lo, hi = blend_weight_interval(weights)
    amp = np.maximum(np.abs(lo), np.abs(hi))
    D = np.linalg.norm(np.asarray(weights["blend_shapes"], np.float64), axis=-1)    # [D, N]
    return amp @ D
