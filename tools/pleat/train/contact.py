"""Contact-aware fine-tuning of a fitted inference block (the simulator-supervised recipe's last step).

A block fitted to simulated garments by least squares learns their conditional mean; where the shirt lies on the
body, half of its error points inwards, and the garment pokes through the body (the first simulator-supervised
t-shirt: 4–6 % of vertex-frames inside the body against 2.2 % for LBS-only and 0.9 % for the simulator). Here f_LP,
f_dec and the blend shapes are trained on, through the skinning, on windows of the simulated sequences fed their own
predictions as in stage 2, with two terms in the posed frame:

    loss = mean ‖x − x_sim‖² (mm²) + w_contact · mean max(0, ε − (x − b)·n)² (mm²)
           + w_strain · mean (‖x_i − x_j‖ − ‖x_sim,i − x_sim,j‖)² over the garment's edges (mm²)

x the garment the runtime would produce, x_sim the simulator's, b and n the posed position and normal of the body
vertex nearest to the simulated vertex in the rest frame (found once per frame; near the body LBS moves garment and
body alike, so the rest-frame neighbour is the posed one). Body vertices are the training setup's subset near the
garment (`model.body_subset_m`), posed by the body's own skinning weights.

The strain term (`simsup.contact_strain_weight`, 0 by default) is for loose cloth. A least-squares fit of a skirt
learns the mean of the folds it can swing into, and a mean of folded states is not a garment of the same edge
lengths: measured on the dress, the fitted skirt's edges were stretched or shrunk twice as far from the simulated
ones as plain skinning leaves them. Matching the simulated edge lengths frame by frame keeps the prediction a
garment the simulator could have made.
"""
import time
from pathlib import Path

import numpy as np
import torch
from scipy.spatial import cKDTree

from pleat import reference
from pleat.garment_asset import ContactCandidates
from pleat.train import sources


def _pad(arrays, T, dtype):
    shape = (len(arrays), T) + arrays[0].shape[1:]
    out = np.zeros(shape, dtype)
    for i, a in enumerate(arrays):
        out[i, :len(a)] = a
    return torch.as_tensor(out)


def prepare(setup, seqs):
    """Tensors for the fine-tune: per sequence the shaped garment and body, rest body normals; per frame the joint
    skinning matrices, the simulated displacement and each garment vertex's nearest body vertex."""
    T = max(len(s["disp"]) for s in seqs)
    Vc = setup.body_collide
    shaped_g, shaped_b, normals_b, nearest = [], [], [], []
    for s in seqs:
        beta = s["beta"]
        g = setup.shaped(beta)
        b = setup.body_v + setup.body_dirs @ beta
        n = reference.normals(b, setup.body_faces, *setup.body_adjacency) if setup.body_faces is not None \
            else setup.body_rest_normals
        tree = cKDTree(b[:Vc])
        nearest.append(tree.query((g[None] + s["disp"]).reshape(-1, 3))[1].reshape(len(s["disp"]), -1)
                       .astype(np.int32))
        shaped_g.append(g)
        shaped_b.append(b[:Vc])
        normals_b.append(n[:Vc])
    return {"M": _pad([s["M"].reshape(len(s["M"]), -1, 12) for s in seqs], T, np.float32),
            "disp": _pad([s["disp"] for s in seqs], T, np.float32),
            "nearest": _pad(nearest, T, np.int32).long(),
            "shaped_g": torch.as_tensor(np.array(shaped_g), dtype=torch.float32),
            "shaped_b": torch.as_tensor(np.array(shaped_b), dtype=torch.float32),
            "normals_b": torch.as_tensor(np.array(normals_b), dtype=torch.float32),
            "skin_idx": torch.as_tensor(setup.skin_indices), "skin_w": torch.as_tensor(setup.skin_weights,
                                                                                        dtype=torch.float32),
            "body_w": torch.as_tensor(setup.body_w[:Vc], dtype=torch.float32),
            "edges": torch.as_tensor(_unique_edges(setup.faces))}


