"""The inference block in torch over a clip: the proof that training, the numpy reference and the runtime agree."""
import numpy as np
import torch

from pleat import reference
from pleat.train.model import skin


@torch.no_grad()
def torch_inference(setup, lp, block, rotations, root_translation, root_rotation, dt_s, beta, material):
    """Ψ in torch over a clip stepped from a reset: X_c by the reference's assembly (latent block filled with the
    model's own previous latent, Z_0 = 0), f_LP with normalisation and latent clamp, f_dec, blend shapes, LBS.
    Returns positions [T, N, 3] (float64) and latents [T, L]."""
    win = {"quats": np.asarray(rotations, np.float64), "root_translation": np.asarray(root_translation, np.float64),
           "root_rotation": np.asarray(root_rotation, np.float64), "dt": np.asarray(dt_s, np.float64)}
    rows = torch.as_tensor(setup.static_inputs(win, beta, material), dtype=torch.float64)
    feats = reference.pose_features(setup.parents, setup.joints_of(beta), setup.input_joints, win["quats"],
                                    win["root_translation"], win["root_rotation"])
    A = torch.as_tensor(np.einsum("nk,wnkab->wnab", setup.skin_weights, feats["skin_matrices"][:, setup.skin_indices]))
    lp, block = lp.double(), block.double()
    shaped = torch.as_tensor(setup.shaped(beta))
    z = torch.zeros(setup.L, dtype=torch.float64)
    out, zs = [], []
    for f in range(len(rows)):
        _, z = lp(z, rows[f])
        out.append(skin(A[f], shaped + block.displacement(z)))
        zs.append(z)
    lp.float(), block.float()
    return torch.stack(out).numpy(), torch.stack(zs).numpy()
