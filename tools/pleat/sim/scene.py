"""A garment on a body playing a clip: what pleat-sim simulates and pleat-show draws."""
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from ..physics import Material, cloth_rest
from pleat.body.model import BodyCollider
from .solver import ClothSolver, SolverSettings


def load_body(path=None):
    """The body npz at `path`, else the shipped body (assets/body.npz). A missing file is an InputError that names
    the command that builds the shipped body; there is no stand-in body."""
    from ..body import BodyModel, default_body_path
    from ..cli import InputError
    p = Path(path) if path else default_body_path()
    if not p.is_file():
        raise InputError(p, "no such body file" if path else
                         "the shipped body is missing: `pleat-body export` builds it (needs `pip install -e "
                         "'tools[body]'`, a few minutes; docs/body.md), or pass --body FILE")
    return BodyModel.load(p)


def load_garment_spec(spec, body):
    """A garment npz path, or a garment name (data/garments/NAME.npz if present, else generated now)."""
    import zipfile

    from ..cli import InputError, not_npz
    from ..garment import Garment, make_garment
    from ..garment.generate import GARMENT_NAMES
    from ..paths import GARMENTS_DIR
    path = Path(spec) if str(spec).endswith(".npz") else GARMENTS_DIR / f"{spec}.npz"
    if str(spec).endswith(".npz") or path.exists():
        try:
            return Garment.load(path)
        except FileNotFoundError:
            raise InputError(spec, "no such garment file") from None
        except (ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile) as exc:
            raise not_npz(path, exc, "a garment npz (pleat-garment writes one)") from None
    if spec not in GARMENT_NAMES:
        raise InputError(spec, f"no such garment: not an npz, not in {GARMENTS_DIR}, and not one of "
                               f"{', '.join(GARMENT_NAMES)} (pleat-garment list)")
    return make_garment(spec, body=body)


def load_motion(spec, body, fps=30.0, frames=None):
    from ..motion import identity_clip
    from ..motion.loaders import load_clip_at
    if spec is None:
        return identity_clip(frames or 1, fps=fps)
    return load_clip_at(spec, body, fps)


def skinning_matrices(body, clip, beta=None, frames=None):
    sel = slice(None) if frames is None else frames
    G = body.forward_kinematics(clip.local_matrices()[sel], clip.root_translation[sel], clip.root_matrices()[sel],
                                beta)
    return body.skinning_matrices(G, beta)


def posed_sequence(body, garment, motion, frames, beta=None):
    """(body vertices [T,V,3], garment by LBS [T,N,3]) at `frames` of `motion` (a Clip, a clip name or file, or None:
    the rest pose)."""
    from ..motion import Clip
    frames = list(frames)
    clip = motion if isinstance(motion, Clip) else load_motion(motion, body, frames=max(frames) + 1)
    M = skinning_matrices(body, clip, beta, frames)
    G = body.forward_kinematics(clip.local_matrices()[frames], clip.root_translation[frames],
                                clip.root_matrices()[frames], beta)
    A = np.einsum("vk,tkij->tvij", body.weights, M[:, :, :3, :])
    v = body.shaped_vertices(beta)
    body_v = np.einsum("tvij,vj->tvi", A[..., :3], v) + A[..., 3]
    del G
    return body_v, garment.skin(M, beta)


LEAD_IN_FRAMES = 15      # rest pose → the clip's first pose (smoothstep slerp of the joint rotations)
HOLD_FRAMES = 5          # then the first pose held, so the cloth settles before frame 0


def lead_in_clip(clip, frames=LEAD_IN_FRAMES, hold=HOLD_FRAMES):
    """The body from its rest pose (identity joint rotations, where the garment template is unstrained) to the
    clip's first pose in `frames` frames, then that pose held for `hold` frames; the root stays at frame 0's.

    Why: the garment skinned by LBS straight onto a posed first frame is far from its rest shape (the 1k t-shirt on
    humanoid3d_walk's first pose: singular values of F from 0.22 to 1.54, 470 J of stretching energy for a
    0.2 kg shirt), so the simulation would start by relaxing a crushed and overstretched mesh, which crumples it and
    keeps Newton from converging. The last frame equals the clip's frame 0."""
    from dataclasses import replace
    from ..rotations import quat_slerp
    n = int(frames) + int(hold) + 1
    s = np.clip(np.arange(n) / max(1, int(frames)), 0.0, 1.0)
    w = s * s * (3.0 - 2.0 * s)
    J = clip.local_rotations.shape[1]
    identity = np.zeros((n, J, 4))
    identity[..., 3] = 1.0
    first = np.broadcast_to(clip.local_rotations[0], (n, J, 4))
    q = quat_slerp(identity, first, np.broadcast_to(w[:, None], (n, J)))
    q[:, 0] = clip.local_rotations[0, 0]            # the pelvis's own rotation only turns body and garment rigidly
    q[-1] = clip.local_rotations[0]
    return replace(clip, name=f"lead-in to {clip.name}", local_rotations=q,
                   root_translation=np.repeat(clip.root_translation[:1], n, axis=0),
                   root_rotation=np.repeat(clip.root_rotation[:1], n, axis=0))