def _unique_edges(faces):
    f = np.asarray(faces, np.int64)
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    return np.unique(e, axis=0)


def _posed(A, v):
    """A [..., N, 12] (rows of a 3×4), v [..., N, 3] → A·[v; 1]."""
    A = A.reshape(*A.shape[:-1], 3, 4)
    return torch.einsum("...ab,...b->...a", A[..., :3], v) + A[..., 3]


def terms(data, seq, frame, disp_pred, eps_m, strain=False):
    """(mean squared error mm², mean squared penetration below ε mm², share of vertices inside[, mean squared edge
    length error mm² with strain=True]) for a batch of (sequence, frame) with predicted rest-frame displacements
    [b, N, 3]."""
    M = data["M"][seq, frame]                                                       # [b, J, 12]
    A = torch.einsum("nk,bnkc->bnc", data["skin_w"], M[:, data["skin_idx"]])        # [b, N, 12]
    g = data["shaped_g"][seq]
    x = _posed(A, g + disp_pred)
    x_sim = _posed(A, g + data["disp"][seq, frame])
    near = data["nearest"][seq, frame]                                              # [b, N]
    bi = seq[:, None].expand_as(near)
    Ab = torch.einsum("bnj,bjc->bnc", data["body_w"][near], M)                      # [b, N, 12]
    b = _posed(Ab, data["shaped_b"][bi, near])
    n = torch.einsum("bnij,bnj->bni", Ab.reshape(*Ab.shape[:-1], 3, 4)[..., :3], data["normals_b"][bi, near])
    n = n / n.norm(dim=-1, keepdim=True).clamp_min(1e-9)
    sd = ((x - b) * n).sum(-1)
    err = ((x - x_sim) ** 2).sum(-1).mean() * 1e6
    pen = (torch.relu(eps_m - sd) ** 2).mean() * 1e6
    if not strain:
        return err, pen, (sd < 0).float().mean()
    e = data["edges"]
    length = (x[:, e[:, 0]] - x[:, e[:, 1]]).norm(dim=-1)
    length_sim = (x_sim[:, e[:, 0]] - x_sim[:, e[:, 1]]).norm(dim=-1)
    return err, pen, (sd < 0).float().mean(), ((length - length_sim) ** 2).mean() * 1e6


def keep_zero_blocks(modules):
    """Masks the gradient of every Linear weight that is exactly 0 now, so it stays 0 under Adam (a zero gradient
    moves nothing). A packed ensemble (pleat.train.ensemble) has zero blocks between its members: kept, the members
    stay independent and the runtime keeps skipping those blocks (sdk/src/layer_blocks.c: the shipped ensemble's step
    costs what its members cost). A trained dense layer has no exact zeros, so this leaves it free. Returns the hooks'
    handles (remove them when done)."""
    from pleat.train.model import linear_layers
    handles = []
    for module in modules:
        for lin in linear_layers(module):
            keep = (lin.weight.detach() != 0).to(lin.weight.dtype)
            if bool((keep == 0).any()):
                handles.append(lin.weight.register_hook(lambda g, keep=keep: g * keep))
    return handles


