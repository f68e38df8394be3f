"""Batched physics-loss iterations: K windows per iteration through one graph (docs/training-speed.md, "Speed").

The per-window path in `core` (Window, rollout_loss, lbs_scale) builds one window's kinematics, rest geometry,
KD-trees, features and losses at a time. This module computes the same quantities for K windows at once:

- kinematics (`pose_windows`): forward kinematics per window, then the garment's blended transforms, the posed body
  (a sparse skinning matrix: body vertices have at most a few joint weights) and its normals for every frame of every
  window in a few array operations;
- rest geometry of the β-shaped template (`RestTopology`): the hinge and face topology is the garment's and is
  found once; only lengths, areas and angles are computed per window (`pleat.physics.cloth_rest` re-derived the
  topology with Python dictionaries for every window, twice per iteration);
- the garment graph of K windows is block-diagonal: node, edge and body-edge rows of window k sit after those of
  window k − 1, with indices offset by k·N, so Φ's MLPs and message passing run once over all K windows
  (`BatchedStage1`); the compressor and the decoder take [K, …] tensors;
- body proximity: one KD-tree per window frame, queried once per garment state (the per-window path queried the
  same state twice: for the loss of frame f and for the features predicting f + 1);
- the equation-4 terms (`terms`) per window, [K] each, written like `pleat.physics` with a leading window axis;
- the LBS-only normaliser (`lbs_terms`, numpy float64, with the kinematics: in the data worker when there is one)
  of all windows and all steps in one call: the zero-network rollout is LBS, so it needs no step-by-step loop.

The model and its parameters are the same (`core.Stage1Model`, `core.AblationModel`; checkpoints are unchanged),
and so are the losses: `tests/python/test_train_batching.py` checks that every window's loss, terms, LBS normaliser
and the gradients equal the per-window path's on fixed windows. With K windows an iteration's loss is the mean
over its windows of loss / LBS loss; K = 1 is the paper's batch of one.
"""
import collections
import contextlib
import time

import numpy as np
import scipy.sparse
import torch
from scipy.spatial import cKDTree

from pleat import reference
from pleat import rotations as rot
from pleat.physics.energies import GRAVITY_M_S2, _dihedral, _huber, _wrap_angle
from pleat.physics.xp import _TorchOps, dot, namespace
from pleat.train.data import vertex_normals
from pleat.train.model import skin

LOSS_TERMS = ("bending", "stretching", "inertia", "gravity", "friction", "collision")
_SCALE_TERMS = ("bending", "stretching", "inertia", "friction", "collision")


# ---- window sampling -------------------------------------------------------------------------------------------
def sample_pick(setup, clips, rng, length):
    """What `core.sample_window` draws, in the same order from the same generator (clip, start, β, material), without
    posing: the posing of K picks is done together by `pose_windows`."""
    while True:
        index = int(rng.integers(len(clips)))
        if len(clips[index].rotations) >= length:
            break
    start = rng.integers(0, len(clips[index].rotations) - length + 1)
    beta = setup.sample_beta(rng)
    mat, mat01 = setup.sample_material(rng)
    return {"clip": clips[index], "clip_index": index, "start": int(start), "length": int(length), "beta": beta,
            "material": mat, "material01": mat01}


# ---- static per-garment data -----------------------------------------------------------------------------------
class Kinematics:
    """The garment/body data `pose_windows` needs (numpy only, so a data worker process can hold it)."""

    def __init__(self, setup):
        self.parents, self.input_joints = setup.parents, setup.input_joints
        self.joint_template, self.joint_shapedirs = setup.joint_template, setup.joint_shapedirs
        self.skin_weights, self.skin_indices = setup.skin_weights, setup.skin_indices
        self.template, self.shape_blend = setup.template, setup.shape_blend
        self.body_v, self.body_dirs = setup.body_v, setup.body_dirs
        self.body_skin = scipy.sparse.csr_matrix(setup.body_w)       # [V, J], a few joints per body vertex
        self.body_faces = setup.body_faces
        self.body_adjacency = getattr(setup, "body_adjacency", None)
        self.body_rest_normals = setup.body_rest_normals
        self.body_collide = setup.body_collide
        self.topology = RestTopology(setup.energies.rest.faces, setup.energies.rest.hinges)
        self.mesh = Mesh(setup.energies)

    def shaped(self, betas):
        """T + G_S(β) for betas [K, B] → [K, N, 3]."""
        return self.template[None] + np.einsum("kb,bnc->knc", betas, self.shape_blend)


def kinematics(setup):
    """The setup's Kinematics, made once."""
    if "_kinematics" not in setup.__dict__:
        setup._kinematics = Kinematics(setup)
    return setup._kinematics


