"""The learned blend shapes (sdk/src/blend_shapes.c): T_def = (T + G_S(β)) + Σ_j w_j D_j."""
import numpy as np


def blend_shapes(shaped_template, blend_shapes, blend_weights):
    """shaped_template [N, 3] (reference.shape_blend) + Σ_j blend_weights[..., j] · blend_shapes[j] ([D, N, 3])
    → T_def [..., N, 3]."""
    d = np.asarray(blend_shapes, np.float64)
    w = np.asarray(blend_weights, np.float64)
    return np.asarray(shaped_template, np.float64) + (w @ d.reshape(d.shape[0], -1)).reshape(w.shape[:-1] + d.shape[1:])