def finetune(lp, block, train, data, iterations, lr=1e-4, batch=16, window=8, w_contact=30.0, eps_m=2e-3,
             gen=None, log=None, deadline=None, w_strain=0.0):
    """Trains f_LP, f_dec and the blend shapes (at 0.1× lr) on the posed error plus the contact term (and, with
    w_strain > 0, the edge-length term), on windows that start at a recorded latent and are fed their own
    predictions (as stage 2). `train`: the distillation's sequences (X_c rows and latent targets), in the order of
    `data`."""
    from pleat.train import core
    gen = gen or torch.Generator().manual_seed(0)
    lengths, static, target = core.padded_sequences(train)
    lp.train()
    params = [{"params": list(lp.parameters()) + list(block.decoder.parameters()), "lr": lr},
              {"params": [block.blend_shapes], "lr": lr * 0.1}]
    block.blend_shapes.requires_grad_(True)
    hooks = keep_zero_blocks([lp.lp, block.decoder])
    opt = torch.optim.Adam(params)
    t0 = time.time()
    done = 0
    err = pen = inside = strain = None   # stay None when no iteration ran (a budget already spent, 0 iterations)
    for it in range(iterations):
        if deadline is not None and time.time() > deadline:      # --max-minutes: stop where the budget ends
            break
        done = it + 1
        idx = torch.randint(len(lengths), (batch,), generator=gen)
        n = lengths[idx]
        starts = (torch.rand(batch, generator=gen) * (n - window).clamp_min(0).add(1)).long()
        z_prev = target[idx, starts]
        err = pen = inside = strain = 0.0
        for k in range(window):
            j = torch.minimum(starts + k, n - 1)
            _, z_prev = lp(z_prev, static[idx, j])
            disp = block.displacement(z_prev)
            e, p, i, *s = terms(data, idx, j, disp, eps_m, strain=w_strain > 0)
            err, pen, inside = err + e / window, pen + p / window, inside + i / window
            if s:
                strain = strain + s[0] / window
        loss = err + w_contact * pen + w_strain * strain
        opt.zero_grad()
        loss.backward()
        torch.nn.utils.clip_grad_norm_(lp.parameters(), 1.0)
        opt.step()
        if log is not None and (it % 50 == 0 or it == iterations - 1):
            rec = {"contact_iteration": it, "error_mm2": float(err.detach()),
                   "penetration_mm2": float(pen.detach()), "inside_share": float(inside),
                   "time_s": round(time.time() - t0, 1)}
            if w_strain > 0:
                rec["edge_length_error_mm2"] = float(strain.detach())
            log(rec)
    lp.eval()
    block.blend_shapes.requires_grad_(False)
    for h in hooks:
        h.remove()
    last = lambda v: None if v is None else float(v.detach())
    return {"iterations": done, "final_error_mm2": last(err), "final_penetration_mm2": last(pen),
            "final_inside_share": last(inside), "w_contact": w_contact, "eps_m": eps_m, "w_strain": w_strain,
            "final_edge_length_error_mm2": last(strain) if w_strain > 0 else None,
            "time_s": time.time() - t0}


# Data-driven contact candidates (asset 1.2 BACA): the body points a garment vertex is checked against at run time
# are chosen where the simulated garment actually was. Measured (docs/accuracy.md "Body contact"): on the validation
# clips, 16 rest-nearest body vertices left 0.50 % of vertex-frames inside the body; the 16 most often nearest in the
# simulated training frames 0.31 %, the same error (the cloth slides several centimetres over the body, and hands touch
# the shirt, which no rest neighbourhood covers).
CANDIDATE_RADIUS_M = 0.03


def candidate_vertices(setup, seqs, count, stride=3, radius_m=CANDIDATE_RADIUS_M):
    """Per garment vertex, `count` body vertex ids (pleat.garment_asset.ContactCandidates): its rest-nearest body
    vertex first, then the body vertices nearest to it in the simulated frames of `seqs` (each with "M" [T, J, 3, 4],
    "beta" and the rest-frame
    "disp" [T, N, 3], as simsup's training sequences; every `stride`-th frame, and only where the garment is within
    `radius_m` of the body), most often nearest first, then its further rest neighbours. The posed body of
    `setup.body` is searched where the garment collides with it (all of it unless the garment's collision_exclude
    leaves parts out, as the simulator did). For `pleat.garment_asset.body_anchors(candidate_vertices=…)`."""
    import scipy.sparse

    body = setup.body
    W = scipy.sparse.csr_matrix(np.asarray(body.weights, np.float64))                  # [V, J]: a few joints each

    def frames():
        for s in seqs:
            beta = np.asarray(s["beta"], np.float64)
            M = np.asarray(s["M"], np.float64)[::stride]                                 # [T, J, 3, 4]
            T, J = M.shape[:2]
            v = np.asarray(body.shaped_vertices(beta), np.float64)
            Ab = (W @ np.moveaxis(M.reshape(T, J, 12), 1, 0).reshape(J, -1)).reshape(len(v), T, 3, 4)
            posed_body = np.einsum("vtab,vb->tva", Ab[..., :3], v) + np.moveaxis(Ab[..., 3], 0, 1)
            A = np.einsum("nk,tnkab->tnab", setup.skin_weights, M[:, setup.skin_indices])
            rest = setup.shaped(beta)[None] + np.asarray(s["disp"], np.float64)[::stride]
            x = np.einsum("tnab,tnb->tna", A[..., :3], rest) + A[..., 3]
            yield from zip(x, posed_body)
    return candidates_from_frames(body, sources.field(setup.garment, "collision_exclude"), setup.template,
                                  frames(), count, radius_m)


