"""What every evaluation needs: an asset and its LBS-only twin, the garment and body the simulator sees, a clip at
30 fps, and rollouts of the C runtime (through `pleat.runtime`, never torch) with per-step timings.

The asset holds everything the runtime needs but not the body mesh; the body comes from assets/body.npz (the one the
asset was built on). `skeleton_mismatch_mm` says how far the asset's skeleton is from that body's, so a report can
refuse to compare a garment against a body it was not made for.
"""
import ctypes as C
import time
from dataclasses import dataclass, field

import numpy as np

from pleat.asset import read_asset, write_asset
from pleat.garment_asset import input_count_without_latent, lbs_only_network

EVAL_FPS = 30.0
NETWORK_KEYS = ("x_mean", "x_std", "z_mean", "z_std", "z_min", "z_max", "blend_shapes", "blend_shapes_int8",
                "blend_shape_scales", "lp_activation", "dec_activation", "int8_ranged_inputs")


def read_weights(source):
    """An asset (path, bytes, or "tier:NAME" for a random-weight asset at a tier's sizes, pleat.eval.tiers) →
    (bytes, weights dict as stored)."""
    if isinstance(source, str) and source.startswith("tier:"):
        from pleat.eval.tiers import random_tier_weights
        source = write_asset(None, random_tier_weights(source[5:]))
    data = source if isinstance(source, (bytes, bytearray)) else open(source, "rb").read()
    return bytes(data), read_asset(data)


def lbs_only_weights(weights, body_contact=False):
    """The same garment, skeleton and ranges with the zero network: the LBS-only baseline, run through the same
    runtime path as the trained model. Plain skinning unless body_contact (then the asset's body anchors stay)."""
    from pleat.asset import BODY_CONTACT_CANDIDATES_KEY, BODY_CONTACT_RING_KEY, BODY_CONTACT_KEYS
    w = {k: v for k, v in weights.items()
         if k not in NETWORK_KEYS and not k.startswith(("lp.", "dec.", "onnx_"))
         and (body_contact or k not in BODY_CONTACT_KEYS + (BODY_CONTACT_CANDIDATES_KEY, BODY_CONTACT_RING_KEY))}
    N = len(w["template"])
    B = len(w["shape_blend"])
    Jin = len(w["input_joints"])
    w.update(lbs_only_network(N, input_count_without_latent(Jin, B)))
    return w


def lbs_only_bytes(weights, body_contact=False):
    return write_asset(None, lbs_only_weights(weights, body_contact))


def is_lbs_only(weights):
    """True when the network cannot move the garment: every learned blend shape D_j is zero."""
    return bool(np.all(np.asarray(weights["blend_shapes"], np.float64) == 0.0))


def garment_from_asset(weights):
    """The simulator's Garment made from the asset's own mesh, skin, shape blend shapes and pins (so the reference
    and the runtime see the same vertices)."""
    from pleat.garment import Garment
    pinned = weights.get("pinned")
    excluded = collision_exclude(weights)
    return Garment.build(name=str(weights.get("garment_name", "garment")), template=weights["template"],
                         faces=weights["faces"], skin_indices=weights["skin_indices"],
                         skin_weights=weights["skin_weights"], shape_blend=weights["shape_blend"],
                         pinned=np.zeros(0, np.int32) if pinned is None else pinned, collision_exclude=excluded)


def collision_exclude(weights):
    """The body joints (indices) whose parts the asset's garment does not collide with (META collision_exclude,
    by name; none when absent)."""
    import json
    meta = json.loads(str(weights["metadata_json"])) if weights.get("metadata_json") is not None else {}
    names = [str(n) for n in weights["joint_names"]]
    return [names.index(n) for n in meta.get("collision_exclude", [])]


def collision_mask(weights, body):
    """bool [V] of the body vertices the asset's garment collides with, or None for all (signed_distances' collide)."""
    from pleat.garment.garment import body_collision_mask
    return body_collision_mask(collision_exclude(weights), body)


def skeleton_mismatch_mm(weights, body):
    """Largest distance between the asset's rest joints and the body's J(0), mm (inf if the joints differ)."""
    names = [str(n) for n in weights["joint_names"]]
    if names != [str(n) for n in body.joint_names]:
        return float("inf")
    return float(np.abs(np.asarray(weights["joint_template"], np.float64) - body.joints()).max() * 1000.0)


def load_motion(spec, body=None, fps=EVAL_FPS, max_frames=None):
    """A clip file or name (DeepMimic, BVH, ASF/AMC, AMASS npz, or a Clip .npz saved by pleat.motion) at `fps`,
    cut to `max_frames`."""
    from pleat.motion.loaders import load_clip_at
    return load_clip_at(spec, body, fps, max_frames)


def clip_rotations_for(clip, joint_names):
    """Local quaternions [T, J_asset, 4] in the asset's joint order (by name)."""
    order = [list(clip.joint_names).index(str(n)) for n in joint_names]
    return clip.local_rotations[:, order]


@dataclass
class Rollout:
    positions: np.ndarray                    # [T, N, 3] f32, m
    latent_norm: np.ndarray                  # [T], ‖Z‖ after each step
    step_us: np.ndarray                      # [T], wall time of plInstance_Step alone
    results: list = field(default_factory=list)   # plResult of each step (0 OK, 1 CLAMPED, 2 NUMERIC_RESET)
    latent_min: np.ndarray = None            # [L] elementwise min / max of Z over the run
    latent_max: np.ndarray = None

    @property
    def resets(self):
        return int(sum(r == 2 for r in self.results))


