"""What training reads: the garment and body set up once (`Setup`: skeleton, X_c assembly, body surface near the
garment, graphs, energies), the kinematics of a clip window, and `Window`, the torch view of one window with the
garment's rollout state, Φ's features and the physics losses of equation 4. Sampling of windows and clips too."""
import numpy as np
import torch
from scipy.spatial import cKDTree

from pleat import garment_asset as ga
from pleat.garment.garment import body_collision_mask
from pleat import reference
from pleat import rotations as rot
from pleat.train import graph as graph_mod
from pleat.train import settings, sources
from pleat.train.model import skin


class Setup:
    """Everything that depends only on the garment and the body."""

    def __init__(self, cfg, garment_spec, device="cpu"):
        # a config stored by an older run may lack keys declared since: they read as their declared defaults
        self.cfg, self.device = settings.complete(cfg), torch.device(device)
        self.garment_spec = garment_spec     # what a run records as its garment (a name or a file)
        m = cfg["model"]
        self.body = sources.body(cfg["body"])
        self.garment = sources.garment(garment_spec, self.body, cfg["garment_vertices"])
        g = self.garment
        names, parents, jt, js = ga.skeleton_from_body(self.body)
        self.joint_names, self.parents = names, parents
        self.joint_template, self.joint_shapedirs = jt, js
        self.input_joints = ga.input_joint_indices(names)
        self.template = np.asarray(sources.field(g, "template"), np.float64)
        self.faces = np.asarray(sources.field(g, "faces"), np.int64)
        self.skin_indices = np.asarray(sources.field(g, "skin_indices"), np.int64)
        self.skin_weights = np.asarray(sources.field(g, "skin_weights"), np.float64)
        self.shape_blend = np.asarray(sources.field(g, "shape_blend"), np.float64)
        pinned = sources.field(g, "pinned", None)
        self.pinned = np.zeros(0, np.int64) if pinned is None else np.asarray(pinned, np.int64).ravel()
        self.name = str(np.asarray(sources.field(g, "name", "garment")))
        self.N, self.B = len(self.template), self.shape_blend.shape[0]
        self.L = m["latent"]
        self.input_count = ga.input_count_without_latent(len(self.input_joints), self.B) + self.L
        # the skeleton, ranges and clamps exactly as the asset will carry them (X_c is assembled from this)
        self.asset_stub = ga.weights_from_garment(g, self.body, None)
        self.asset_stub["z_mean"] = np.zeros(self.L, np.float32)
        self.material_min = np.array(ga.MATERIAL_MIN)
        self.material_max = np.array(ga.MATERIAL_MAX)
        # Body surface for proximity edges, collision and friction: the body vertices within `body_subset_m` of the
        # garment template (posing all 13.7k body vertices per frame was most of an iteration's cost). Their
        # one-ring is posed too, so that their normals are the full mesh's; only the near vertices themselves are
        # collided with. Body parts far from the garment at rest (hands, head, legs) are left out: a hand pressed
        # against the shirt is not collided.
        vc = getattr(self.body, "collision_vertex_count", None) or len(self.body.v_template)
        bf = np.asarray(getattr(self.body, "faces", np.zeros((0, 3))), np.int64)
        bf = bf if len(bf) and bf.max() < vc else None
        body_v = np.asarray(self.body.v_template[:vc], np.float64)
        radius = m["body_subset_m"]
        near = cKDTree(self.template).query(body_v)[0] < radius if radius > 0 else np.ones(vc, bool)
        collide = body_collision_mask(sources.field(g, "collision_exclude"), self.body)
        if collide is not None:         # the parts the simulator does not collide this garment with (a skirt's hands)
            near &= collide[:vc]
        keep = np.nonzero(near)[0]
        ring_faces = bf[near[bf].any(1)] if bf is not None else None
        posed = keep if bf is None else np.concatenate([keep, np.setdiff1d(ring_faces.ravel(), keep)])
        self.body_index = keep                      # [Vc] body vertices collided with (first Vc of the posed set)
        self.body_collide = len(keep)
        remap = np.full(vc, -1, np.int64)
        remap[posed] = np.arange(len(posed))
        self.body_v = body_v[posed]
        self.body_dirs = np.asarray(self.body.shapedirs[:vc], np.float64)[posed]
        self.body_w = np.asarray(self.body.weights[:vc], np.float64)[posed]
        self.body_faces = None
        if bf is not None:
            self.body_faces = remap[ring_faces]
            from pleat.asset import normal_adjacency
            self.body_adjacency = normal_adjacency(self.body_faces, len(posed))
        rest_n = getattr(self.body, "vertex_normals_rest", None)
        self.body_rest_normals = None if rest_n is None else np.asarray(rest_n)[:vc][posed]
        # graphs
        levels, self.vertex_level = graph_mod.build_hierarchy(self.faces, self.N, m["mp_levels"], cfg["seed"])
        self.levels = []
        for verts, edges in levels:
            e = torch.as_tensor(edges, device=self.device)
            s = torch.cat([e[:, 0], e[:, 1]])
            r = torch.cat([e[:, 1], e[:, 0]])
            mask = torch.zeros(self.N, 1, device=self.device)
            mask[torch.as_tensor(verts, device=self.device)] = 1.0
            self.levels.append((s, r, mask))
        self.chain, final = graph_mod.compressor_hierarchy(self.template, self.faces, m["conv_steps"],
                                                           m["conv_neighbours"], cfg["seed"])
        self.final_vertices = len(final)
        self.free_mask = np.ones(self.N, np.float32)
        self.free_mask[self.pinned] = 0.0
        self.energies = sources.energies(self.template, self.faces, torch, device=self.device)
        lvl = np.eye(m["mp_levels"])[self.vertex_level]
        pin = np.zeros((self.N, 1))
        pin[self.pinned] = 1.0
        self.static_node = torch.as_tensor(np.concatenate([pin, lvl], 1), dtype=torch.float32, device=self.device)
        self.node_features = 3 + 3 + 3 + 3 + 4 + 1 + self.static_node.shape[1]
        self.edge_features = 13
        self.body_features = 9

    # -- sampling --
    def sample_beta(self, rng):
        return rng.uniform(-self.cfg["stage1"]["beta_max"], self.cfg["stage1"]["beta_max"], self.B)

    def sample_material(self, rng):
        u = rng.uniform(0.0, 1.0, 4)
        return self.material_min + u * (self.material_max - self.material_min), u

    # -- per-window kinematics (numpy, float64) --
    def pose_window(self, clip, start, length, beta, prepend_first=0):
        """Frames start..start+length-1 of the clip (with `prepend_first` copies of the first frame before them,
        the runtime's first-frame convention)."""
        q = np.asarray(clip.rotations[start:start + length], np.float64)
        tr = np.asarray(clip.root_translation[start:start + length], np.float64)
        rq = np.asarray(clip.root_rotation[start:start + length], np.float64)
        dt = np.full(len(q), 1.0 / float(clip.fps))
        if prepend_first:
            q = np.concatenate([np.repeat(q[:1], prepend_first, 0), q])
            tr = np.concatenate([np.repeat(tr[:1], prepend_first, 0), tr])
            rq = np.concatenate([np.repeat(rq[:1], prepend_first, 0), rq])
            dt = np.concatenate([np.full(prepend_first, dt[0]), dt])
        feats = reference.pose_features(self.parents, self.joints_of(beta), self.input_joints, q, tr, rq)
        M = feats["skin_matrices"]                                     # [W, J, 3, 4] rest → world
        W, J = M.shape[:2]
        A = np.einsum("nk,wnkab->wnab", self.skin_weights, M[:, self.skin_indices])
        shaped_body = self.body_v + self.body_dirs @ beta
        Ab = np.matmul(self.body_w, M.reshape(W, J, 12)).reshape(W, -1, 3, 4)   # [W, V, 3, 4] (BLAS, not einsum)
        body = np.matmul(Ab[..., :3], shaped_body[:, :, None])[..., 0] + Ab[..., 3]
        if self.body_faces is not None:
            n = np.stack([reference.normals(b, self.body_faces, *self.body_adjacency) for b in body])
        else:
            n = np.matmul(Ab[..., :3], self.body_rest_normals[:, :, None])[..., 0]
            n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)
        body, n = body[:, :self.body_collide], n[:, :self.body_collide]
        Hinv = np.swapaxes(rot.yaw_matrix(feats["yaw"]), -1, -2)
        return {"A": A, "body": body, "body_normals": n, "dt": dt, "Hinv": Hinv, "p0": feats["pelvis"],
                "quats": q, "root_translation": tr, "root_rotation": rq}

    def joints_of(self, beta):
        return reference.shaped_joints(self.joint_template, self.joint_shapedirs, beta)

    def static_inputs(self, win, beta, material):
        """X_c (latent block zero) for every frame of the window, by the reference's own assembly: row f is the
        input that predicts frame f (rows 0 and 1 use the first-frame history rule and are not used in windows)."""
        return reference.assemble_inputs(self.asset_stub, win["quats"], win["root_translation"],
                                         win["root_rotation"], win["dt"], beta, material)

    def shaped(self, beta):
        return self.template + np.einsum("b,bnc->nc", beta, self.shape_blend)