def simulate(garment, body, clip, beta=None, material=None, frames=None, settings=None, progress=True,
             keep_body=True, lead_in_frames=LEAD_IN_FRAMES, hold_frames=HOLD_FRAMES, start_perturbation_m=0.0):
    """Run the reference simulator over the clip. Returns (positions [T,N,3] f32, body [T,V,3] f32 or None,
    summary dict). With lead_in_frames > 0 the garment starts unstrained on the body's rest pose and is simulated
    through `lead_in_clip` first; frame 0 is where that ends (lead_in_frames=0: LBS onto frame 0, pushed out).
    start_perturbation_m > 0 moves every free vertex of the start state by that much in a random (seeded) direction:
    how far two equally valid references drift apart (`reference_spread`, docs/accuracy.md)."""
    material = material or Material()
    settings = settings or SolverSettings(dt_s=1.0 / clip.fps)
    n_frames = clip.num_frames if frames is None else min(int(frames), clip.num_frames)
    rest = cloth_rest(garment.shaped(beta), garment.faces)
    solver = ClothSolver(rest, material, pinned=garment.pinned, settings=settings)
    lead = None
    if lead_in_frames > 0:
        lead = _simulate_lead_in(garment, body, clip, beta, solver, settings, lead_in_frames, hold_frames, progress,
                                 start_perturbation_m)
    M = skinning_matrices(body, clip, beta, slice(0, n_frames))
    A = np.einsum("vk,tkij->tvij", body.weights, M[:, :, :3, :])
    shaped_body = body.shaped_vertices(beta)
    body_v = np.einsum("tvij,vj->tvi", A[..., :3], shaped_body) + A[..., 3]
    pins = garment.skin(M, beta)                                     # LBS garment: pinned targets, first frame
    collide = garment.body_collision_mask(body)
    colliders = [BodyCollider(body_v[0], body.faces, collide)]
    if lead is not None:
        x, x_prev = lead["x"], lead["x_prev"]
    else:
        x = _perturbed(_pushed_out(pins[0], colliders[0], solver, settings), solver, start_perturbation_m)
        x_prev = x.copy()
    out = np.empty((n_frames, len(x), 3), np.float32)
    out[0] = x
    per_frame = dict(substeps=[], substeps_converged=[], substeps_force_converged=[], newton_iterations=[], cg_iterations=[], gradient_ratio=[], converged=[],
                     penetration_before_projection_mm=[], penetration_after_projection_mm=[], seconds=[])
    iterator = range(1, n_frames)
    if progress:
        from tqdm import tqdm
        iterator = tqdm(iterator, desc=f"pleat-sim {garment.name}", unit="frame")
    t0 = time.perf_counter()
    c0 = time.process_time()
    for t in iterator:
        t_frame = time.perf_counter()
        colliders.append(BodyCollider(body_v[t], body.faces, collide))
        x_new, stats = solver.step(x, x_prev, pin_targets=pins[t], body_t=colliders[t - 1], body_next=colliders[t],
                                   pins_t=pins[t - 1])
        colliders[t - 1] = None
        x = x_new
        x_prev = x - settings.dt_s * stats.velocity      # the next step's x_{t−1}: carries the last substep's velocity
        out[t] = x
        per_frame["seconds"].append(round(time.perf_counter() - t_frame, 4))
        per_frame["substeps"].append(stats.substeps)
        per_frame["substeps_converged"].append(stats.substeps_converged)
        per_frame["substeps_force_converged"].append(stats.substeps_force_converged)
        per_frame["newton_iterations"].append(stats.newton_iterations)
        per_frame["cg_iterations"].append(stats.cg_iterations)
        per_frame["gradient_ratio"].append(float(stats.worst_gradient_ratio))
        per_frame["converged"].append(bool(stats.converged))
        per_frame["penetration_before_projection_mm"].append(1000.0 * stats.penetration_before_projection_m)
        per_frame["penetration_after_projection_mm"].append(1000.0 * stats.penetration_after_projection_m)
        if progress:
            iterator.set_postfix(K=stats.substeps, newton=stats.newton_iterations,
                                 pen_mm=round(1000.0 * stats.penetration_before_projection_m, 2))
    elapsed = time.perf_counter() - t0
    cpu = time.process_time() - c0
    pen_before = per_frame["penetration_before_projection_mm"]
    pen_after = per_frame["penetration_after_projection_mm"]
    summary = dict(frames=int(n_frames), garment=garment.name, vertices=int(len(x)), dt_s=settings.dt_s,
                   seconds_per_frame=elapsed / max(1, n_frames - 1),
                   cpu_seconds_per_frame=cpu / max(1, n_frames - 1),   # this process's CPU time (shared machine)
                   max_penetration_mm=max(pen_after, default=0.0),
                   max_penetration_before_projection_mm=max(pen_before, default=0.0),
                   penetration_tolerance_mm=1000.0 * settings.penetration_tol_m,
                   final_gradient_norm=float(stats.gradient_norm) if n_frames > 1 else 0.0,
                   gradient_tolerance=float(settings.force_tol * solver.weight_scale),
                   worst_gradient_ratio=max(per_frame["gradient_ratio"], default=0.0),
                   mean_substeps=float(np.mean(per_frame["substeps"])) if n_frames > 1 else 0.0,
                   mean_newton_iterations_per_substep=(float(np.sum(per_frame["newton_iterations"])
                                                             / max(1, np.sum(per_frame["substeps"])))),
                   steps_not_converged=int(sum(not c for c in per_frame["converged"])),
                   substeps_converged_fraction=(float(np.sum(per_frame["substeps_converged"])
                                                      / max(1, np.sum(per_frame["substeps"])))),
                   substeps_force_converged_fraction=(float(np.sum(per_frame["substeps_force_converged"])
                                                            / max(1, np.sum(per_frame["substeps"])))),
                   material=dict(zip(("m", "mu", "lambda", "k"), material.as_tuple())),
                   beta=[] if beta is None else [float(b) for b in np.atleast_1d(beta)],
                   settings=asdict(settings), per_frame=per_frame)
    if lead is not None:
        summary["lead_in"] = lead["summary"]
    return out, (body_v.astype(np.float32) if keep_body else None), summary