def pose_windows(kin, picks, normals_from=0):
    """`Setup.pose_window` for K picks of equal length, stacked: A [K, W, N, 3, 4], body / body_normals
    [K, W, Vc, 3], dt [K, W], Hinv [K, W, 3, 3], p0 [K, W, 3] (float64), plus the picks' β [K, B]. Body normals
    are computed from frame `normals_from` on (the same numbers per frame); earlier frames' are NaN."""
    M, dts, Hinv, p0 = [], [], [], []
    for p in picks:
        s, n, clip = p["start"], p["length"], p["clip"]
        q = np.asarray(clip.rotations[s:s + n], np.float64)
        tr = np.asarray(clip.root_translation[s:s + n], np.float64)
        rq = np.asarray(clip.root_rotation[s:s + n], np.float64)
        joints = reference.shaped_joints(kin.joint_template, kin.joint_shapedirs, p["beta"])
        feats = reference.pose_features(kin.parents, joints, kin.input_joints, q, tr, rq)
        M.append(feats["skin_matrices"])
        dts.append(np.full(len(q), 1.0 / float(clip.fps)))
        Hinv.append(np.swapaxes(rot.yaw_matrix(feats["yaw"]), -1, -2))
        p0.append(feats["pelvis"])
    M = np.stack(M)                                                    # [K, W, J, 3, 4] rest → world
    K, W, J = M.shape[:3]
    betas = np.stack([p["beta"] for p in picks])
    A = np.einsum("nk,swnkab->swnab", kin.skin_weights, M[:, :, kin.skin_indices])
    shaped_body = kin.body_v[None] + np.einsum("vcb,kb->kvc", kin.body_dirs, betas)          # [K, V, 3]
    Ab = kin.body_skin @ np.moveaxis(M.reshape(K * W, J, 12), 1, 0).reshape(J, -1)           # [V, K·W·12]
    Ab = np.moveaxis(Ab.reshape(-1, K, W, 3, 4), 0, 2)                                         # [K, W, V, 3, 4]
    body = np.einsum("kwvab,kvb->kwva", Ab[..., :3], shaped_body) + Ab[..., 3]
    if kin.body_faces is not None:
        normals = np.full(body.shape, np.nan)
        normals[:, normals_from:] = reference.normals(body[:, normals_from:], kin.body_faces, *kin.body_adjacency)
    else:
        normals = np.einsum("kwvab,vb->kwva", Ab[..., :3], kin.body_rest_normals)
        normals /= np.maximum(np.linalg.norm(normals, axis=-1, keepdims=True), 1e-12)
    vc = kin.body_collide
    return {"A": A, "body": body[:, :, :vc], "body_normals": normals[:, :, :vc], "dt": np.stack(dts),
            "Hinv": np.stack(Hinv), "p0": np.stack(p0), "beta": betas}


class RestTopology:
    """The rest geometry of `pleat.physics.cloth_rest` for many shapes of one mesh: the faces, hinges and the two
    faces of each hinge are fixed, so only the geometry is computed per shape."""

    def __init__(self, faces, hinges):
        self.faces = np.asarray(faces, np.int64)
        self.hinges = np.asarray(hinges, np.int64)
        face_of = {}
        for fi, (a, b, c) in enumerate(self.faces):
            face_of[(a, b)] = fi
            face_of[(b, c)] = fi
            face_of[(c, a)] = fi
        self.hinge_fa = np.array([face_of[(a, b)] for a, b in self.hinges[:, :2]], np.int64)
        self.hinge_fb = np.array([face_of[(b, a)] for a, b in self.hinges[:, :2]], np.int64)

    def geometry(self, shaped):
        """shaped [K, N, 3] float64 → dm_inv [K, F, 2, 2], face_area [K, F], hinge_angle, hinge_weight [K, H],
        vertex_area [K, N] (numpy float64, the formulas of cloth_rest)."""
        x = np.asarray(shaped, np.float64)
        f = self.faces
        K, N = x.shape[:2]
        d1 = x[:, f[:, 1]] - x[:, f[:, 0]]
        d2 = x[:, f[:, 2]] - x[:, f[:, 0]]
        l1 = np.linalg.norm(d1, axis=-1)
        n = np.cross(d1, d2)
        nlen = np.linalg.norm(n, axis=-1)
        if np.any(nlen <= 0) or np.any(l1 <= 0):
            raise ValueError("garment has degenerate (zero-area) faces")
        dm = np.zeros(l1.shape + (2, 2))
        dm[..., 0, 0] = l1
        dm[..., 0, 1] = np.einsum("kij,kij->ki", d1, d2) / l1
        dm[..., 1, 1] = nlen / l1
        area = 0.5 * nlen
        h = self.hinges
        if len(h):
            elen2 = np.sum((x[:, h[:, 1]] - x[:, h[:, 0]]) ** 2, axis=-1)
            weight = 3.0 * elen2 / (area[:, self.hinge_fa] + area[:, self.hinge_fb])
            angle = _dihedral(*(x[:, h[:, i]] for i in range(4)), np)
        else:
            weight = angle = np.zeros((K, 0))
        slots = (f.reshape(1, -1) + N * np.arange(K)[:, None]).ravel()
        vertex_area = np.bincount(slots, weights=np.repeat(area / 3.0, 3, axis=-1).ravel(),
                                  minlength=K * N).reshape(K, N)
        return {"dm_inv": np.linalg.inv(dm), "face_area": area, "hinge_angle": angle, "hinge_weight": weight,
                "vertex_area": vertex_area}


def prepare(kin, picks, lbs_steps=None):
    """Everything about K picks that does not depend on the network (numpy): kinematics, shaped template, rest
    geometry, the KD-tree of the body in every frame from the third on (the first one queried) and, with
    `lbs_steps`, the LBS-only terms of rollouts of that many steps (`lbs_terms`). Cheap to send to another
    process."""
    win = pose_windows(kin, picks, normals_from=3)     # normals enter the losses only, from frame 3 on
    shaped = kin.shaped(win["beta"])
    win["shaped"] = shaped
    win["rest"] = kin.topology.geometry(shaped)
    win["material"] = np.stack([p["material"] for p in picks])
    win["material01"] = np.stack([p["material01"] for p in picks])
    # frames 0 and 1 only start the garment (its LBS); the first state queried is frame 2's (features of frame 3)
    win["trees"] = [[None, None] + [cKDTree(b) for b in frames[2:]] for frames in win["body"]]
    if lbs_steps:
        win["lbs_terms"] = lbs_terms(kin, win, lbs_steps)
    return win


