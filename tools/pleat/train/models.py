"""The three trained models, built from the networks of pleat.train.model: stage 1's Φ with the inference block,
stage 2's latent predictor f_LP (with the asset's normalisation and latent guard baked in) and the ablation's
f_LP → f_dec → D trained on the physics losses directly."""
import numpy as np
import torch

from pleat.train.model import InferenceBlock, Phi


class Stage1Model(torch.nn.Module):
    def __init__(self, setup):
        super().__init__()
        m = setup.cfg["model"]
        self.phi = Phi(m, setup.node_features, setup.edge_features, setup.body_features, m["mp_levels"],
                       setup.chain, setup.final_vertices)
        self.block = InferenceBlock(m, setup.N, free_mask=setup.free_mask)

    def forward(self, node, edges, body, recv, graph):
        z = self.phi.encode_process_convolve(node, edges, graph, body, recv)
        return z, self.block.displacement(z)


class LatentPredictor(torch.nn.Module):
    """f_LP with the asset's normalisation and latent guard baked in, so training runs exactly what ships."""

    def __init__(self, setup, norms):
        super().__init__()
        m = setup.cfg["model"]
        from pleat.train.model import mlp
        self.lp = mlp([setup.input_count] + list(m["lp_hidden"]) + [setup.L], m["activation"])
        for k, v in norms.items():
            self.register_buffer(k, torch.as_tensor(np.asarray(v), dtype=torch.float32))

    def forward(self, z_prev, static):
        x = torch.cat([z_prev, static[..., z_prev.shape[-1]:]], -1)
        y = self.lp((x - self.x_mean) / self.x_std)
        z = torch.minimum(torch.maximum(y * self.z_std + self.z_mean, self.z_min), self.z_max)
        return y, z


class AblationModel(torch.nn.Module):
    def __init__(self, setup, norms):
        super().__init__()
        self.lp = LatentPredictor(setup, norms)
        self.block = InferenceBlock(setup.cfg["model"], setup.N, free_mask=setup.free_mask)

    def forward(self, z_prev, row):
        _, z = self.lp(z_prev, row)
        return z, self.block.displacement(z)