def _pushed_out(x, collider, solver, settings):
    x = x.copy()
    _, _, n, d = collider.query(x)
    low = (d < settings.collision_margin_m) & ~solver.pinned
    x[low] += (settings.collision_margin_m - d[low])[:, None] * n[low]
    return x


def start_perturbation(vertex_count, pinned, distance_m):
    """[N, 3]: every free vertex's move by distance_m along a random direction (seed 0), zero on the pinned ones
    (bool [N]): how the spread's twin reference starts, in this simulator and in Blender's (pleat_blender.teacher)."""
    d = np.random.default_rng(0).standard_normal((vertex_count, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return distance_m * d * ~np.asarray(pinned, bool)[:, None]


def _perturbed(x, solver, distance_m):
    """x with every free vertex moved by distance_m along a random direction (seed 0)."""
    if not distance_m:
        return x
    return x + start_perturbation(len(x), solver.pinned, distance_m)


def _simulate_lead_in(garment, body, clip, beta, solver, settings, frames, hold, progress, start_perturbation_m=0.0):
    lead = lead_in_clip(clip, frames, hold)
    M = skinning_matrices(body, lead, beta)
    A = np.einsum("vk,tkij->tvij", body.weights, M[:, :, :3, :])
    shaped_body = body.shaped_vertices(beta)
    body_v = np.einsum("tvij,vj->tvi", A[..., :3], shaped_body) + A[..., 3]
    pins = garment.skin(M, beta)
    collide = garment.body_collision_mask(body)
    prev = BodyCollider(body_v[0], body.faces, collide)
    x = _perturbed(_pushed_out(pins[0], prev, solver, settings), solver, start_perturbation_m)
    x_prev = x.copy()
    t0 = time.perf_counter()
    c0 = time.process_time()
    not_converged = 0
    substeps = substeps_ok = 0
    ratios = []
    for t in range(1, lead.num_frames):
        nxt = BodyCollider(body_v[t], body.faces, collide)
        x_new, stats = solver.step(x, x_prev, pin_targets=pins[t], body_t=prev, body_next=nxt, pins_t=pins[t - 1])
        x = x_new
        x_prev = x - settings.dt_s * stats.velocity
        prev = nxt
        not_converged += int(not stats.converged)
        substeps += stats.substeps
        substeps_ok += stats.substeps_converged
        ratios.append(float(stats.worst_gradient_ratio))
    summary = dict(frames=int(frames), hold_frames=int(hold), seconds=time.perf_counter() - t0,
                   cpu_seconds=time.process_time() - c0,
                   steps_not_converged=not_converged, substeps=substeps, substeps_converged=substeps_ok,
                   worst_gradient_ratio=max(ratios, default=0.0))
    return dict(x=x, x_prev=x_prev, summary=summary)
