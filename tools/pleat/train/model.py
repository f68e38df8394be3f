"""Networks of the two stages (paper sections 3.2 and 3.3), in PyTorch.

Φ = Encode–Process–Convolve–Decode: HOOD-style MLP encoders, multi-level message passing over the garment graph and
body–garment proximity edges, a spatially varying mesh-convolution compressor (Zhou et al. 2020) down to the latent
Z ∈ R^L, the decoder MLP f_dec: R^L → R^D and D learnable blend shapes. The inference block Ψ = f_LP → f_dec → blend
shapes is what the asset stores; `mlp_to_weights` names its layers the way docs/asset-format.md does.
"""
import torch
from torch import nn

ACTIVATIONS = {"relu": nn.ReLU, "silu": nn.SiLU}


def mlp(sizes, activation="relu", layer_norm=False):
    layers = []
    for i in range(len(sizes) - 1):
        layers.append(nn.Linear(sizes[i], sizes[i + 1]))
        if i < len(sizes) - 2:
            layers.append(ACTIVATIONS[activation]())
    if layer_norm:
        layers.append(nn.LayerNorm(sizes[-1]))
    return nn.Sequential(*layers)


def linear_layers(seq):
    return [m for m in seq if isinstance(m, nn.Linear)]


class GraphBlock(nn.Module):
    """One message-passing step (MeshGraphNets / HOOD): edge update from (edge, sender, receiver), node update from
    (node, Σ incoming edges[, Σ incoming body edges]); both residual."""

    def __init__(self, hidden, with_body):
        super().__init__()
        self.edge = mlp([3 * hidden, hidden, hidden], layer_norm=True)
        self.with_body = with_body
        if with_body:
            self.body_edge = mlp([2 * hidden, hidden, hidden], layer_norm=True)
        self.node = mlp([(3 if with_body else 2) * hidden, hidden, hidden], layer_norm=True)

    def forward(self, h, e, senders, receivers, node_mask, body=None):
        e = e + self.edge(torch.cat([e, h[senders], h[receivers]], -1))
        agg = torch.zeros_like(h).index_add_(0, receivers, e)
        parts = [h, agg]
        if self.with_body:
            be, brecv = body
            be = be + self.body_edge(torch.cat([be, h[brecv]], -1))
            parts.append(torch.zeros_like(h).index_add_(0, brecv, be))
            body = (be, brecv)
        h = h + node_mask * self.node(torch.cat(parts, -1))
        return h, e, body


class VCConv(nn.Module):
    """Spatially varying convolution of Zhou et al. 2020: each (output vertex, neighbour) pair mixes M shared kernel
    bases with its own learned coefficients; the output vertices are a down-sampled subset."""

    def __init__(self, neighbours, c_in, c_out, bases):
        super().__init__()
        self.register_buffer("nbr", torch.as_tensor(neighbours))
        n_out, k = neighbours.shape
        self.coeff = nn.Parameter(torch.randn(n_out, k, bases) / (k * bases) ** 0.5)
        self.basis = nn.Parameter(torch.randn(bases, c_in, c_out) / c_in ** 0.5)
        self.bias = nn.Parameter(torch.zeros(n_out, c_out))

    def forward(self, x):  # x [V_in, C_in] → [V_out, C_out]
        g = x[self.nbr]                                        # [V_out, K, C_in]
        mixed = torch.einsum("okm,okc->omc", self.coeff, g)    # [V_out, M, C_in]
        return torch.einsum("omc,mcd->od", mixed, self.basis) + self.bias


class VCResBlock(nn.Module):
    """Down-sampling residual block: ELU(conv(x)) + linear(learned-weight pooling of x)."""

    def __init__(self, neighbours, c_in, c_out, bases):
        super().__init__()
        self.conv = VCConv(neighbours, c_in, c_out, bases)
        k = neighbours.shape[1]
        self.pool = nn.Parameter(torch.full((neighbours.shape[0], k), 1.0 / k))
        self.res = nn.Linear(c_in, c_out)

    def forward(self, x):
        pooled = torch.einsum("ok,okc->oc", self.pool, x[self.conv.nbr])
        return nn.functional.elu(self.conv(x)) + self.res(pooled)


