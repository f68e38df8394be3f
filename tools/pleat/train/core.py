"""The two training stages, the ablation and packing (paper sections 3.2, 3.3, 4.1, 4.3).

Stage 1 trains Φ (Encode–Process–Convolve–Decode + blend shapes) on the physics losses of equation 4 with no ground
truth: each iteration samples a clip window, β ~ U(−β_max, β_max) and a material in the paper's ranges, starts the
garment from the LBS of the shaped template on the first three frames, and rolls Φ autoregressively for 1 → 5 steps
(one more every `rollout_every` of the run), back-propagating through the whole rollout.
Stage 2 freezes Φ, records its latents on rollouts, and fits f_LP on X_c (built by the same function the runtime
reference uses) with MSE, feeding f_LP its own previous predictions inside a window (Z_0 = 0 at sequence starts).
The ablation trains f_LP → f_dec → D directly on the stage-1 losses.
"""
import json
import math
import os
import platform
import time
from pathlib import Path

import numpy as np
import torch
from scipy.spatial import cKDTree
from tqdm import tqdm

from pleat import REPO_ROOT
from pleat import garment_asset as ga
from pleat import reference
from pleat import rotations as rot
from pleat.train import graph as graph_mod
from pleat.train import sources
from pleat.train.model import InferenceBlock, Phi, mlp_to_weights, skin

LOSS_TERMS = ("bending", "stretching", "inertia", "gravity", "friction", "collision")


# ---- configuration -----------------------------------------------------------------------------------------------
def load_config(preset=None, path=None, overrides=None):
    src = Path(path) if path else REPO_ROOT / "configs" / f"{preset}.json"
    cfg = json.loads(src.read_text())
    for key, value in (overrides or {}).items():
        node = cfg
        parts = key.split(".")
        for p in parts[:-1]:
            node = node[p]
        node[parts[-1]] = value
    return cfg


def lerp(a, b, s):
    return a + (b - a) * min(max(s, 0.0), 1.0)


def run_fraction(cfg1, it, elapsed_s=None, budget_s=None):
    """How far through the run iteration `it` is, in [0, 1]: by iteration count, or by wall clock when a time
    budget (--max-minutes) would end the run first, so that a budget-stopped run still goes through the whole
    rollout and collision-weight schedule."""
    s = it / max(cfg1["iterations"] - 1, 1)
    if budget_s and elapsed_s is not None:
        s = max(s, elapsed_s / budget_s)
    return min(max(s, 0.0), 1.0)


def loss_weights(cfg1, it, s=None):
    s = run_fraction(cfg1, it) if s is None else s
    c0, c1 = cfg1["collision_ramp"]
    w_c = cfg1["w_collision"][0] + (cfg1["w_collision"][1] - cfg1["w_collision"][0]) * \
        min(max((s - c0) / max(c1 - c0, 1e-9), 0.0), 1.0)
    return {"bending": cfg1["w_bending"], "stretching": cfg1["w_stretching"],
            "inertia": lerp(*cfg1["w_inertia"], s), "gravity": lerp(*cfg1["w_gravity"], s),
            "friction": cfg1["w_friction"], "collision": w_c}


def rollout_steps(cfg1, it, s=None):
    """1 step at first, one more every `rollout_every` of the run (the paper: every 5,000 of 120,000), at most
    `rollout_max`."""
    s = run_fraction(cfg1, it) if s is None else s
    return int(min(cfg1["rollout_max"], 1 + math.floor(s / cfg1["rollout_every"] + 1e-9)))


def make_optimizer(model, lr, blend_lr_scale=1.0):
    """Adam; the blend shapes D (per-vertex parameters) at `blend_lr_scale` × lr. Adam moves every parameter by
    about lr per step whatever its gradient's size, so on a 4.4k-vertex garment an lr that suits the networks
    moves each vertex of each of the D shapes independently by that much: at 5·10⁻⁴ m per step the shirt's 1.5 cm
    edges were torn apart within ten iterations (stretching 10³ → 10⁷ J)."""
    blend = [p for n, p in model.named_parameters() if n.endswith("blend_shapes")]
    rest = [p for n, p in model.named_parameters() if not n.endswith("blend_shapes")]
    return torch.optim.Adam([{"params": rest, "lr": lr}, {"params": blend, "lr": lr * blend_lr_scale}])


def set_threads(threads=None):
    """Torch intra-op threads; default 1. The graphs here are small (hundreds to a few thousand vertices, widths
    32-64), so extra threads mostly synchronise: on the shared 2-core machine (load ≈ 5) one tiny stage-1
    iteration took 0.48 s with 1 thread and 1.98 s with 2 (docs/training.md). Give more with --threads on an
    idle many-core machine."""
    torch.set_num_threads(max(1, int(threads or 1)))


