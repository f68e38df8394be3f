"""The input normalisation (sdk/src/input_normalisation.c): x = (X_c − x_mean) / x_std, what f_LP reads."""
import numpy as np


def input_normalisation(x_c, x_mean, x_std):
    """x_c [..., I] (reference.input_assembly); x_mean, x_std [I] (the asset's XMEA/XSTD) → x [..., I]."""
    return (np.asarray(x_c, np.float64) - np.asarray(x_mean, np.float64)) / np.asarray(x_std, np.float64)
