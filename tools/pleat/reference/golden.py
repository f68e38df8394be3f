"""Random assets at realistic sizes and golden vectors for the C, SIMD and GLSL paths.

    python -m pleat.reference.golden --out DIR [--frames 300] [--fp16] [--seed 0] [--vertices 4424]

writes DIR/asset.pleat and DIR/case.bin (format in `write_case`). Expected values come from the float64 reference run
on the weights as the asset stores them (read back, so fp32- or fp16-rounded) and on the float32-rounded inputs
stored in case.bin.

`random_weights(...)` builds a weights dict (docs/asset-format.md "The weights file") of any size: a tube-shaped
garment around the torso of a 24-joint SMPL-named stick skeleton, smooth skin weights, smooth shape and blend shapes,
and MLPs whose latent recurrence is contractive so long rollouts stay bounded.
"""
import argparse
import json
import struct
import sys
import time
from pathlib import Path

import numpy as np

from pleat.asset import input_count, input_layout, read_asset, write_asset
from pleat.body.model import SMPL_JOINT_NAMES, SMPL_PARENTS  # noqa: F401 (also imported from here by tests)
from pleat.cli import add_quiet, command
from pleat.fileio import atomic_write
from pleat.garment_asset import input_joint_indices
from pleat.physics import materials as physics_materials
from pleat.reference.input_assembly import assemble_inputs
from pleat.reference.instance import Instance
from pleat.reference.mlp import mlp
from pleat.rotations import axis_angle_to_matrix, matrix_to_quat

# Rest joint locations (m, +Y up, SMPL's left = +X), a plausible adult standing on y = 0.
SMPL_JOINT_TEMPLATE = np.array([
    [0.00, 0.95, 0.00], [0.09, 0.87, 0.00], [-0.09, 0.87, 0.00], [0.00, 1.06, -0.01], [0.10, 0.50, 0.01],
    [-0.10, 0.50, 0.01], [0.00, 1.19, 0.01], [0.10, 0.09, -0.03], [-0.10, 0.09, -0.03], [0.00, 1.25, 0.02],
    [0.11, 0.03, 0.10], [-0.11, 0.03, 0.10], [0.00, 1.47, -0.01], [0.07, 1.38, 0.00], [-0.07, 1.38, 0.00],
    [0.00, 1.55, 0.04], [0.18, 1.40, -0.01], [-0.18, 1.40, -0.01], [0.44, 1.40, -0.02], [-0.44, 1.40, -0.02],
    [0.70, 1.40, -0.01], [-0.70, 1.40, -0.01], [0.78, 1.40, -0.01], [-0.78, 1.40, -0.01]])
# All joints but the pelvis, wrists and hands (docs/inputs.md): the rule of a garment asset on the shipped body.
SMPL_INPUT_JOINTS = [int(k) for k in input_joint_indices(SMPL_JOINT_NAMES)]
MATERIAL_MIN = np.array(physics_materials.MATERIAL_MIN)    # the paper's training ranges (section 4.1)
MATERIAL_MAX = np.array(physics_materials.MATERIAL_MAX)
TUBE_Y = (0.72, 1.42)
TUBE_RADIUS = (0.17, 0.12)   # x, z