class Budget:
    """Wall-clock budget of one stage (--max-minutes), counted across resumes."""

    def __init__(self, minutes, elapsed_s=0.0):
        self.budget_s = None if not minutes else 60.0 * float(minutes)
        self.t0 = time.time() - float(elapsed_s or 0.0)

    def elapsed(self):
        return time.time() - self.t0

    def spent(self):
        return self.budget_s is not None and self.elapsed() >= self.budget_s


# ---- distributed ---------------------------------------------------------------------------------------------------
def dist_info():
    world = int(os.environ.get("WORLD_SIZE", "1"))
    rank = int(os.environ.get("RANK", "0"))
    if world > 1 and not torch.distributed.is_initialized():
        backend = "nccl" if torch.cuda.is_available() else "gloo"
        torch.distributed.init_process_group(backend)
        if torch.cuda.is_available():
            torch.cuda.set_device(int(os.environ.get("LOCAL_RANK", "0")))
    return rank, world


def wrap_ddp(module, world, device):
    if world > 1:
        return torch.nn.parallel.DistributedDataParallel(
            module, device_ids=[device.index] if device.type == "cuda" else None)
    return module


def unwrap(module):
    return module.module if hasattr(module, "module") else module


# ---- static garment/body setup -----------------------------------------------------------------------------------
class Setup:
    """Everything that depends only on the garment and the body."""

    def __init__(self, cfg, garment_spec, device="cpu"):
        self.cfg, self.device = cfg, torch.device(device)
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
        radius = float(m.get("body_subset_m") or 0.0)
        near = cKDTree(self.template).query(body_v)[0] < radius if radius > 0 else np.ones(vc, bool)
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
        self.energies = sources.energies(self.template, self.faces, torch)
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
    fn = torch.cross(x[faces[:, 1]] - x[faces[:, 0]], x[faces[:, 2]] - x[faces[:, 0]], dim=-1)
    n = torch.zeros_like(x)
    for c in range(3):
        n = n.index_add(0, faces[:, c], fn)
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


def weighted(terms, w):
    return sum(w[k] * terms[k] for k in LOSS_TERMS)


def physics_clips(cfg, body):
    """Training clips for the physics-loss stages (stage 1, ablation): the training split without the clips named
    in `stage1.exclude_clips` (substrings of the clip name). Clips whose LBS is shredded (cartwheel, crawl, roll,
    getup, backflip, spins) carry 10⁴–10⁵ J of LBS stretching per window, against 10²–10³ J for walks, and
    dominated the first default run's loss."""
    clips = sources.clips("train", cfg["fps"], cfg["clips"]["train_limit"] or None,
                          cfg["clips"]["frames_limit"] or None, body)
    drop = list(cfg["stage1"].get("exclude_clips") or [])
    kept = [c for c in clips if not any(d in c.name for d in drop)]
    return kept or clips


# nonnegative terms: the gravity term is work relative to the previous state and may be negative
_SCALE_TERMS = ("bending", "stretching", "inertia", "friction", "collision")


@torch.no_grad()
def lbs_scale(setup, win, beta, mat, mat01, steps, w, floor):
    """The LBS-only loss of the same window (the garment following LBS of the shaped template, zero network),
    from its nonnegative terms, at least `floor`: dividing a window's loss by it makes every window's loss read
    as 'relative to LBS', so one extreme window (10⁵ J of LBS stretching) cannot dominate an iteration."""
    window = Window(setup, win, beta, mat, mat01)
    zero = torch.zeros(setup.N, 3, device=setup.device)
    _, terms = rollout_loss(setup, None, window, steps, w, lambda f: zero)
    return max(sum(w[k] * terms[k] for k in _SCALE_TERMS), float(floor)), terms


# ---- bookkeeping -------------------------------------------------------------------------------------------------
class Run:
    def __init__(self, out, stage, cfg, rank):
        self.out, self.stage, self.rank = Path(out), stage, rank
        self.t0 = time.time()
        if rank == 0:
            self.out.mkdir(parents=True, exist_ok=True)
            (self.out / f"config_{stage}.json").write_text(json.dumps(
                {"config": cfg, "sources": sources.used, "hardware": hardware()}, indent=2, default=str))
            self.metrics = open(self.out / f"metrics_{stage}.jsonl", "a")

    def log(self, record):
        if self.rank == 0:
            record = {"stage": self.stage, "time_s": round(time.time() - self.t0, 3), **record}
            self.metrics.write(json.dumps(record) + "\n")
            self.metrics.flush()

    def checkpoint(self, state):
        if self.rank == 0:
            tmp = self.out / f"{self.stage}.pt.tmp"
            torch.save(state, tmp)
            os.replace(tmp, self.out / f"{self.stage}.pt")

    def resume(self):
        p = self.out / f"{self.stage}.pt"
        return torch.load(p, weights_only=False) if p.exists() else None