class _Prepared:
    """The clip list and kinematics a data worker prepares windows from (held by the worker process)."""

    def __init__(self, kin, clips, asset_stub=None, drop_trees=False):
        self.kin, self.clips, self.asset_stub, self.drop_trees = kin, clips, asset_stub, drop_trees

    def __call__(self, picks, static=False, lbs_steps=None):
        picks = [dict(p, clip=self.clips[p["clip_index"]]) for p in picks]
        win = prepare(self.kin, picks, lbs_steps)
        if self.drop_trees:
            win.pop("trees")
        if static:
            win["static"] = np.stack([static_inputs(self.asset_stub, p) for p in picks])
        return win


def static_inputs(asset_stub, pick):
    """Setup.static_inputs of a pick: X_c (latent block zero) for every frame of its window."""
    s, n, clip = pick["start"], pick["length"], pick["clip"]
    return reference.assemble_inputs(asset_stub, np.asarray(clip.rotations[s:s + n], np.float64),
                                     np.asarray(clip.root_translation[s:s + n], np.float64),
                                     np.asarray(clip.root_rotation[s:s + n], np.float64),
                                     np.full(n, 1.0 / float(clip.fps)), pick["beta"], pick["material"])


def _worker_loop(prepared, conn):
    while True:
        msg = conn.recv()
        if msg is None:
            break
        picks, static, steps = msg
        win = prepared(picks, static, steps)
        win["worker_cpu_s"] = time.process_time()        # the worker's CPU time so far, for the bench's totals
        conn.send(win)


class WindowSource:
    """K windows per call, drawn from `rng` in the order `core.sample_window` draws them, prepared (kinematics,
    rest geometry, KD-trees, LBS-only terms, optionally X_c rows) here or, with `workers` ≥ 1, in that many forked
    processes that many calls ahead: while torch trains on iteration i, the workers prepare iterations i + 1 … i +
    workers, round robin (numpy/scipy only; they never touch torch). One worker is what two cores can use; more pay
    where the trainer has a GPU and the machine more cores (docs/training-speed.md, "On a GPU"). `steps` is guessed ahead
    by `next_steps`; when a guess misses (the rollout schedule moved on, 4 times a run), those windows are dropped and
    new ones drawn and prepared here. With `drop_trees` the KD-trees stay in the worker (the trainer finds nearest
    body vertices on its device: `nearest="torch"`), which spares pickling them across the pipe."""

    def __init__(self, setup, clips, rng, windows, static=False, workers=0, drop_trees=False):
        self.setup, self.clips, self.rng, self.K, self.static = setup, clips, rng, int(windows), static
        self.prepared = _Prepared(kinematics(setup), clips, setup.asset_stub if static else None, drop_trees)
        self.pending = collections.deque()     # (worker index, guessed steps) per job in flight, oldest first
        self.procs, self.conns, self.next_worker = [], [], 0
        self.worker_cpu = []                   # each worker's CPU time as of its last handed-out windows
        if workers > 0:
            import multiprocessing as mp
            ctx = mp.get_context("fork")
            for _ in range(int(workers)):
                conn, child = ctx.Pipe()
                proc = ctx.Process(target=_worker_loop, args=(self.prepared, child), daemon=True)
                proc.start()
                child.close()
                self.procs.append(proc)
                self.conns.append(conn)
                self.worker_cpu.append(0.0)

    @property
    def worker_cpu_s(self):
        """The workers' CPU time, summed, as of their last handed-out windows (for the bench's totals)."""
        return float(sum(self.worker_cpu))

    def _picks(self, steps):
        picks = [sample_pick(self.setup, self.clips, self.rng, steps + 3) for _ in range(self.K)]
        for p in picks:
            del p["clip"]          # the worker has the clips; only the index travels
        return picks

    def next(self, steps, next_steps=None):
        """The windows of this iteration (rollouts of `steps`), and with workers, keep each of them preparing a
        later iteration's (of `next_steps`, default `steps`)."""
        win = None
        if self.pending:
            w, guess = self.pending.popleft()
            win = self.conns[w].recv()
            self.worker_cpu[w] = win.pop("worker_cpu_s")
            if guess != steps:
                win = None
        if win is None:
            win = self.prepared(self._picks(steps), self.static, steps)
        n = steps if next_steps is None else next_steps
        while len(self.pending) < len(self.procs):
            w = self.next_worker
            self.next_worker = (w + 1) % len(self.procs)
            self.conns[w].send((self._picks(n), self.static, n))
            self.pending.append((w, n))
        return win

    def close(self):
        for w, _ in self.pending:
            self.conns[w].recv()
        self.pending.clear()
        for conn, proc in zip(self.conns, self.procs):
            conn.send(None)
            proc.join(timeout=10)
        self.procs, self.conns = [], []


# ---- the batch in torch ----------------------------------------------------------------------------------------
def _f32(a, device):
    return torch.as_tensor(np.ascontiguousarray(a), dtype=torch.float32, device=device)