def tube_mesh(vertex_count):
    """A closed-around, open-ended tube around the torso with exactly vertex_count vertices: a rings × around grid
    plus one centre vertex in some quads (which then make 4 triangles instead of 2). Triangles are counter-clockwise
    seen from outside. Returns (vertices [N, 3], faces [F, 3], (theta, height01) [N, 2])."""
    if vertex_count < 8:
        raise ValueError("vertex_count must be at least 8")
    height = TUBE_Y[1] - TUBE_Y[0]
    around = max(3, int(round(np.sqrt(vertex_count * np.pi * sum(TUBE_RADIUS) / height))))
    rings = vertex_count // around
    while rings < 2 or vertex_count - rings * around > around * (rings - 1):
        around -= 1
        rings = vertex_count // around
    centres = vertex_count - rings * around
    theta = np.tile(np.arange(around) * 2 * np.pi / around, rings)
    h = np.repeat(np.linspace(0.0, 1.0, rings), around)
    grid = np.stack([TUBE_RADIUS[0] * np.sin(theta), TUBE_Y[0] + h * height, TUBE_RADIUS[1] * np.cos(theta)], -1)
    i, j = np.meshgrid(np.arange(rings - 1), np.arange(around), indexing="ij")
    i, j = i.reshape(-1), j.reshape(-1)
    p00, p01 = i * around + j, i * around + (j + 1) % around
    p10, p11 = p00 + around, p01 + around
    with_centre = np.zeros(len(i), bool)
    with_centre[np.linspace(0, len(i) - 1, centres).round().astype(int) if centres else []] = True
    c = rings * around + np.arange(centres)
    q = with_centre
    faces = np.concatenate([
        np.stack([p00[~q], p01[~q], p11[~q]], -1), np.stack([p00[~q], p11[~q], p10[~q]], -1),
        np.stack([p00[q], p01[q], c], -1), np.stack([p01[q], p11[q], c], -1),
        np.stack([p11[q], p10[q], c], -1), np.stack([p10[q], p00[q], c], -1)])
    centre_pos = (grid[p00[q]] + grid[p01[q]] + grid[p10[q]] + grid[p11[q]]) / 4
    # the mean of a chord lies inside the tube; push it back onto the ellipse so the surface stays smooth
    ang = np.arctan2(centre_pos[:, 0] / TUBE_RADIUS[0], centre_pos[:, 2] / TUBE_RADIUS[1])
    centre_pos[:, 0], centre_pos[:, 2] = TUBE_RADIUS[0] * np.sin(ang), TUBE_RADIUS[1] * np.cos(ang)
    vertices = np.concatenate([grid, centre_pos])
    coords = np.concatenate([np.stack([theta, h], -1),
                             np.stack([ang, (centre_pos[:, 1] - TUBE_Y[0]) / height], -1)])
    return vertices, faces, coords


def _segment_distance(points, a, b):
    ab = b - a
    t = np.clip(((points - a) @ ab) / max(ab @ ab, 1e-12), 0.0, 1.0)
    return np.linalg.norm(points - (a + t[:, None] * ab), axis=1)


def smooth_skin_weights(vertices, joints, parents, influences, sigma=0.08):
    """K nearest bones (joint k → its first child) with Gaussian falloff, normalised."""
    J = len(parents)
    child = {p: k for k, p in reversed(list(enumerate(parents))) if p >= 0}
    d = np.stack([_segment_distance(vertices, joints[k], joints[child.get(k, k)]) for k in range(J)], axis=1)
    idx = np.argsort(d, axis=1, kind="stable")[:, :influences]
    w = np.exp(-(np.take_along_axis(d, idx, 1) / sigma) ** 2) + 1e-6
    w /= w.sum(axis=1, keepdims=True)
    return idx, w


def smooth_fields(coords, count, rng, modes=4):
    """count random smooth vector fields [count, N, 3] on the tube, unit RMS each."""
    theta, h = coords[:, 0], coords[:, 1]
    basis = [np.cos(m * theta) * np.cos(n * np.pi * h) for m in range(modes) for n in range(3)]
    basis += [np.sin(m * theta) * np.cos(n * np.pi * h) for m in range(1, modes) for n in range(3)]
    basis = np.stack(basis, 0)                                     # [M, N]
    coeff = rng.standard_normal((count, 3, len(basis)))
    fields = np.einsum("dcm,mn->dnc", coeff, basis)
    return fields / np.sqrt(np.mean(np.sum(fields ** 2, -1), axis=1))[:, None, None]


def _linear(rng, fan_out, fan_in, gain):
    return (rng.standard_normal((fan_out, fan_in)) * gain / np.sqrt(fan_in),
            rng.standard_normal(fan_out) * 0.01)