def hardware():
    info = {"machine": platform.machine(), "processor": platform.processor() or platform.machine(),
            "cpu_count": os.cpu_count(), "torch": torch.__version__, "threads": torch.get_num_threads()}
    if torch.cuda.is_available():
        info["gpu"] = torch.cuda.get_device_name(0)
    return info


def _rng_state():
    return {"torch": torch.get_rng_state()}


def device_for(name, rank):
    if name == "auto":
        name = "cuda" if torch.cuda.is_available() else "cpu"
    if name == "cuda":
        return torch.device("cuda", int(os.environ.get("LOCAL_RANK", rank)))
    return torch.device("cpu")


# ---- stage 1 -----------------------------------------------------------------------------------------------------
def train_stage1(cfg, garment, out, resume=False, device="auto", progress=True, max_minutes=None):
    rank, world = dist_info()
    dev = device_for(device, rank)
    torch.manual_seed(cfg["seed"])
    setup = Setup(cfg, garment, dev)
    clips = physics_clips(cfg, setup.body)
    model = Stage1Model(setup).to(dev)
    c1 = cfg["stage1"]
    opt = make_optimizer(model, c1["lr"], c1.get("blend_lr_scale", 1.0))
    run = Run(out, "stage1", cfg, rank)
    start, elapsed = 0, 0.0
    if resume and (state := run.resume()) is not None:
        model.load_state_dict(state["model"])
        opt.load_state_dict(state["optimizer"])
        start, elapsed = state["iteration"], state.get("elapsed_s", 0.0)
    if start == 0:
        run.log({"iteration": 0, "validation": validate_stage1(setup, model, cfg)})
    budget = Budget(max_minutes, elapsed)
    rng = np.random.default_rng([cfg["seed"], rank, start])
    batched = batched_path(c1)
    if batched:     # K windows per iteration through one graph (batching.py; the same losses, tested)
        from pleat.train import batching
        net = batching.BatchedStage1(model)
        ddp = wrap_ddp(batching.compiled(net) if c1.get("compile") else net, world, dev)
        source = batching.WindowSource(setup, clips, rng, c1.get("windows_per_iteration", 1),
                                       worker=bool(c1.get("data_worker", False)))
    else:
        ddp = wrap_ddp(model, world, dev)
    bar = tqdm(range(start, c1["iterations"]), disable=not progress or rank != 0, desc="stage1")
    it = start - 1
    for it in bar:
        s = run_fraction(c1, it, budget.elapsed(), budget.budget_s)
        steps = rollout_steps(c1, it, s)
        w = loss_weights(c1, it, s)
        if batched:
            s_next = run_fraction(c1, it + 1, budget.elapsed(), budget.budget_s)
            objective, rec = batching.stage1_iteration(setup, ddp, source, c1, steps, w,
                                                       rollout_steps(c1, it + 1, s_next))
            opt.zero_grad()
            objective.backward()
        else:
            win, beta, mat, mat01 = sample_window(setup, clips, rng, steps + 3)
            scale = 1.0
            if c1.get("loss_norm") == "lbs":
                scale, _ = lbs_scale(setup, win, beta, mat, mat01, steps, w, c1.get("loss_norm_floor", 1.0))
            loss, terms = rollout_loss(setup, ddp, Window(setup, win, beta, mat, mat01), steps, w)
            opt.zero_grad()
            (loss / scale).backward()
            rec = {"loss": loss.item(), "lbs_scale": scale, "ratio": loss.item() / scale, **terms}
        gn = torch.nn.utils.clip_grad_norm_(model.parameters(), c1["grad_clip"])
        opt.step()
        rec = {"iteration": it + 1, **rec, "steps": steps, "grad_norm": float(gn), "fraction": s,
               **{f"w_{k}": v for k, v in w.items()}}
        run.log(rec)
        bar.set_postfix(loss=f"{rec['loss']:.4g}", ratio=f"{rec['ratio']:.3g}", steps=steps)
        stop = stop_everywhere(world, budget.spent(), dev)
        if (it + 1) % c1["checkpoint_every"] == 0 or it + 1 == c1["iterations"] or stop:
            run.checkpoint({"model": model.state_dict(), "optimizer": opt.state_dict(), "iteration": it + 1,
                            "config": cfg, "garment": garment, "rng": _rng_state(), "elapsed_s": budget.elapsed()})
        every = c1.get("validation_every") or 0
        if every and (it + 1) % every == 0 and not stop and it + 1 != c1["iterations"]:
            run.log({"iteration": it + 1, "validation": validate_stage1(setup, model, cfg)})
        if stop:
            run.log({"iteration": it + 1, "stopped": "time budget", "max_minutes": max_minutes,
                     "elapsed_s": budget.elapsed()})
            break
    if batched:
        source.close()
    val = validate_stage1(setup, model, cfg)
    run.log({"iteration": it + 1, "validation": val})
    return model, setup, val