def to_t(a, device):
    return torch.as_tensor(np.ascontiguousarray(a), dtype=torch.float32, device=device)


def vertex_normals(x, faces):
    """Area-weighted unit vertex normals of x [..., N, 3] in torch, differentiable: the normals of
    pleat.reference.normals (each face's cross product added to its three vertices), for Φ's features and losses."""
    fn = torch.cross(x[..., faces[:, 1], :] - x[..., faces[:, 0], :], x[..., faces[:, 2], :] - x[..., faces[:, 0], :],
                     dim=-1)
    n = torch.zeros_like(x)
    for c in range(3):
        n = n.index_add(x.dim() - 2, faces[:, c], fn)
    return n / n.norm(dim=-1, keepdim=True).clamp_min(1e-12)


class Window:
    """Torch view of one sampled window plus the garment's rollout state."""

    def __init__(self, setup, win, beta, material, material01):
        d = setup.device
        self.setup, self.win = setup, win
        self.A = to_t(win["A"], d)
        self.body = win["body"]
        self.body_t = to_t(win["body"], d)
        self.body_n = to_t(win["body_normals"], d)
        self.Hinv, self.p0 = to_t(win["Hinv"], d), to_t(win["p0"], d)
        self.dt = win["dt"]
        self.shaped = to_t(setup.shaped(beta), d)
        self.rest = setup.energies.rest_for(setup.shaped(beta), self.shaped)
        self.material = to_t(material, d)
        self.material01 = to_t(material01, d)
        self.trees = {}
        lbs = skin(self.A[:3], self.shaped)
        self.states = [lbs[0], lbs[1], lbs[2]]  # x_{t-2}, x_{t-1}, x_t

    def tree(self, f):
        if f not in self.trees:
            self.trees[f] = cKDTree(self.body[f])
        return self.trees[f]

    def features(self, f):
        """X_H+ for predicting frame f from the last three states, canonicalised in the heading frame of f."""
        s = self.setup
        x2, x1, x0 = self.states[-3], self.states[-2], self.states[-1]
        dt = float(self.dt[f])
        Hinv, p0 = self.Hinv[f], self.p0[f]
        vel = (x0 - x1) / dt
        acc = (x0 - 2 * x1 + x2) / dt ** 2
        pos = x0 - p0
        nrm = vertex_normals(x0, s.energies.faces)
        N = s.N
        node = torch.cat([pos @ Hinv.T, vel @ Hinv.T, 0.1 * acc @ Hinv.T, nrm @ Hinv.T,
                          self.material01.expand(N, 4), torch.full((N, 1), dt * 30.0), s.static_node], -1)
        edges = []
        for snd, rcv, _ in s.levels:
            rel = (x0[snd] - x0[rcv]) @ Hinv.T
            rest = self.shaped[snd] - self.shaped[rcv]
            edges.append(torch.cat([rel, rel.norm(dim=-1, keepdim=True), rest, rest.norm(dim=-1, keepdim=True),
                                    self.material01.expand(len(snd), 4), torch.full((len(snd), 1), dt * 30.0)], -1))
        dist, idx = self.tree(f - 1).query(x0.detach().cpu().numpy())
        keep = np.nonzero(dist < s.cfg["model"]["body_radius_m"])[0]
        recv = torch.as_tensor(keep, device=s.device)
        bi = torch.as_tensor(idx[keep], device=s.device)
        b_t = (self.body_t[f - 1][bi] - x0[recv]) @ Hinv.T
        b_n = (self.body_t[f][bi] - x0[recv]) @ Hinv.T
        body = torch.cat([b_t, b_n, b_t.norm(dim=-1, keepdim=True), b_n.norm(dim=-1, keepdim=True),
                          torch.full((len(keep), 1), dt * 30.0)], -1)
        return node, edges, body, recv

    def advance(self, f, displacement):
        x = skin(self.A[f], self.shaped + displacement)
        self.states.append(x)
        return x

    def losses(self, f):
        s = self.setup
        x, x_t, x_tm1 = self.states[-1], self.states[-2], self.states[-3]
        _, idx = self.tree(f).query(x.detach().cpu().numpy())
        idx = torch.as_tensor(idx, device=s.device)
        return s.energies.terms(x, x_t, x_tm1, self.material, float(self.dt[f]), self.body_t[f][idx],
                                self.body_n[f][idx], self.body_t[f - 1][idx], self.rest)


def sample_window(setup, clips, rng, length, beta=None, material=None):
    while True:
        clip = clips[rng.integers(len(clips))]
        if len(clip.rotations) >= length:
            break
    start = rng.integers(0, len(clip.rotations) - length + 1)
    beta = setup.sample_beta(rng) if beta is None else beta
    mat, mat01 = setup.sample_material(rng) if material is None else material
    win = setup.pose_window(clip, start, length, beta)
    return win, beta, mat, mat01


def physics_clips(cfg, body):
    """Training clips for the physics-loss stages (stage 1, ablation): the training split without the clips named
    in `stage1.exclude_clips` (substrings of the clip name). Clips whose LBS is shredded (cartwheel, crawl, roll,
    getup, backflip, spins) carry 10⁴–10⁵ J of LBS stretching per window, against 10²–10³ J for walks, and
    dominated the first default run's loss."""
    clips = sources.clips("train", cfg["fps"], cfg["clips"]["train_limit"] or None,
                          cfg["clips"]["frames_limit"] or None, body)
    drop = cfg["stage1"]["exclude_clips"]
    kept = [c for c in clips if not any(d in c.name for d in drop)]
    return kept or clips
