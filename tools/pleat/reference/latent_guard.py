"""The latent guard (sdk/src/latent_guard.c): Z_t+1 = clamp(y · z_std + z_mean, z_min, z_max).

f_LP predicts the standardised latent y; the guard takes it back to latent units and keeps it in the range the decoder
saw in training. The step checks y is finite first: the clamp would turn ±inf into a bound and hide an overflow that
must reset the instance."""
import numpy as np


def latent_guard(y, z_mean, z_std, z_min, z_max):
    """y [..., L]; z_mean, z_std, z_min, z_max [L] (the asset's ZMEA/ZSTD/ZMIN/ZMAX) → Z_t+1 [..., L]."""
    f64 = lambda a: np.asarray(a, np.float64)
    return np.clip(f64(y) * f64(z_std) + f64(z_mean), f64(z_min), f64(z_max))