def batched_path(c1):
    """Whether the physics-loss stages run the batched path (batching.py; default) or the per-window one
    (`--set stage1.batched=false`, kept for the A/B comparison in bench/train_throughput.py)."""
    return bool(c1.get("batched", True))


def stop_everywhere(world, stop, device):
    """Under DDP every rank must stop at the same iteration: rank 0's clock decides."""
    if world <= 1:
        return stop
    flag = torch.tensor([1.0 if stop else 0.0], device=device)
    torch.distributed.broadcast(flag, 0)
    return bool(flag.item())


def rollout_loss(setup, model, window, steps, w, predictor=None):
    setup.energies.collision_weight = w["collision"]
    total, acc = 0.0, {k: 0.0 for k in LOSS_TERMS}
    for i in range(steps):
        f = 3 + i
        if predictor is None:
            node, edges, body, recv = window.features(f)
            _, disp = model(node, edges, body, recv, setup.levels)
        else:
            disp = predictor(f)
        window.advance(f, disp)
        terms = window.losses(f)
        total = total + weighted(terms, w)
        for k in LOSS_TERMS:
            acc[k] += float(terms[k].detach()) / steps
    return total / steps, acc


@torch.no_grad()
def validate_stage1(setup, model, cfg):
    clips = sources.clips("validation", cfg["fps"], cfg["clips"]["validation_limit"] or None,
                          cfg["clips"]["frames_limit"] or None, setup.body)
    rng = np.random.default_rng(12345)
    c1 = cfg["stage1"]
    w = loss_weights(c1, c1["iterations"] - 1)
    losses, ratios, terms, lbs_terms = [], [], {k: [] for k in LOSS_TERMS}, {k: [] for k in LOSS_TERMS}
    if batched_path(c1):
        from pleat.train import batching
        losses, ratios, terms, lbs_terms = batching.validate_stage1(setup, model, clips, rng, w, c1)
    for _ in range(0 if batched_path(c1) else c1["validation_windows"]):
        win, beta, mat, mat01 = sample_window(setup, clips, rng, c1["rollout_max"] + 3)
        scale, tl = lbs_scale(setup, win, beta, mat, mat01, c1["rollout_max"], w, c1.get("loss_norm_floor", 1.0))
        loss, t = rollout_loss(setup, model, Window(setup, win, beta, mat, mat01), c1["rollout_max"], w)
        losses.append(float(loss))
        ratios.append(float(loss) / scale)
        for k in LOSS_TERMS:
            terms[k].append(t[k])
            lbs_terms[k].append(tl[k])
    # mean and median: a few extreme windows (LBS of a cartwheel) dominate the mean; `ratio` is each window's loss
    # over the LBS-only loss of the same window (< 1: better than LBS by the physics of equation 4)
    return {"loss": float(np.mean(losses)), "loss_median": float(np.median(losses)), "windows": len(losses),
            "ratio_mean": float(np.mean(ratios)), "ratio_median": float(np.median(ratios)),
            **{k: float(np.mean(v)) for k, v in terms.items()},
            **{f"lbs_{k}": float(np.mean(v)) for k, v in lbs_terms.items()}}


def load_stage1(out, device="cpu"):
    state = torch.load(Path(out) / "stage1.pt", weights_only=False)
    cfg = state["config"]
    setup = Setup(cfg, state["garment"], device)
    model = Stage1Model(setup).to(device)
    model.load_state_dict(state["model"])
    model.eval()
    return model, setup, cfg, state