def random_motion(frames, joint_count=24, seed=0, fps=30.0, dt_jitter=0.15):
    """A smooth walking-like clip: local rotations within ±60°, root walking along a slowly turning heading with a
    small bob, dt = 1/fps with uniform jitter. Returns (rotations [T, J, 4], root_translation [T, 3],
    root_rotation [T, 4], dt_s [T])."""
    rng = np.random.default_rng(seed + 1000)
    dt = (1.0 / fps) * (1.0 + rng.uniform(-dt_jitter, dt_jitter, frames))
    t = np.cumsum(dt) - dt[0]
    freq = rng.uniform(0.2, 1.5, (3, joint_count, 3))
    phase = rng.uniform(0, 2 * np.pi, (3, joint_count, 3))
    amp = rng.uniform(0.1, 0.45, (3, joint_count, 3))
    aa = np.sum(amp[:, None] * np.sin(2 * np.pi * freq[:, None] * t[None, :, None, None] + phase[:, None]), axis=0)
    angle = np.linalg.norm(aa, axis=-1, keepdims=True)
    aa = np.where(angle > np.pi / 3, aa * (np.pi / 3) / np.maximum(angle, 1e-12), aa)
    rotations = matrix_to_quat(axis_angle_to_matrix(aa))
    yaw = rng.uniform(-np.pi, np.pi) + 0.8 * np.sin(2 * np.pi * 0.07 * t) + 0.3 * t
    speed = 1.2 + 0.2 * np.sin(2 * np.pi * 0.3 * t)
    heading = np.stack([np.sin(yaw), np.zeros_like(yaw), np.cos(yaw)], -1)
    root_translation = np.cumsum(heading * (speed * dt)[:, None], axis=0)
    root_translation[:, 1] = 0.02 * np.sin(2 * np.pi * 1.8 * t)
    tilt = np.stack([0.05 * np.sin(2 * np.pi * 1.8 * t), np.zeros_like(t), 0.03 * np.sin(2 * np.pi * 0.9 * t)], -1)
    root_rotation = matrix_to_quat(axis_angle_to_matrix(np.stack([np.zeros_like(yaw), yaw, np.zeros_like(yaw)], -1))
                                   @ axis_angle_to_matrix(tilt))
    return rotations, root_translation, root_rotation, dt