def candidates_from_frames(body, collision_exclude, template, frames, count, radius_m=CANDIDATE_RADIUS_M,
                           source="simulated frames"):
    """ContactCandidates (see candidate_vertices) from posed frames: `frames` yields (garment positions [N, 3], posed
    body vertices [V, 3]) pairs; the body is searched where the garment collides with it (collision_exclude, as
    Garment.body_collision_mask reads it); `source` says where the frames came from."""
    from pleat.garment.garment import body_collision_mask
    collide = body_collision_mask(collision_exclude, body)
    ids = np.arange(len(body.v_template)) if collide is None else np.flatnonzero(collide)
    N = len(template)
    counts = [dict() for _ in range(N)]
    seen = 0
    for x, posed_body in frames:
        d, j = cKDTree(np.asarray(posed_body)[ids]).query(np.asarray(x, np.float64))
        j = ids[j]
        for i in np.flatnonzero(d < radius_m):
            counts[i][int(j[i])] = counts[i].get(int(j[i]), 0) + 1
        seen += 1
    if seen == 0:
        raise ValueError("contact candidates: no frames")
    _, rest_nearest = cKDTree(np.asarray(body.v_template, np.float64)[ids]).query(
        np.asarray(template, np.float64), k=count)
    rest_nearest = ids[np.asarray(rest_nearest).reshape(N, count)]
    table = np.full((N, count), -1, np.int64)
    for i, c in enumerate(counts):
        ranked = [int(rest_nearest[i, 0])] + sorted(c, key=lambda b: (-c[b], b)) + [int(b) for b in rest_nearest[i]]
        chosen = list(dict.fromkeys(ranked))[:count]
        table[i, :len(chosen)] = chosen
    return ContactCandidates(table, np.array([len(c) > 0 for c in counts], bool), source)


def candidates_from_asset(asset_path, body, clips, betas, count, stride=3, radius_m=CANDIDATE_RADIUS_M):
    """ContactCandidates (see candidate_vertices) from a trained asset's own garment instead of simulated frames: the C
    runtime runs it, body contact off, on `clips` (pleat.motion Clips) at each β of `betas`, and every `stride`-th
    frame counts. The runtime's contact corrects what the networks put inside the body, so the networks' own garment
    is where it needs candidates; and it costs seconds where a simulation costs hours. The asset's META names the
    body parts its garment does not collide with (collision_exclude, by joint name)."""
    from pleat import runtime
    from pleat.eval import scene as S
    data = Path(asset_path).read_bytes()
    _, weights = S.read_weights(asset_path)

    def frames():
        with runtime.Context() as ctx:
            asset = ctx.load_asset(data)
            for clip in clips:
                rotations = S.clip_rotations_for(clip, weights["joint_names"])
                for beta in betas:
                    body_v, _ = S.posed_body(body, clip, beta)
                    inst = ctx.create_instance(asset, beta=beta, body_contact=False)
                    try:
                        for t in range(clip.num_frames):
                            x, _ = inst.step(rotations[t], clip.root_translation[t], clip.root_rotation[t],
                                             1.0 / clip.fps)
                            if t % stride == 0:
                                yield x, body_v[t]
                    finally:
                        inst.close()
    return candidates_from_frames(body, S.collision_exclude(weights), weights["template"], frames(), count,
                                  radius_m, source="the asset's own garment on the training clips (the C runtime, "
                                                   "body contact off)")