# ---- stage 2 -----------------------------------------------------------------------------------------------------
def padded_sequences(seqs, dev="cpu"):
    """Recorded sequences padded into tensors, so a batch is gathered with two index tensors, not a Python loop:
    lengths [S], static [S, T, ·] (X_c without its latent block), target [S, T+1, L] with target[:, 0] = Z_0 = 0 and
    target[:, j+1] = Z_j."""
    lengths = torch.as_tensor([len(q["z"]) for q in seqs], device=dev)
    T, L = int(lengths.max()), seqs[0]["z"].shape[1]
    static = torch.zeros(len(seqs), T, seqs[0]["static"].shape[1], device=dev)
    target = torch.zeros(len(seqs), T + 1, L, device=dev)
    for i, q in enumerate(seqs):
        static[i, :len(q["z"])] = to_t(q["static"], dev)
        target[i, 1:len(q["z"]) + 1] = to_t(q["z"], dev)
    return lengths, static, target


def window_loss(predictor, z_mean, z_std, lengths, static, target, batch, window, gen, dev="cpu", weights=None):
    """Stage 2's loss on one batch of windows: each starts at a recorded Z_{j-1} (zero at a sequence start) and is
    fed the predictor's own (clamped) predictions; MSE on the normalised latent, averaged over the window.
    weights [L] (mean 1), if given, weigh the latent components (e.g. by how much displacement each one carries)."""
    idx = torch.randint(len(lengths), (batch,), generator=gen).to(dev)
    n = lengths[idx]
    starts = (torch.rand(batch, generator=gen).to(dev) * (n - window).clamp_min(0).add(1)).long()
    z_prev = target[idx, starts]
    loss = 0.0
    for k in range(window):
        j = torch.minimum(starts + k, n - 1)
        y, z_prev = predictor(z_prev, static[idx, j])
        sq = (y - (target[idx, j + 1] - z_mean) / z_std) ** 2
        loss = loss + (sq.mean() if weights is None else (sq * weights).mean())
    return loss / window


@torch.no_grad()
def record_latents(setup, model, clips, count, frames, rng, deadline=None):
    """Frozen-Φ rollouts: per sequence the X_c rows (latent block zero) and Φ's latent for each predicted frame.
    Past `deadline` (time.time()) no further sequence is started once two are recorded."""
    if batched_path(setup.cfg["stage1"]):      # several sequences rolled together (batching.py)
        from pleat.train import batching
        return batching.record_latents(setup, model, clips, count, frames, rng, deadline,
                                       int(setup.cfg.get("stage2", {}).get("record_group", 8)))
    seqs = []
    for _ in range(count):
        if deadline is not None and len(seqs) >= 2 and time.time() > deadline:
            break
        # clips shorter than the sequence are skipped (sample_window), unless every clip is
        length = min(frames + 3, max(len(c.rotations) for c in clips))
        win, beta, mat, mat01 = sample_window(setup, [c for c in clips if len(c.rotations) >= 4] or clips, rng,
                                              length)
        window = Window(setup, win, beta, mat, mat01)
        zs = []
        for f in range(3, len(win["dt"])):
            node, edges, body, recv = window.features(f)
            z, disp = model(node, edges, body, recv, setup.levels)
            window.advance(f, disp)
            zs.append(z.cpu().numpy())
        static = setup.static_inputs(win, beta, mat)[3:]  # row i ↔ frame i + 3
        seqs.append({"static": static.astype(np.float64), "z": np.array(zs, np.float64)})
    return seqs


def normalisation(setup, seqs):
    L = setup.L
    z = np.concatenate([s["z"] for s in seqs])
    z_mean, z_std = z.mean(0), z.std(0)
    z_std = np.where(z_std > 1e-6, z_std, 1.0)
    x = np.concatenate([s["static"] for s in seqs])
    prev = np.concatenate([np.concatenate([np.zeros((1, L)), s["z"][:-1]]) for s in seqs])
    x[:, :L] = prev
    x_mean, x_std = x.mean(0), x.std(0)
    x_std = np.where(x_std > 1e-6, x_std, 1.0)
    # material: already mapped to [0, 1] by X_c assembly; the paper keeps it there (no mean/std)
    x_mean[-4:], x_std[-4:] = 0.0, 1.0
    return {"x_mean": x_mean, "x_std": x_std, "z_mean": z_mean, "z_std": z_std,
            "z_min": z.min(0), "z_max": z.max(0)}


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