def rollout(context, asset_bytes, rotations, root_translation, root_rotation, dt_s, beta=None, material=None,
            keep_positions=True, network_rate_hz=0.0, body_contact_offset_m=None):
    """Steps one C instance through a motion. rotations [T, J, 4] (asset joint order), root_translation [T, 3],
    root_rotation [T, 4], dt_s scalar or [T]. The time of each step is that of the plInstance_Step call alone
    (ctypes structures are prepared outside the timed region). body_contact_offset_m: plInstanceDef's clearance
    (None: the SDK's default)."""
    from pleat import runtime as rt
    asset = context.load_asset(asset_bytes)
    inst = context.create_instance(asset, beta=beta, material=material, network_rate_hz=network_rate_hz,
                                   body_contact_offset_m=body_contact_offset_m)
    try:
        T = len(rotations)
        N = inst.vertex_count
        L = asset.info["latent_count"]
        dt = np.broadcast_to(np.asarray(dt_s, np.float64), (T,))
        rot = np.ascontiguousarray(np.asarray(rotations, np.float32))
        tr = np.asarray(root_translation, np.float32)
        rr = np.asarray(root_rotation, np.float32)
        out_p = np.empty((N, 3), np.float32)
        out_n = np.empty((N, 3), np.float32)
        out = rt._StepOutput(out_p.ctypes.data, 12, out_n.ctypes.data, 12, N)
        latent = np.empty(L, np.float32)
        positions = np.empty((T, N, 3), np.float32) if keep_positions else None
        norms = np.empty(T)
        times = np.empty(T)
        results = []
        zmin = np.full(L, np.inf)
        zmax = np.full(L, -np.inf)
        lib = context.lib
        step = lib.plInstance_Step
        out_ref = C.byref(out)
        for t in range(T):
            frame = rt._FrameInput(rot[t].ctypes.data, rot.shape[1], 16, rt._Vec3(*map(float, tr[t])),
                                   rt._Quat(*map(float, rr[t])), float(dt[t]))
            frame_ref = C.byref(frame)
            t0 = time.perf_counter()
            r = step(inst.handle, frame_ref, out_ref)
            times[t] = (time.perf_counter() - t0) * 1e6
            rt._check(lib, r, "plInstance_Step")
            results.append(int(r))
            lib.plInstance_GetLatent(inst.handle, latent.ctypes.data, L)
            norms[t] = float(np.linalg.norm(latent))
            np.minimum(zmin, latent, out=zmin)
            np.maximum(zmax, latent, out=zmax)
            if keep_positions:
                positions[t] = out_p
        return Rollout(positions=positions, latent_norm=norms, step_us=times, results=results, latent_min=zmin,
                       latent_max=zmax)
    finally:
        inst.close()
        asset.close()


def clip_rollout(context, asset_bytes, weights, clip, beta=None, material=None, dt_s=None, keep_positions=True,
                 network_rate_hz=0.0, body_contact_offset_m=None):
    rot = clip_rotations_for(clip, weights["joint_names"])
    dt = 1.0 / clip.fps if dt_s is None else dt_s
    return rollout(context, asset_bytes, rot, clip.root_translation, clip.root_rotation, dt, beta, material,
                   keep_positions, network_rate_hz, body_contact_offset_m)


def median_step_us(context, asset_bytes, rotations, root_translation, root_rotation, dt_s, warmup=30, repeats=5):
    """Step time (µs): the median plInstance_Step time of each of `repeats` passes over the motion (after `warmup`
    steps), and the lowest of those medians — on a machine shared with other jobs a pass can be slowed as a whole,
    and the fastest pass is the closest to the step's own cost."""
    n = len(rotations)
    w = min(warmup, n)
    rollout(context, asset_bytes, rotations[:w], root_translation[:w], root_rotation[:w],
            np.broadcast_to(dt_s, (n,))[:w], keep_positions=False)
    medians = [float(np.median(rollout(context, asset_bytes, rotations, root_translation, root_rotation, dt_s,
                                       keep_positions=False).step_us[w:])) for _ in range(repeats)]
    return min(medians)


def posed_body(body, clip, beta=None):
    """Body vertices [T, V, 3] and skinning matrices [T, J, 4, 4] along the clip."""
    R = clip.local_matrices()
    Q = clip.root_matrices()
    G = body.forward_kinematics(R, clip.root_translation, Q, beta)
    M = body.skinning_matrices(G, beta)
    v = body.shaped_vertices(beta)
    A = np.einsum("vk,tkij->tvij", body.weights, M[..., :3, :])
    verts = np.einsum("tvij,vj->tvi", A[..., :3], v) + A[..., 3]
    return verts, M


def signed_distances(body_vertices, body_faces, garment_positions, collide=None):
    """[T, N] signed distance of each garment vertex to the posed body at the same frame (negative inside), from the
    simulator's contact measure (BodyCollider.plane_distance: the tangent plane at the nearest body vertex), so
    penetration means what the simulator means; `collide` (Garment.body_collision_mask) leaves out the body parts
    the garment does not collide with, as the simulator does."""
    from pleat.body import BodyCollider
    out = np.empty(garment_positions.shape[:2])
    for t in range(len(garment_positions)):
        out[t] = BodyCollider(body_vertices[t], body_faces, collide).plane_distance(
            np.asarray(garment_positions[t], np.float64))
    return out
