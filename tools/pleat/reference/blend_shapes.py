"""The learned blend shapes (sdk/src/blend_shapes.c): T_def = (T + G_S(β)) + Σ_j w_j D_j.

int8 blend shapes (asset 1.4) are D_j = q_j · s_j; the runtime folds the scale into the weight, (w_j · s_j) · q_j
(plFoldShapeScales), and so does `fold_shape_scales` here: pass the int8 q as the shapes and the folded weights."""
import numpy as np


def fold_shape_scales(blend_weights, scales):
    """The weights the blend takes for int8 shapes: w_j · s_j in float32, one rounding, as plFoldShapeScales."""
    return np.asarray(blend_weights, np.float32) * np.asarray(scales, np.float32)


def blend_shapes(shaped_template, blend_shapes, blend_weights):
    """shaped_template [N, 3] (reference.shape_blend) + Σ_j blend_weights[..., j] · blend_shapes[j] ([D, N, 3])
    → T_def [..., N, 3]."""
    d = np.asarray(blend_shapes, np.float64)
    w = np.asarray(blend_weights, np.float64)
    return np.asarray(shaped_template, np.float64) + (w @ d.reshape(d.shape[0], -1)).reshape(w.shape[:-1] + d.shape[1:])