def train_stage2(cfg, out, resume=False, device="auto", progress=True, max_minutes=None):
    rank, world = dist_info()
    dev = device_for(device, rank)
    stage2_cfg = cfg["stage2"]
    phi, setup, cfg, _ = load_stage1(out, dev)
    cfg = dict(cfg, stage2=stage2_cfg)      # Φ's config from its checkpoint, stage 2's from this run (--set works)
    c2 = cfg["stage2"]
    run = Run(out, "stage2", cfg, rank)
    rng = np.random.default_rng([cfg["seed"], 2, rank])
    data_path = Path(out) / "stage2_latents.npz"
    train_clips = sources.clips("train", cfg["fps"], cfg["clips"]["train_limit"] or None,
                                cfg["clips"]["frames_limit"] or None, setup.body)
    val_clips = sources.clips("validation", cfg["fps"], cfg["clips"]["validation_limit"] or None,
                              cfg["clips"]["frames_limit"] or None, setup.body)
    t_rec = time.time()
    if resume and data_path.exists():
        with np.load(data_path, allow_pickle=True) as d:
            seqs, val = list(d["train"]), list(d["validation"])
    else:
        # recording rolls Φ (the slow network) frame by frame: with a time budget it gets at most
        # `record_budget_share` of it, so that f_LP still trains
        share = c2.get("record_budget_share", 0.5)
        deadline = None if not max_minutes else t_rec + 60.0 * max_minutes * share
        seqs = record_latents(setup, phi, train_clips, c2["sequences"], c2["sequence_frames"], rng,
                              None if deadline is None else deadline - 0.2 * 60.0 * max_minutes * share)
        val = record_latents(setup, phi, val_clips, max(1, len(seqs) // 4), c2["sequence_frames"], rng, deadline)
        if rank == 0:
            np.savez(data_path, train=np.array(seqs, dtype=object), validation=np.array(val, dtype=object))
    run.log({"iteration": 0, "recorded_sequences": len(seqs), "recorded_frames": sum(len(q["z"]) for q in seqs),
             "record_time_s": time.time() - t_rec})
    norms = normalisation(setup, seqs)
    model = LatentPredictor(setup, norms).to(dev)
    opt = torch.optim.Adam(model.parameters(), lr=c2["lr"])
    start, elapsed = 0, time.time() - t_rec
    if resume and (state := run.resume()) is not None:
        model.load_state_dict(state["model"])
        opt.load_state_dict(state["optimizer"])
        start, elapsed = state["iteration"], state.get("elapsed_s", elapsed)
    budget = Budget(max_minutes, elapsed)
    ddp = wrap_ddp(model, world, dev)
    lengths, static, target = padded_sequences(seqs, dev)
    W = c2["window"]
    gen = torch.Generator(device="cpu").manual_seed(int(cfg["seed"]) * 1000 + 2 + rank)
    bar = tqdm(range(start, c2["iterations"]), disable=not progress or rank != 0, desc="stage2")
    it = start - 1
    for it in bar:
        loss = window_loss(ddp, model.z_mean, model.z_std, lengths, static, target, c2["batch"], W, gen, dev)
        opt.zero_grad()
        loss.backward()
        opt.step()
        run.log({"iteration": it + 1, "loss": loss.item()})
        bar.set_postfix(loss=f"{loss.item():.4g}")
        stop = stop_everywhere(world, budget.spent(), dev)
        if (it + 1) % c2["checkpoint_every"] == 0 or it + 1 == c2["iterations"] or stop:
            run.checkpoint({"model": model.state_dict(), "optimizer": opt.state_dict(), "iteration": it + 1,
                            "norms": norms, "config": cfg, "elapsed_s": budget.elapsed()})
        if stop:
            run.log({"iteration": it + 1, "stopped": "time budget", "max_minutes": max_minutes,
                     "elapsed_s": budget.elapsed()})
            break
    val_metrics = validate_stage2(model, val, dev)
    run.log({"iteration": it + 1, "validation": val_metrics})
    return model, val_metrics


@torch.no_grad()
def validate_stage2(model, seqs, dev):
    """Free-running rollouts from Z_0 = 0 on held-out clips: MSE of the normalised latent, and the same for the
    constant predictor z_mean (what 'no information' scores) as a yardstick."""
    err, base = [], []
    for s in seqs:
        z = torch.zeros(model.z_mean.shape, device=dev)
        gt = to_t(s["z"], dev)
        for k, row in enumerate(to_t(s["static"], dev)):
            y, z = model(z, row)
            g = (gt[k] - model.z_mean) / model.z_std
            err.append(float(((y - g) ** 2).mean()))
            base.append(float((g ** 2).mean()))
    return {"mse_normalised": float(np.mean(err)), "mse_constant_mean": float(np.mean(base)), "frames": len(err)}


# ---- ablation (paper 4.3) ------------------------------------------------------------------------------------------
def pose_statistics(setup, clips, rng, samples=8):
    rows = []
    for _ in range(samples):
        clip = clips[rng.integers(len(clips))]
        beta = setup.sample_beta(rng)
        mat, _ = setup.sample_material(rng)
        win = setup.pose_window(clip, 0, len(clip.rotations), beta)
        rows.append(setup.static_inputs(win, beta, mat)[2:])
    x = np.concatenate(rows)
    mean, std = x.mean(0), x.std(0)
    std = np.where(std > 1e-6, std, 1.0)
    mean[:setup.L], std[:setup.L] = 0.0, 1.0
    mean[-4:], std[-4:] = 0.0, 1.0
    L = setup.L
    return {"x_mean": mean, "x_std": std, "z_mean": np.zeros(L), "z_std": np.ones(L),
            "z_min": np.full(L, -1e3), "z_max": np.full(L, 1e3)}


class AblationModel(torch.nn.Module):
    def __init__(self, setup, norms):
        super().__init__()
        self.lp = LatentPredictor(setup, norms)
        self.block = InferenceBlock(setup.cfg["model"], setup.N, free_mask=setup.free_mask)

    def forward(self, z_prev, row):
        _, z = self.lp(z_prev, row)
        return z, self.block.displacement(z)


def train_ablation(cfg, garment, out, resume=False, device="auto", progress=True, max_minutes=None):
    rank, world = dist_info()
    dev = device_for(device, rank)
    torch.manual_seed(cfg["seed"])
    setup = Setup(cfg, garment, dev)
    clips = physics_clips(cfg, setup.body)
    rng = np.random.default_rng([cfg["seed"], 3, rank])
    norms = pose_statistics(setup, clips, rng)
    model = AblationModel(setup, norms).to(dev)
    ca, c1 = cfg["ablation"], cfg["stage1"]
    opt = make_optimizer(model, ca["lr"], c1.get("blend_lr_scale", 1.0))
    run = Run(out, "ablation", cfg, rank)
    start, elapsed = 0, 0.0
    if resume and (state := run.resume()) is not None:
        model.load_state_dict(state["model"])
        opt.load_state_dict(state["optimizer"])
        start, elapsed = state["iteration"], state.get("elapsed_s", 0.0)
    budget = Budget(max_minutes, elapsed)
    ddp = wrap_ddp(model, world, dev)
    z_lo = np.full(setup.L, np.inf)
    z_hi = np.full(setup.L, -np.inf)
    sched = dict(c1, iterations=ca["iterations"])
    batched = batched_path(c1)
    if batched:     # the batch's windows through the model together (batching.py; the same losses, tested)
        from pleat.train import batching
        source = batching.WindowSource(setup, clips, rng, ca["batch"], static=True,
                                       worker=bool(c1.get("data_worker", False)))
    bar = tqdm(range(start, ca["iterations"]), disable=not progress or rank != 0, desc="ablation")
    for it in bar:
        s = run_fraction(sched, it, budget.elapsed(), budget.budget_s)
        steps = rollout_steps(sched, it, s)
        w = loss_weights(sched, it, s)
        loss = 0.0
        acc = {k: 0.0 for k in LOSS_TERMS}
        if batched:
            s_next = run_fraction(sched, it + 1, budget.elapsed(), budget.budget_s)
            loss, acc = batching.ablation_iteration(setup, ddp, source, c1, steps, w, z_lo, z_hi,
                                                    rollout_steps(sched, it + 1, s_next))
            acc.pop("loss")
        for _ in range(0 if batched else ca["batch"]):
            win, beta, mat, mat01 = sample_window(setup, clips, rng, steps + 3)
            window = Window(setup, win, beta, mat, mat01)
            static = to_t(setup.static_inputs(win, beta, mat), dev)
            zbox = [torch.zeros(setup.L, device=dev)]

            def predictor(f, static=static, zbox=zbox):
                z, disp = ddp(zbox[0], static[f])
                zbox[0] = z
                with torch.no_grad():
                    zn = z.detach().cpu().numpy()
                    np.minimum(z_lo, zn, out=z_lo)
                    np.maximum(z_hi, zn, out=z_hi)
                return disp

            scale = 1.0
            if c1.get("loss_norm") == "lbs":
                scale, _ = lbs_scale(setup, win, beta, mat, mat01, steps, w, c1.get("loss_norm_floor", 1.0))
            l, terms = rollout_loss(setup, None, window, steps, w, predictor)
            loss = loss + l / scale / ca["batch"]
            for k in LOSS_TERMS:
                acc[k] += terms[k] / ca["batch"]
        opt.zero_grad()
        loss.backward()
        torch.nn.utils.clip_grad_norm_(model.parameters(), c1["grad_clip"])
        opt.step()
        run.log({"iteration": it + 1, "loss": loss.item(), "steps": steps, "fraction": s, **acc})
        bar.set_postfix(loss=f"{loss.item():.4g}")
        stop = stop_everywhere(world, budget.spent(), dev)
        if (it + 1) % ca["checkpoint_every"] == 0 or it + 1 == ca["iterations"] or stop:
            run.checkpoint({"model": model.state_dict(), "optimizer": opt.state_dict(), "iteration": it + 1,
                            "config": cfg, "garment": garment, "z_min": z_lo, "z_max": z_hi,
                            "elapsed_s": budget.elapsed()})
        if stop:
            run.log({"iteration": it + 1, "stopped": "time budget", "max_minutes": max_minutes,
                     "elapsed_s": budget.elapsed()})
            break
    if batched:
        source.close()
    return model, setup


# ---- packing -------------------------------------------------------------------------------------------------------
def network_weights(setup, lp_seq, block, norms, fps):
    act = setup.cfg["model"]["activation"]
    net = {k: np.asarray(v, np.float32) for k, v in norms.items()}
    net.update(mlp_to_weights(lp_seq, "lp"))
    net.update(mlp_to_weights(block.decoder, "dec"))
    net["blend_shapes"] = block.exported_blend_shapes().cpu().numpy().astype(np.float32)
    net["lp_activation"] = act
    net["dec_activation"] = act
    net["train_fps"] = np.float32(fps)
    return net


def final_losses(out, stage):
    p = Path(out) / f"metrics_{stage}.jsonl"
    if not p.exists():
        return None
    recs = [json.loads(line) for line in p.read_text().splitlines() if line.strip()]
    train = [r for r in recs if "loss" in r]
    val = [r["validation"] for r in recs if "validation" in r]
    tail = train[-10:]
    return {"first_loss": train[0]["loss"] if train else None,
            "final_loss_mean_last10": float(np.mean([r["loss"] for r in tail])) if tail else None,
            "iterations": train[-1]["iteration"] if train else 0,
            "wall_time_s": train[-1]["time_s"] if train else None,
            "validation": val[-1] if val else None,
            "stopped_by_time_budget": any("stopped" in r for r in recs)}


def pack(out, model_kind="two-stage", path=None, fp16=False, onnx=False):
    from pleat.asset import write_asset
    out = Path(out)
    if model_kind == "two-stage":
        s1 = torch.load(out / "stage1.pt", weights_only=False)
        s2 = torch.load(out / "stage2.pt", weights_only=False)
        cfg = s1["config"]
        setup = Setup(cfg, s1["garment"], "cpu")
        stage1 = Stage1Model(setup)
        stage1.load_state_dict(s1["model"])
        lp = LatentPredictor(setup, s2["norms"])
        lp.load_state_dict(s2["model"])
        net = network_weights(setup, lp.lp, stage1.block, s2["norms"], cfg["fps"])
        stages = ("stage1", "stage2")
    else:
        sa = torch.load(out / "ablation.pt", weights_only=False)
        cfg = sa["config"]
        setup = Setup(cfg, sa["garment"], "cpu")
        norms = pose_statistics(setup, physics_clips(cfg, setup.body), np.random.default_rng([cfg["seed"], 3, 0]))
        model = AblationModel(setup, norms)
        model.load_state_dict(sa["model"])
        norms = {k: getattr(model.lp, k).numpy() for k in ("x_mean", "x_std", "z_mean", "z_std")}
        norms["z_min"], norms["z_max"] = sa["z_min"], sa["z_max"]
        net = network_weights(setup, model.lp.lp, model.block, norms, cfg["fps"])
        stages = ("ablation",)
    meta = {"model": f"pleat {model_kind} (paper sections 3.2-3.3)" if model_kind == "two-stage"
            else "ablation: inference block trained alone on the physics losses (paper 4.3)",
            "training": {"preset": cfg["preset"], "config": cfg, "sources": sources.used,
                         "hardware": hardware(), "losses": {s: final_losses(out, s) for s in stages}}}
    meta["training"]["wall_time_s"] = sum((meta["training"]["losses"][s] or {}).get("wall_time_s") or 0.0
                                          for s in stages)
    weights = ga.weights_from_garment(setup.garment, setup.body, net, metadata=meta, name=setup.name)
    target = Path(path) if path else out / f"{setup.name}{'' if model_kind == 'two-stage' else '_ablation'}.pleat"
    write_asset(str(target), weights, fp16=fp16, onnx=onnx)
    np.savez(out / f"{target.stem}_weights.npz", **{k: np.asarray(v) for k, v in weights.items()})
    return target, weights


# ---- the inference block in torch (the proof that training, reference and runtime agree) --------------------------
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