class WindowBatch:
    """K windows of one iteration in torch, with the garments' rollout states [K, N, 3]."""

    def __init__(self, setup, win, compiled_terms=False, nearest="auto"):
        d = self.device = setup.device
        # "kdtree": the prepared KD-trees on the CPU; "torch": exact distances on the device (`nearest_on_device`);
        # "auto": the trees where the windows carry them
        self.on_device = nearest == "torch" or (nearest == "auto" and "trees" not in win)
        self.terms = _compiled_terms() if compiled_terms else terms
        self.setup, self.win = setup, win
        self.K, self.F = win["A"].shape[:2]
        self.N, self.Vc = setup.N, win["body"].shape[2]
        self.A = _f32(win["A"], d)
        self.body = win["body"]
        self.body_t = _f32(win["body"], d)
        self.body_n = _f32(win["body_normals"], d)
        self.Hinv_T = _f32(np.swapaxes(win["Hinv"], -1, -2), d)       # [K, F, 3, 3]: v @ Hinv.T for row vectors v
        self.p0 = _f32(win["p0"], d)
        self.dt = win["dt"]                                             # [K, F] float64
        self.dt30 = _f32(win["dt"] * 30.0, d)                           # [K, F]
        self.dt2 = _f32(win["dt"] * win["dt"], d)                       # [K, F]
        self.shaped = _f32(win["shaped"], d)
        self.rest = {k: _f32(v, d) for k, v in win["rest"].items()}
        self.material = _f32(win["material"], d)
        self.material01 = _f32(win["material01"], d)
        self.trees = None if self.on_device else win["trees"]
        self.near = {}
        self.kidx = torch.arange(self.K, device=d)
        self.rest_edges = []
        for snd, rcv, _ in setup.levels:
            r = self.shaped[:, snd] - self.shaped[:, rcv]
            self.rest_edges.append(torch.cat([r, r.norm(dim=-1, keepdim=True)], -1))
        lbs = skin(self.A[:, :3], self.shaped[:, None])
        self.states = [lbs[:, 0], lbs[:, 1], lbs[:, 2]]

    def nearest(self, f):
        """Nearest body vertex of frame f to the garment state of frame f (dist, index [K, N], torch on the device);
        a state is queried once although both the loss of frame f and the features predicting f + 1 need it."""
        if f not in self.near:
            if self.on_device:
                self.near[f] = nearest_on_device(self.states[f].detach(), self.body_t[:, f])
            else:
                x = self.states[f].detach().cpu().numpy()
                out = [self.trees[k][f].query(x[k]) for k in range(self.K)]
                self.near[f] = (torch.as_tensor(np.stack([o[0] for o in out]), device=self.device),
                                torch.as_tensor(np.stack([o[1] for o in out]), device=self.device))
        return self.near[f]

    def features(self, f):
        """Φ's inputs predicting frame f for all K windows, as block-diagonal graph rows (core.Window.features per
        window, concatenated): node [K·N, ·], edges per level [K·E_l, 13], body edges [ΣE_b, 9] and their
        receivers (indices into K·N)."""
        s, K, N = self.setup, self.K, self.N
        x2, x1, x0 = self.states[-3], self.states[-2], self.states[-1]
        dt = torch.as_tensor(self.dt[:, f], dtype=torch.float32, device=self.device)[:, None, None]
        HT = self.Hinv_T[:, f]
        vel = (x0 - x1) / dt
        acc = (x0 - 2 * x1 + x2) / self.dt2[:, f, None, None]
        pos = x0 - self.p0[:, f, None]
        nrm = vertex_normals(x0, s.energies.faces)
        dt30 = self.dt30[:, f, None, None]
        vectors = (torch.stack([pos, vel, 0.1 * acc, nrm], 2).reshape(K, N * 4, 3) @ HT).reshape(K, N, 12)
        node = torch.cat([vectors, self.material01[:, None].expand(K, N, 4), dt30.expand(K, N, 1),
                          s.static_node.expand(K, N, -1)], -1).reshape(K * N, -1)
        edges = []
        for (snd, rcv, _), rest in zip(s.levels, self.rest_edges):
            rel = (x0[:, snd] - x0[:, rcv]) @ HT
            E = len(snd)
            edges.append(torch.cat([rel, rel.norm(dim=-1, keepdim=True), rest,
                                    self.material01[:, None].expand(K, E, 4), dt30.expand(K, E, 1)],
                                   -1).reshape(K * E, -1))
        dist, idx = self.nearest(f - 1)
        k_t, recv_local = torch.nonzero(dist < s.cfg["model"]["body_radius_m"], as_tuple=True)    # row-major
        bi = idx[k_t, recv_local]
        xr = x0[k_t, recv_local]
        rel = torch.stack([self.body_t[k_t, f - 1, bi] - xr, self.body_t[k_t, f, bi] - xr], 1)     # [E_b, 2, 3]
        # rows are grouped by window (torch.nonzero is row-major): one product with each window's heading, the same
        # numbers as a per-row product with its gathered copy, without gathering E_b 3×3 matrices
        b_t, b_n = torch.cat([r.reshape(-1, 3) @ HT[k] for k, r in
                              enumerate(rel.split(torch.bincount(k_t, minlength=K).tolist()))]).view(-1, 2, 3).unbind(1)
        body = torch.cat([b_t, b_n, b_t.norm(dim=-1, keepdim=True), b_n.norm(dim=-1, keepdim=True),
                          self.dt30[k_t, f, None]], -1)
        return node, edges, body, k_t * N + recv_local

    def advance(self, f, displacement):
        x = skin(self.A[:, f], self.shaped + displacement)
        self.states.append(x)
        return x

    def losses(self, f, collision_weight):
        """Equation-4 terms of the newest state (frame f) per window, [K] each."""
        x, x_t, x_tm1 = self.states[-1], self.states[-2], self.states[-3]
        _, idx = self.nearest(f)
        k = self.kidx[:, None]
        if self.terms is not terms:        # compiled: the weight as a tensor, so its ramp recompiles nothing
            collision_weight = torch.tensor(float(collision_weight), device=self.device)
        return self.terms(torch_mesh(self.setup), x, x_t, x_tm1, self.material, self.dt2[:, f],
                          self.body_t[k, f, idx], self.body_n[k, f, idx], self.body_t[k, f - 1, idx], self.rest,
                          collision_weight)


