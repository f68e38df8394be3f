"""Shape blend (cached per β) and the learned blend shapes: T_def = T + Σ_b β_b G_S[b] + Σ_j w_j D_j."""
import numpy as np


def shape_blend(template, shape_blend_shapes, beta):
    """Shaped template T + Σ_b β_b G_S[b] → [N, 3]."""
    return np.asarray(template, np.float64) + np.tensordot(np.asarray(beta, np.float64),
                                                           np.asarray(shape_blend_shapes, np.float64), axes=1)


def blend_shapes(shaped_template, blend_shape_displacements, blend_weights):
    """shaped_template [N, 3] + Σ_j blend_weights[..., j] · D_j ([D, N, 3]) → [..., N, 3]."""
    d = np.asarray(blend_shape_displacements, np.float64)
    w = np.asarray(blend_weights, np.float64)
    return np.asarray(shaped_template, np.float64) + (w @ d.reshape(d.shape[0], -1)).reshape(w.shape[:-1] + d.shape[1:])
