"""Linear blend skinning: x_i' = Σ_k skin_weight[i,k] · M_{skin_index[i,k]} · x_i."""
import numpy as np


def blend_matrices(skin_indices, skin_weights, skin_matrices):
    """Σ_k w_ik M_{j_ik} per vertex: skin_indices/skin_weights [N, K], skin_matrices [J, 3, 4] → [N, 3, 4] (the C
    kernels' plBlendJointMatrices; skinning and body contact blend with it)."""
    m = np.asarray(skin_matrices, np.float64)[np.asarray(skin_indices, np.int64)]  # [N, K, 3, 4]
    return np.einsum("nk,nkij->nij", np.asarray(skin_weights, np.float64), m)


def skinning(rest_positions, skin_indices, skin_weights, skin_matrices):
    """rest_positions [N, 3], skin_indices/skin_weights [N, K], skin_matrices [J, 3, 4] → positions [N, 3]."""
    x = np.asarray(rest_positions, np.float64)
    blended = blend_matrices(skin_indices, skin_weights, skin_matrices)
    return np.einsum("nij,nj->ni", blended[..., :3], x) + blended[..., 3]