def random_weights(vertices=4424, latent=128, blend=128, lp_hidden=(512, 512, 512), dec_hidden=(512, 512),
                   influences=4, betas=10, seed=0, activation="relu", garment_name="golden-tube",
                   blend_rms_m=0.03, latent_gain=0.5, body_contact=True):
    """A weights dict for write_asset with random but well-behaved contents (float64 arrays; the writer rounds).

    The skeleton is always the 24 SMPL-named joints with 19 input joints. latent_gain bounds the Lipschitz constant
    of Z_t → Z_t+1 measured at sample points (the recurrence is contractive, so rollouts stay bounded);
    blend_rms_m is the RMS learned displacement for typical latents. body_contact adds body contact (asset 1.2) on a
    stand-in body, points 1 cm inside the tube, skinned like it, several candidates per vertex (below): the
    blend shapes push many vertices through it, so the contact job has work on most frames."""
    rng = np.random.default_rng(seed)
    J = len(SMPL_JOINT_NAMES)
    verts, faces, coords = tube_mesh(vertices)
    N = len(verts)
    skin_indices, skin_weights = smooth_skin_weights(verts, SMPL_JOINT_TEMPLATE, SMPL_PARENTS, influences)
    # Shape: β0 widens (1.5 cm per unit), β1 makes taller (3 % per unit about the pelvis), the rest smooth noise.
    shape = np.zeros((betas, N, 3))
    jshape = np.zeros((betas, J, 3))
    radial = verts.copy()
    radial[:, 1] = 0
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    if betas > 0:
        shape[0] = 0.015 * radial
        jshape[0, :, 0] = 0.01 * np.sign(SMPL_JOINT_TEMPLATE[:, 0])
    if betas > 1:
        shape[1, :, 1] = 0.03 * (verts[:, 1] - SMPL_JOINT_TEMPLATE[0, 1])
        jshape[1, :, 1] = 0.03 * (SMPL_JOINT_TEMPLATE[:, 1] - SMPL_JOINT_TEMPLATE[0, 1])
    if betas > 2:
        shape[2:] = 0.005 * smooth_fields(coords, betas - 2, rng)
        jshape[2:] = 0.003 * rng.standard_normal((betas - 2, J, 3))
    Jin = len(SMPL_INPUT_JOINTS)
    I = input_count(latent, Jin, betas)

    w = dict(garment_name=garment_name, joint_names=list(SMPL_JOINT_NAMES), joint_parents=np.array(SMPL_PARENTS),
             joint_template=SMPL_JOINT_TEMPLATE.copy(), joint_shapedirs=jshape, input_joints=np.array(SMPL_INPUT_JOINTS),
             template=verts, shape_blend=shape, faces=faces, skin_indices=skin_indices, skin_weights=skin_weights,
             lp_activation=activation, dec_activation=activation, dt_range_s=np.array([1 / 240, 1 / 15]),
             beta_range=np.array([-4.0, 4.0]), material_min=MATERIAL_MIN, material_max=MATERIAL_MAX,
             material_default=(MATERIAL_MIN + MATERIAL_MAX) / 2, train_fps=30.0,
             metadata_json=json.dumps({"generator": "pleat.reference.golden.random_weights", "seed": seed}))
    w["z_mean"] = 0.1 * rng.standard_normal(latent)
    w["z_std"] = rng.uniform(0.5, 1.5, latent)
    w["z_min"] = w["z_mean"] - 2.5 * w["z_std"]
    w["z_max"] = w["z_mean"] + 2.5 * w["z_std"]

    # Input normalisation from the statistics of a random clip (what training would record); the latent block uses
    # the latent's own statistics, β the training distribution U(−3, 3), material is already in [0, 1].
    clip = random_motion(120, J, seed)
    stats_asset = dict(w, z_mean=w["z_mean"], input_joints=w["input_joints"])
    xs = assemble_inputs(stats_asset, *clip, beta=np.zeros(betas))
    x_mean, x_std = xs.mean(0), np.maximum(xs.std(0), 0.05)
    x_mean[:latent], x_std[:latent] = w["z_mean"], w["z_std"]
    layout = input_layout(latent, Jin, betas)
    x_mean[layout["beta"]], x_std[layout["beta"]] = 0.0, np.sqrt(3.0)
    x_mean[layout["material"]], x_std[layout["material"]] = 0.0, 1.0
    w["x_mean"], w["x_std"] = x_mean, x_std

    def make_mlp(prefix, sizes):
        for i, (fan_in, fan_out) in enumerate(zip(sizes[:-1], sizes[1:])):
            last = i == len(sizes) - 2
            w[f"{prefix}.{i}.weight"], w[f"{prefix}.{i}.bias"] = _linear(rng, fan_out, fan_in,
                                                                       1.0 if last else np.sqrt(2.0))
    make_mlp("lp", [I, *lp_hidden, latent])
    make_mlp("dec", [latent, *dec_hidden, blend])

    # Contractive recurrence: measure ‖∂Z_t+1/∂Z_t‖₂ (exact for ReLU, piecewise linear) at sample inputs and scale
    # the latent columns of the first LP layer until every sample is below latent_gain.
    lp_w = lambda: [w[f"lp.{i}.weight"] for i in range(len(lp_hidden) + 1)]
    lp_b = [w[f"lp.{i}.bias"] for i in range(len(lp_hidden) + 1)]
    samples = (xs[rng.choice(len(xs), 4, replace=False)] - x_mean) / x_std
    samples[:, :latent] = rng.standard_normal((4, latent))
    worst = 0.0
    for x in samples:
        jac = np.diag(w["z_std"]) @ _mlp_jacobian(x, lp_w(), lp_b, activation, latent) @ np.diag(1 / w["z_std"])
        worst = max(worst, _spectral_norm(jac))
    w["lp.0.weight"][:, :latent] *= min(1.0, latent_gain / max(worst, 1e-12))

    # Blend shapes: smooth fields scaled to the requested RMS displacement at typical decoder outputs.
    fields = smooth_fields(coords, blend, rng)
    dec_w = [w[f"dec.{i}.weight"] for i in range(len(dec_hidden) + 1)]
    dec_b = [w[f"dec.{i}.bias"] for i in range(len(dec_hidden) + 1)]
    z = w["z_mean"] + w["z_std"] * rng.standard_normal((16, latent))
    weights_out = mlp(z, dec_w, dec_b, activation)
    disp = np.einsum("sd,dnc->snc", weights_out, fields)
    w["blend_shapes"] = fields * (blend_rms_m / np.sqrt(np.mean(np.sum(disp ** 2, -1))))
    w["pinned"] = np.arange(0, min(N, 3 * (N // 50 + 1)), 3)[: max(1, N // 150)]
    if body_contact:
        # The stand-in body (asset 1.2): point v 1 cm inside vertex v (every seventh without a normal), and for every
        # third vertex a second point as deep, moved 3 mm along the tube; each vertex's candidates are its own
        # point, its neighbour's, that second point where it has one, and an empty slot; every eleventh vertex has
        # none. As the tube deforms the nearest candidate changes, so the golden covers the choice as well as the push.
        extra = np.arange(0, N, 3)
        along = np.zeros(3)
        along[np.argmax(np.ptp(verts, axis=0))] = 0.003
        points = np.concatenate([verts - 0.01 * radial, verts[extra] - 0.01 * radial[extra] + along])
        normal = np.concatenate([radial, radial[extra]])
        normal[:N:7] = 0.0
        table = np.full((N, 4), 0xFFFF, np.int64)
        v = np.arange(N)
        table[:, 0], table[:, 1] = v, (v + 1) % N
        table[extra, 2] = N + np.arange(len(extra))
        table[v % 11 == 5] = 0xFFFF
        # Rings (BARG) for the points under the tube's vertices: the tube's own fans (counter-clockwise seen from
        # outside, so the posed normal points out like the rest one; pleat.garment_asset's rings); the second points
        # keep the blended rest normal.
        from pleat.garment_asset import _vertex_rings
        ring_table = np.full((len(points), 8), 0xFFFF, np.int64)
        for v, r in _vertex_rings(faces, N, np.arange(N)).items():
            if 3 <= len(r) <= 8:
                ring_table[v, :len(r)] = r
        w.update(body_anchor=points, body_anchor_shape=np.concatenate([shape, shape[:, extra]], axis=1),
                 body_anchor_normal=normal,
                 body_anchor_skin_indices=np.concatenate([skin_indices, skin_indices[extra]]),
                 body_anchor_skin_weights=np.concatenate([skin_weights, skin_weights[extra]]),
                 body_anchor_candidates=table.astype(np.uint16), body_anchor_ring=ring_table.astype(np.uint16))
    return w


def _spectral_norm(m, iterations=60):
    """Largest singular value by power iteration (LAPACK's SVD is needlessly slow on a busy 2-core machine)."""
    v = np.ones(m.shape[1]) / np.sqrt(m.shape[1])
    for _ in range(iterations):
        v = m.T @ (m @ v)
        v /= np.linalg.norm(v)
    return float(np.linalg.norm(m @ v))


def _mlp_jacobian(x, weights, biases, activation, columns):
    """∂ mlp(x) / ∂ x[:columns]."""
    h = np.asarray(x, np.float64)
    jac = None
    for i, (wm, b) in enumerate(zip(weights, biases)):
        pre = h @ wm.T + b
        jac = wm[:, :columns] if jac is None else wm @ jac
        if i + 1 < len(weights):
            if activation == "relu":
                d = (pre > 0).astype(np.float64)
            else:
                s = 1 / (1 + np.exp(-pre))
                d = s * (1 + pre * (1 - s))
            h = pre * (pre > 0) if activation == "relu" else pre * s
            jac = d[:, None] * jac
    return jac


CASE_MAGIC = b"PLGOLDEN"
CASE_VERSION = 1


def write_case(path, beta, material, rotations, root_translation, root_rotation, dt_s, latents, positions, normals):
    """case.bin, little-endian: "PLGOLDEN", u32 version = 1, u32 frame_count, u32 joint_count, u32 vertex_count N,
    u32 beta_count B, u32 latent_count L, f32 beta[B], f32 material[4], then per frame: f32 rotations[J][4],
    f32 root_translation[3], f32 root_rotation[4], f32 dt_s, f32 expected_latent[L], f32 expected_positions[N][3],
    f32 expected_normals[N][3]."""
    T, J = rotations.shape[:2]
    N, L, B = positions.shape[1], latents.shape[1], len(beta)
    f32 = lambda a: np.asarray(a, "<f4").reshape(T, -1)
    frames = np.concatenate([f32(rotations), f32(root_translation), f32(root_rotation), f32(dt_s), f32(latents),
                             f32(positions), f32(normals)], axis=1)
    with atomic_write(path, "wb") as f:
        f.write(CASE_MAGIC + struct.pack("<6I", CASE_VERSION, T, J, N, B, L))
        f.write(np.asarray(beta, "<f4").tobytes() + np.asarray(material, "<f4").tobytes())
        f.write(frames.astype("<f4").tobytes())


def read_case(path):
    data = Path(path).read_bytes()
    if data[:8] != CASE_MAGIC:
        raise ValueError("not a golden case file")
    version, T, J, N, B, L = struct.unpack_from("<6I", data, 8)
    if version != CASE_VERSION:
        raise ValueError(f"case version {version}")
    head = 8 + 24
    beta = np.frombuffer(data, "<f4", B, head)
    material = np.frombuffer(data, "<f4", 4, head + 4 * B)
    per = J * 4 + 3 + 4 + 1 + L + 2 * N * 3
    body = np.frombuffer(data, "<f4", offset=head + 4 * (B + 4))
    if body.size != T * per:
        raise ValueError(f"case body has {body.size} floats, expected {T * per}")
    body = body.reshape(T, per)
    cut = np.cumsum([J * 4, 3, 4, 1, L, N * 3])
    parts = np.split(body, cut, axis=1)
    return dict(beta=beta, material=material, rotations=parts[0].reshape(T, J, 4), root_translation=parts[1],
                root_rotation=parts[2], dt_s=parts[3][:, 0], latents=parts[4], positions=parts[5].reshape(T, N, 3),
                normals=parts[6].reshape(T, N, 3))


def run_reference(asset, beta, material, rotations, root_translation, root_rotation, dt_s):
    """Steps a reference Instance through a clip; returns (latents [T, L], positions [T, N, 3], normals [T, N, 3])."""
    inst = Instance(asset, beta, material)
    latents, positions, normals = [], [], []
    for k in range(len(dt_s)):
        p, n = inst.step(rotations[k], root_translation[k], root_rotation[k], float(dt_s[k]))
        latents.append(inst.latent.copy())
        positions.append(p)
        normals.append(n)
    return np.array(latents), np.array(positions), np.array(normals)


def generate(out_dir, frames=300, fp16=False, seed=0, vertices=4424):
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    weights = random_weights(vertices=vertices, seed=seed)
    data = write_asset(out_dir / "asset.pleat", weights, fp16=fp16)
    asset = read_asset(data)                      # the weights exactly as stored (fp32 or fp16)
    rng = np.random.default_rng(seed + 7)
    B = len(asset["shape_blend"])
    beta = rng.uniform(-2.0, 2.0, B).astype(np.float32)
    lo, hi = asset["material_min"].astype(np.float64), asset["material_max"].astype(np.float64)
    material = (lo + rng.uniform(0.1, 0.9, 4) * (hi - lo)).astype(np.float32)
    motion = [np.asarray(a, np.float32) for a in random_motion(frames, len(asset["joint_parents"]), seed)]
    latents, positions, normals = run_reference(asset, beta, material, *motion)
    write_case(out_dir / "case.bin", beta, material, *motion, latents, positions, normals)
    return asset, latents, positions, normals


def build_parser():
    p = argparse.ArgumentParser(prog="pleat-golden", description=__doc__.split("\n\n")[0])
    p.add_argument("--out", required=True, help="output folder (asset.pleat, case.bin)")
    p.add_argument("--frames", type=int, default=300, help="frames of the random-motion case")
    p.add_argument("--fp16", action="store_true", help="store weight matrices and blend shapes as fp16")
    p.add_argument("--seed", type=int, default=0, help="seed of the random weights and motion")
    p.add_argument("--vertices", type=int, default=4424, help="garment vertex count of the random asset")
    return add_quiet(p)


@command("pleat-golden", build_parser)
def main(a):
    start = time.perf_counter()
    _, latents, positions, _ = generate(a.out, a.frames, a.fp16, a.seed, a.vertices)
    if not a.quiet:
        print(f"wrote {a.out}/asset.pleat and case.bin: {a.frames} frames, {positions.shape[1]} vertices, "
              f"|latent| max {np.abs(latents).max():.3f}, {time.perf_counter() - start:.1f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