class Compressor(nn.Module):
    def __init__(self, chain, final_vertices, channels, bases, latent):
        super().__init__()
        blocks, c = [], channels[0]
        for nbr, c_out in zip(chain, channels[1:]):
            blocks.append(VCResBlock(nbr, c, c_out, bases))
            c = c_out
        self.blocks = nn.ModuleList(blocks)
        self.flat = nn.Linear(final_vertices * c, latent)

    def forward(self, h):
        for b in self.blocks:
            h = b(h)
        return self.flat(h.reshape(-1))


class Phi(nn.Module):
    """Stage-1 network: per-step garment/body features → (Z, blend weights)."""

    def __init__(self, cfg, node_features, edge_features, body_features, levels, chain, final_vertices):
        super().__init__()
        H = cfg["hidden"]
        self.schedule = list(cfg["mp_schedule"])
        self.node_enc = mlp([node_features, H, H], layer_norm=True)
        self.edge_enc = nn.ModuleList([mlp([edge_features, H, H], layer_norm=True) for _ in range(levels)])
        self.body_enc = mlp([body_features, H, H], layer_norm=True)
        self.blocks = nn.ModuleList([GraphBlock(H, with_body=(l == 0)) for l in self.schedule])
        chans = [H] + list(cfg["conv_channels"])[:len(chain)]
        self.compressor = Compressor(chain, final_vertices, chans, cfg["conv_bases"], cfg["latent"])

    def encode_process_convolve(self, node_x, edge_x, graph, body_x, body_recv):
        h = self.node_enc(node_x)
        e = [enc(x) for enc, x in zip(self.edge_enc, edge_x)]
        body = (self.body_enc(body_x), body_recv)
        for block, l in zip(self.blocks, self.schedule):
            s, r, mask = graph[l]
            h, e[l], b = block(h, e[l], s, r, mask, body if l == 0 else None)
            if l == 0:
                body = b
        return self.compressor(h)


class InferenceBlock(nn.Module):
    """f_dec and the learnable blend shapes D (shared by both stages), and optionally f_LP (stage 2, ablation)."""

    def __init__(self, cfg, vertices, input_count=None, free_mask=None):
        super().__init__()
        L, D = cfg["latent"], cfg["blend"]
        self.activation = cfg["activation"]
        self.decoder = mlp([L] + list(cfg["dec_hidden"]) + [D], cfg["activation"])
        self.blend_shapes = nn.Parameter(torch.randn(D, vertices, 3) * cfg["blend_init_m"])
        self.register_buffer("free_mask", torch.ones(vertices, 1) if free_mask is None
                             else torch.as_tensor(free_mask, dtype=torch.float32)[:, None])
        self.lp = None
        if input_count is not None:
            self.lp = mlp([input_count] + list(cfg["lp_hidden"]) + [L], cfg["activation"])

    def displacement(self, z):
        w = self.decoder(z)
        # Pinned vertices follow LBS exactly: their rows of D are held at zero (and so written to BLND).
        return torch.einsum("...d,dnc->...nc", w, self.blend_shapes * self.free_mask)

    def exported_blend_shapes(self):
        return (self.blend_shapes * self.free_mask).detach()


def skin(blend_matrices, rest_positions):
    """LBS with per-vertex blended transforms A_i = Σ_k w_ik M_k ([..., N, 3, 4])."""
    return torch.einsum("...nab,...nb->...na", blend_matrices[..., :3], rest_positions) + blend_matrices[..., 3]


def mlp_to_weights(seq, prefix):
    out = {}
    for i, lin in enumerate(linear_layers(seq)):
        out[f"{prefix}.{i}.weight"] = lin.weight.detach().cpu().numpy().astype("float32")
        out[f"{prefix}.{i}.bias"] = lin.bias.detach().cpu().numpy().astype("float32")
    return out