def nearest_on_device(x, body, max_elements=1 << 24):
    """The body vertex nearest each garment vertex, by exact distances on x's device (`stage1.nearest` = "torch"):
    x [K, N, 3], body [K, V, 3] → (distance, index) [K, N]. What the KD-trees give, in float32 (a near-tie between
    two body vertices may resolve the other way); it spares the trainer the CPU round trip of every rollout step,
    which on a GPU is most of an iteration (docs/training-speed.md, "On a GPU"). Windows go in groups of at most
    `max_elements` distances (K = 32 on the 1k shirt would be 415 MB at once)."""
    K, N, V = x.shape[0], x.shape[1], body.shape[1]
    step = max(1, int(max_elements) // max(1, N * V))
    dist, idx = [], []
    for k in range(0, K, step):
        d = torch.cdist(x[k:k + step], body[k:k + step], compute_mode="donot_use_mm_for_euclid_dist")
        m = d.min(-1)
        dist.append(m.values)
        idx.append(m.indices)
    return torch.cat(dist), torch.cat(idx)


class Mesh:
    """What the equation-4 terms need besides positions: face and hinge indices (numpy, or torch on a device) and
    the constants of `sources.Energies` (collision margin ε, friction μ_f and its Huber ε_u)."""

    def __init__(self, energies, device=None):
        rest = energies.rest
        if device is None:
            self.faces, self.hinges = np.asarray(rest.faces, np.int64), np.asarray(rest.hinges, np.int64)
        else:
            self.faces = torch.as_tensor(rest.faces, device=device)
            self.hinges = torch.as_tensor(rest.hinges, device=device)
        self.eps, self.friction_mu, self.friction_eps = energies.eps, energies.friction_mu, energies.friction_eps


def torch_mesh(setup):
    if "_torch_mesh" not in setup.__dict__:
        setup._torch_mesh = Mesh(setup.energies, setup.device)
    return setup._torch_mesh


def terms(mesh, x, x_t, x_tm1, material, dt2, body_points, body_normals, body_points_t, rest, collision_weight):
    """`sources.Energies.terms` (the pleat.physics energies) with a leading window axis, for torch tensors (the
    rollout, with autograd) or numpy arrays (the LBS-only normaliser in `prepare`): x [K, N, 3], material [K, 4],
    dt2 [K] (dt² per window), rest geometry [K, …] → {term: [K]}."""
    xp = namespace(x)
    torch_side = xp is _TorchOps
    m, mu, lam, k = (material[:, i, None] for i in range(4))
    mass = m * rest["vertex_area"]
    eps = mesh.eps
    gap = xp.relu(eps - dot(x - body_points, body_normals))
    collision = (1.0 * gap * gap * gap).sum(-1)
    with torch.no_grad() if torch_side else contextlib.nullcontext():
        # lagged normal force of the collision penalty (held fixed in the step)
        g = xp.relu(eps - ((x - body_points) * body_normals).sum(-1))
        normal_force = 3.0 * g * g * (collision_weight if torch.is_tensor(collision_weight)
                                      else float(collision_weight))
    # stretching (StVK)
    faces, di = mesh.faces, rest["dm_inv"]
    x0 = x[:, faces[:, 0]]
    d1 = x[:, faces[:, 1]] - x0
    d2 = x[:, faces[:, 2]] - x0
    f0 = d1 * di[..., 0, 0, None] + d2 * di[..., 1, 0, None]
    f1 = d1 * di[..., 0, 1, None] + d2 * di[..., 1, 1, None]
    e00 = 0.5 * (dot(f0, f0) - 1.0)
    e11 = 0.5 * (dot(f1, f1) - 1.0)
    e01 = 0.5 * dot(f0, f1)
    tr = e00 + e11
    psi = mu * (e00 * e00 + e11 * e11 + 2.0 * e01 * e01) + 0.5 * lam * tr * tr
    stretching = (rest["face_area"] * psi).sum(-1)
    # bending (wrap=True, as training always measures it)
    h = mesh.hinges
    dtheta = _wrap_angle(_dihedral(x[:, h[:, 0]], x[:, h[:, 1]], x[:, h[:, 2]], x[:, h[:, 3]], xp)
                         - rest["hinge_angle"], xp)
    bending = (0.5 * k * rest["hinge_weight"] * dtheta * dtheta).sum(-1)
    # inertia, gravity (relative to the previous state)
    d = x - (2 * x_t - x_tm1)
    inertia = (0.5 * mass / dt2[:, None] * dot(d, d)).sum(-1)
    before = (mass * GRAVITY_M_S2 * x_t[..., 1]).sum(-1)
    gravity = (mass * GRAVITY_M_S2 * x[..., 1]).sum(-1) - (before.detach() if torch_side else before)
    # friction
    u = (x - x_t) - (body_points - body_points_t)
    ut = u - dot(u, body_normals)[..., None] * body_normals
    y = xp.sqrt(xp.clamp_min(dot(ut, ut), 1e-30))
    friction = (mesh.friction_mu * normal_force * _huber(y, mesh.friction_eps, xp)).sum(-1)
    return {"stretching": stretching, "bending": bending, "inertia": inertia, "gravity": gravity,
            "friction": friction, "collision": collision}


def _compiled_terms():
    """`terms` through torch.compile (`stage1.compile`), made once: its ~80 small elementwise ops on [K, F] and
    [K, H] slices fused into a few loops (≈ 30 ms less per K = 8 iteration); the same formulas, float32 rounding
    may differ."""
    global _COMPILED_TERMS
    if _COMPILED_TERMS is None:
        _COMPILED_TERMS = torch.compile(terms, dynamic=False)
    return _COMPILED_TERMS


_COMPILED_TERMS = None


def _weighted(t, w):
    return sum(w[k] * t[k] for k in LOSS_TERMS)


def rollout(batch, steps, w, predict):
    """core.rollout_loss for K windows: predict(f) → displacement [K, N, 3]. Returns the per-window loss [K] (mean
    over steps of the weighted terms) and the per-window terms {term: [K] numpy}, averaged over steps."""
    total = 0.0
    acc = {k: np.zeros(batch.K) for k in LOSS_TERMS}
    for i in range(steps):
        f = 3 + i
        batch.advance(f, predict(f))
        t = batch.losses(f, w["collision"])
        total = total + _weighted(t, w)
        for k in LOSS_TERMS:
            acc[k] += t[k].detach().cpu().numpy().astype(np.float64) / steps
    return total / steps, acc


def lbs_terms(kin, win, steps):
    """The equation-4 terms of the zero-network rollout of each window (the LBS of the shaped template in every
    frame: no step depends on a network, so all steps of all windows are one call), in numpy float64, averaged over
    steps as core.rollout_loss averages them. The friction term is given per unit collision weight (it is linear in
    it: the lagged normal force is 3·gap²·w_c), so the weights of the iteration that uses it need not be known."""
    A, shaped = win["A"][:, :steps + 3], win["shaped"]
    K = len(A)
    lbs = np.einsum("kfnab,knb->kfna", A[..., :3], shaped) + A[..., 3]           # [K, steps+3, N, 3]
    frames = np.arange(3, 3 + steps)
    idx = np.stack([np.stack([win["trees"][k][f].query(lbs[k, f])[1] for f in frames]) for k in range(K)])
    kk, ff = np.arange(K)[:, None, None], frames[None, :, None]

    def flat(a):
        return a.reshape((K * steps,) + a.shape[2:])

    rest = {k: flat(np.broadcast_to(v[:, None], (K, steps) + v.shape[1:])) for k, v in win["rest"].items()}
    t = terms(kin.mesh, flat(lbs[:, 3:]), flat(lbs[:, 2:-1]), flat(lbs[:, 1:-2]),
              flat(np.broadcast_to(win["material"][:, None], (K, steps, 4))),
              flat(win["dt"][:, 3:3 + steps] * win["dt"][:, 3:3 + steps]),
              flat(win["body"][kk, ff, idx]), flat(win["body_normals"][kk, ff, idx]),
              flat(win["body"][kk, ff - 1, idx]), rest, 1.0)
    acc = {k: np.zeros(K) for k in LOSS_TERMS}
    for i in range(steps):     # the per-window path's order: a running sum over steps of term / steps
        for k in LOSS_TERMS:
            acc[k] += t[k].reshape(K, steps)[:, i] / steps
    return acc


def lbs_scales(win, w, floor):
    """core.lbs_scale of the prepared windows (`prepare(..., lbs_steps=steps)`) at the loss weights w: scales [K]
    and the LBS-only terms {term: [K]}."""
    acc = dict(win["lbs_terms"])
    acc["friction"] = acc["friction"] * float(w["collision"])
    return np.maximum(sum(w[k] * acc[k] for k in _SCALE_TERMS), float(floor)), acc


# ---- Φ over K windows ----------------------------------------------------------------------------------------
class BatchedStage1(torch.nn.Module):
    """core.Stage1Model's forward for K windows at once (the same parameters: this module only holds the model).

    Two rewrites of the same arithmetic make it cheaper than K calls of the model:
    - the first layer of each edge MLP acts on [e, h_sender, h_receiver]; it is applied as
      W_e·e + (W_s·h)[sender] + (W_r·h)[receiver] (the same linear map split by columns), so the node terms are
      computed once per node instead of once per edge;
    - on a coarse level only that level's vertices are updated (the node mask is zero elsewhere), so the level's
      edge and node MLPs run on those vertices only, and their update is added back at their rows.

    With `bf16` (`stage1.autocast_bf16`, config.autocast_bf16) the encoders, the message passing and the compressor
    run under bfloat16 autocast: their matmuls take bf16 operands (float32 accumulation), LayerNorm and ReLU act on
    the bf16 results, while the residual node and edge streams, the sums over edges, Z, the decoder and the blend
    shapes stay float32. An opt-in approximation (docs/training-speed.md, "Speed"), not the same arithmetic."""

    def __init__(self, model, bf16=False):
        super().__init__()
        self.model = model
        self.bf16 = bool(bf16)

    def forward(self, node, edges, body, recv, graph, K):
        phi = self.model.phi
        with torch.autocast(node.device.type, torch.bfloat16, enabled=self.bf16):
            h = _f32_stream(phi.node_enc(node))
            e = [_f32_stream(enc(x)) for enc, x in zip(phi.edge_enc, edges)]
            b = (_f32_stream(phi.body_enc(body)), recv)
            for block, l in zip(phi.blocks, phi.schedule):
                if l == 0:
                    h, e[l], b = graph_block(block, h, e[l], graph[l], b)
                else:
                    h, e[l], _ = graph_block(block, h, e[l], graph[l])
            z = compress(phi.compressor, h.reshape(K, -1, h.shape[-1]))
        z = z.float()
        return z, displacement(self.model.block, z)


def _f32_stream(x):
    """An encoder's output starts a residual stream: float32 also under bf16 autocast (a no-op without it)."""
    return x.float()


def displacement(block, z):
    """InferenceBlock.displacement for z [K, L]: one matrix product with the blend shapes, then the pinned rows
    zeroed (the same numbers: the mask is 0 or 1 per vertex, so it can multiply after the sum)."""
    D, N, _ = block.blend_shapes.shape
    w = block.decoder(z)
    return (w @ block.blend_shapes.reshape(D, N * 3)).reshape(-1, N, 3) * block.free_mask


class _DynamicBody(torch.nn.Module):
    """torch.compile of BatchedStage1 whose body-edge count may change every call (one compilation)."""

    def __init__(self, net):
        super().__init__()
        self.net = net
        self.compiled = torch.compile(net)

    def forward(self, node, edges, body, recv, graph, K):
        torch._dynamo.mark_dynamic(body, 0)
        torch._dynamo.mark_dynamic(recv, 0)
        return self.compiled(node, edges, body, recv, graph, K)


def compiled(net):
    """BatchedStage1 through torch.compile (`stage1.compile`): about 1.3x less CPU per window in the network at
    K = 8 on the shared 2-core machine, after a compilation of about 3 minutes there (docs/training-speed.md, "Speed")."""
    return _DynamicBody(net)


def graph_block(block, h, e, level, body=None):
    """model.GraphBlock.forward on one level of the block-diagonal graph (see BatchedStage1). level: the dict of
    `block_graph`; `active` is None on the finest level (every vertex is updated there)."""
    lin0 = block.edge[0]
    H = h.shape[-1]
    W = lin0.weight
    active = level["active"]
    hl = h if active is None else h.index_select(0, active)
    s, r = level["senders"], level["receivers"]
    pre = (torch.nn.functional.linear(e, W[:, :H], lin0.bias) + (hl @ W[:, H:2 * H].T).index_select(0, s)
           + (hl @ W[:, 2 * H:].T).index_select(0, r))
    e = e + block.edge[1:](pre)
    parts = [hl, torch.zeros_like(hl).index_add_(0, r, e)]
    if block.with_body:
        be, brecv = body
        be = be + block.body_edge(torch.cat([be, hl.index_select(0, brecv)], -1))
        parts.append(torch.zeros_like(hl).index_add_(0, brecv, be))
        body = (be, brecv)
    update = block.node(torch.cat(parts, -1)).to(h.dtype)      # float32 under bf16 autocast, as h is
    h = h + update if active is None else h.index_add(0, active, update)
    return h, e, body


def compress(compressor, h):
    """model.Compressor.forward for h [K, N, C] → Z [K, L]. With K > 1 vertex-major (`_compress_vertex_major`):
    the same sums in another order (Z and the gradients agree to float32 rounding), 1.5× faster at K = 8; K = 1,
    the default iteration, keeps this einsum form, so its training stays bit-identical."""
    if h.shape[0] > 1:
        return _compress_vertex_major(compressor, h)
    for blk in compressor.blocks:
        conv = blk.conv
        g = h[:, conv.nbr]                                                   # [K, V_out, k, C_in]
        pooled = torch.einsum("ok,bokc->boc", blk.pool, g)
        mixed = torch.einsum("okm,bokc->bomc", conv.coeff, g)
        y = torch.einsum("bomc,mcd->bod", mixed, conv.basis) + conv.bias
        h = torch.nn.functional.elu(y) + blk.res(pooled)
    return compressor.flat(h.reshape(h.shape[0], -1))


def _compress_vertex_major(compressor, h):
    """`compress` with the windows inside each vertex's row, x [V, K·C] between blocks: a block's neighbour rows
    are gathered whole ([V_out, k, K·C]), the coefficient mixing is one batched product over output vertices with
    the windows as rows and the basis one matrix product, with no permuted copies in between (the einsum form
    copies its [K, V_out, M, C] mixture twice per block, forward and backward)."""
    K = h.shape[0]
    x = h.transpose(0, 1).reshape(h.shape[1], -1)                          # [N, K·C]
    for blk in compressor.blocks:
        conv = blk.conv
        o, k = conv.nbr.shape
        M, C, D = conv.basis.shape
        g = x.index_select(0, conv.nbr.reshape(-1)).view(o, k, K * C)       # [V_out, k, K·C]
        pooled = torch.bmm(blk.pool.unsqueeze(1), g).view(o * K, C)         # [V_out·K, C]
        mixed = torch.bmm(g.transpose(1, 2), conv.coeff)                    # [V_out, K·C, M]
        y = mixed.reshape(o * K, C * M) @ conv.basis.permute(1, 0, 2).reshape(C * M, D)
        y = (y.view(o, K, D) + conv.bias[:, None]).view(o * K, D)
        x = (torch.nn.functional.elu(y) + blk.res(pooled)).view(o, K * D)
    return compressor.flat(x.view(x.shape[0], K, -1).transpose(0, 1).reshape(K, -1))


def block_graph(setup, K):
    """setup.levels for K windows (kept on the setup): per level the senders and receivers, with window k's
    vertices at k·N + i; on coarse levels (node mask not all ones) as positions in the list of that level's
    vertices (`active`, ascending)."""
    cache = setup.__dict__.setdefault("_block_graphs", {})
    if K not in cache:
        d, N = setup.device, setup.N
        out = []
        for s, r, m in setup.levels:
            full = (s[None] + N * torch.arange(K, device=d)[:, None]).reshape(-1), \
                (r[None] + N * torch.arange(K, device=d)[:, None]).reshape(-1)
            if bool((m > 0).all()):
                out.append({"active": None, "senders": full[0], "receivers": full[1]})
                continue
            verts = torch.nonzero(m[:, 0] > 0)[:, 0]
            n = len(verts)
            pos = torch.full((N,), -1, dtype=torch.long, device=d)
            pos[verts] = torch.arange(n, device=d)
            off = n * torch.arange(K, device=d)[:, None]
            assert bool((pos[s] >= 0).all() and (pos[r] >= 0).all()), "a coarse edge leaves its level"
            out.append({"active": (verts[None] + N * torch.arange(K, device=d)[:, None]).reshape(-1),
                        "senders": (pos[s][None] + off).reshape(-1), "receivers": (pos[r][None] + off).reshape(-1)})
        cache[K] = out
    return cache[K]


# ---- one stage-1 iteration over K windows -------------------------------------------------------------------------
def stage1_loss(setup, net, win, steps, w, loss_norm, floor, compiled_terms=False):
    """The K windows' losses for one iteration. net: BatchedStage1 (or its DDP wrapper). Returns (objective for
    backward = mean over windows of loss / LBS loss, per-window raw losses [K], scales [K], terms {k: [K]}).
    compiled_terms: the equation-4 terms through torch.compile (with `stage1.compile`)."""
    batch = WindowBatch(setup, win, compiled_terms)
    scale = np.ones(batch.K)
    if loss_norm == "lbs":
        scale, _ = lbs_scales(win, w, floor)
    graph = block_graph(setup, batch.K)

    def predict(f):
        node, edges, body, recv = batch.features(f)
        return net(node, edges, body, recv, graph, batch.K)[1]

    loss, acc = rollout(batch, steps, w, predict)
    objective = (loss / torch.as_tensor(scale, dtype=loss.dtype, device=loss.device)).mean()
    return objective, loss, scale, acc


def stage1_iteration(setup, net, source, c1, steps, w, next_steps=None):
    """One stage-1 iteration's objective (to back-propagate) and its log record: with K windows, `loss`,
    `lbs_scale`, `ratio` and the terms are means over the windows (K = 1: exactly the per-window record)."""
    win = source.next(steps, next_steps)
    objective, loss, scale, acc = stage1_loss(setup, net, win, steps, w, c1["loss_norm"],
                                              c1["loss_norm_floor"], c1["compile"])
    losses = loss.detach().cpu().numpy().astype(np.float64)
    rec = {"loss": float(losses.mean()), "lbs_scale": float(scale.mean()), "ratio": float((losses / scale).mean())}
    if len(losses) > 1:
        rec["windows"] = len(losses)
    rec.update({k: float(v.mean()) for k, v in acc.items()})
    return objective, rec


@torch.no_grad()
def validate_stage1(setup, model, clips, rng, w, c1):
    """core.validate_stage1's windows (the same draws from `rng`) as one batch; returns the per-window losses,
    ratios and terms, and the LBS-only terms, as lists."""
    n, steps = c1["validation_windows"], c1["rollout_max"]
    picks = [sample_pick(setup, clips, rng, steps + 3) for _ in range(n)]
    win = prepare(kinematics(setup), picks, steps)
    batch = WindowBatch(setup, win)
    scale, lbs = lbs_scales(win, w, c1["loss_norm_floor"])
    net, graph = BatchedStage1(model), block_graph(setup, n)

    def predict(f):
        node, edges, body, recv = batch.features(f)
        return net(node, edges, body, recv, graph, n)[1]

    loss, terms = rollout(batch, steps, w, predict)
    losses = [float(v) for v in loss.cpu().numpy()]
    return (losses, [l / sc for l, sc in zip(losses, scale)], {k: list(v) for k, v in terms.items()},
            {k: list(v) for k, v in lbs.items()})


def ablation_iteration(setup, model, source, c1, steps, w, z_lo, z_hi, next_steps=None):
    """One ablation iteration over the source's K windows: f_LP → f_dec → D fed its own latents, on the stage-1
    losses; updates the latent range z_lo/z_hi in place. Returns the objective (mean over windows of loss / LBS
    loss, what core's per-window loop sums) and the log record (terms averaged over windows)."""
    win = source.next(steps, next_steps)
    batch = WindowBatch(setup, win)
    scale = np.ones(batch.K)
    if c1["loss_norm"] == "lbs":
        scale, _ = lbs_scales(win, w, c1["loss_norm_floor"])
    static = _f32(win["static"], batch.device)                          # [K, W, I]
    state = {"z": torch.zeros(batch.K, setup.L, device=batch.device)}

    def predict(f):
        z, disp = model(state["z"], static[:, f])
        state["z"] = z
        zn = z.detach().cpu().numpy()
        np.minimum(z_lo, zn.min(0), out=z_lo)
        np.maximum(z_hi, zn.max(0), out=z_hi)
        return disp

    loss, acc = rollout(batch, steps, w, predict)
    objective = (loss / torch.as_tensor(scale, dtype=loss.dtype, device=loss.device)).mean()
    return objective, {"loss": objective.item(), **{k: float(v.mean()) for k, v in acc.items()}}


@torch.no_grad()
def record_latents(setup, model, clips, count, frames, rng, deadline=None, group=8):
    """core.record_latents with `group` sequences rolled together (the same draws from `rng`); past `deadline` no
    further group is started once two sequences are recorded."""
    pool = [c for c in clips if len(c.rotations) >= 4] or clips
    length = min(frames + 3, max(len(c.rotations) for c in clips))
    prepared = _Prepared(kinematics(setup), pool, setup.asset_stub)
    net = BatchedStage1(model)
    seqs = []
    while len(seqs) < count:
        if deadline is not None and len(seqs) >= 2 and time.time() > deadline:
            break
        n = min(group, count - len(seqs))
        win = prepared([sample_pick(setup, pool, rng, length) for _ in range(n)], static=True)
        batch, graph = WindowBatch(setup, win), block_graph(setup, n)
        zs = []
        for f in range(3, length):
            node, edges, body, recv = batch.features(f)
            z, disp = net(node, edges, body, recv, graph, n)
            batch.advance(f, disp)
            zs.append(z.cpu().numpy())
        zs = np.stack(zs, 1)
        for k in range(n):
            seqs.append({"static": win["static"][k, 3:].astype(np.float64), "z": zs[k].astype(np.float64)})
    return seqs
