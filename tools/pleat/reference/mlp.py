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
