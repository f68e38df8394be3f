"""Writes the two small binary files the headless renderer (samples/render, `pleat-render`) reads.

    python -m pleat.render_export body   --out out/demo/body.bin   [--body assets/body.npz] [--beta b0,b1,..]
                                         [--asset A.pleat] [--influences 4]
    python -m pleat.render_export motion --out out/demo/walk.bin   --clip humanoid3d_walk [--fps 30]
                                         [--frames N] [--asset A.pleat]

Formats (little-endian, documented in docs/demo.md):
  PLBODY01: magic, u32 version = 1, u32 vertex_count V, face_count F, joint_count J, influence_count K, beta_count B,
            f32 beta[B], char joint_names[J][32], f32 joints[J][3] (J(β)), f32 vertices[V][3] (shaped for β),
            u32 faces[F][3], u32 skin_indices[V][K], f32 skin_weights[V][K].
  PLMOTION: magic, u32 version = 1, u32 frame_count T, u32 joint_count J, f32 fps, char joint_names[J][32],
            then per frame f32 rotations[J][4] (x,y,z,w), f32 root_translation[3], f32 root_rotation[4] (x,y,z,w).
With --asset, joints are written in the asset's joint order (the renderer also matches them by name).
"""
import argparse
import os
import struct
import sys

import numpy as np

from pleat.cli import UsageError, add_quiet, command, positive_float
from pleat.rotations import quat_normalize

NAME_BYTES = 32
BODY_MAGIC = b"PLBODY01"
MOTION_MAGIC = b"PLMOTION"
VERSION = 1


def _open_for_writing(path):
    """An atomic binary writer (pleat.fileio): the file appears only when the block ends without error."""
    from pleat.fileio import atomic_write
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    return atomic_write(path, "wb")


def _names_block(names):
    out = bytearray()
    for name in names:
        raw = str(name).encode("utf-8")
        if len(raw) >= NAME_BYTES:
            raise ValueError(f"joint name {name!r} is longer than {NAME_BYTES - 1} bytes")
        out += raw + b"\0" * (NAME_BYTES - len(raw))
    return bytes(out)


def sparse_skin(weights, influences):
    """Dense [V, J] skin weights → the K largest per vertex, renormalised: (indices [V, K] u32, weights [V, K])."""
    weights = np.asarray(weights, dtype=np.float64)
    k = min(influences, weights.shape[1])
    order = np.argsort(-weights, axis=1, kind="stable")[:, :k]
    top = np.take_along_axis(weights, order, axis=1)
    top = np.maximum(top, 0.0)
    sums = top.sum(axis=1, keepdims=True)
    if np.any(sums <= 0):
        raise ValueError("a body vertex has no positive skin weight")
    return order.astype(np.uint32), (top / sums).astype(np.float32)


def write_body_file(path, joint_names, joints, vertices, faces, skin_indices, skin_weights, beta):
    """Writes PLBODY01. joints [J, 3], vertices [V, 3], faces [F, 3], skin_indices/weights [V, K], beta [B]."""
    joints = np.ascontiguousarray(joints, dtype="<f4")
    vertices = np.ascontiguousarray(vertices, dtype="<f4")
    faces = np.ascontiguousarray(faces, dtype="<u4")
    skin_indices = np.ascontiguousarray(skin_indices, dtype="<u4")
    skin_weights = np.ascontiguousarray(skin_weights, dtype="<f4")
    beta = np.ascontiguousarray(beta, dtype="<f4").reshape(-1)
    J, V, F, K = len(joint_names), vertices.shape[0], faces.shape[0], skin_indices.shape[1]
    if joints.shape != (J, 3) or vertices.shape != (V, 3) or faces.shape != (F, 3):
        raise ValueError("body arrays have inconsistent shapes")
    if skin_indices.shape != (V, K) or skin_weights.shape != (V, K) or np.any(skin_indices >= J):
        raise ValueError("body skin arrays are inconsistent")
    if np.any(faces >= V):
        raise ValueError("body face index out of range")
    with _open_for_writing(path) as f:
        f.write(BODY_MAGIC + struct.pack("<6I", VERSION, V, F, J, K, beta.size))
        f.write(beta.tobytes())
        f.write(_names_block(joint_names))
        for a in (joints, vertices, faces, skin_indices, skin_weights):
            f.write(a.tobytes())


def write_motion_file(path, joint_names, fps, rotations, root_translation, root_rotation):
    """Writes PLMOTION. rotations [T, J, 4] (x,y,z,w), root_translation [T, 3], root_rotation [T, 4]."""
    rotations = quat_normalize(np.asarray(rotations, dtype=np.float64))
    root_rotation = quat_normalize(np.asarray(root_rotation, dtype=np.float64))
    root_translation = np.asarray(root_translation, dtype=np.float64)
    T, J = rotations.shape[:2]
    if rotations.shape != (T, J, 4) or root_translation.shape != (T, 3) or root_rotation.shape != (T, 4):
        raise ValueError("motion arrays have inconsistent shapes")
    if len(joint_names) != J:
        raise ValueError(f"{len(joint_names)} joint names for {J} joints")
    frames = np.concatenate([rotations.reshape(T, J * 4), root_translation, root_rotation], axis=1)
    if not np.all(np.isfinite(frames)):
        raise ValueError("motion has non-finite values")
    with _open_for_writing(path) as f:
        f.write(MOTION_MAGIC + struct.pack("<3If", VERSION, T, J, float(fps)))
        f.write(_names_block(joint_names))
        f.write(np.ascontiguousarray(frames, dtype="<f4").tobytes())


def _read_asset(asset_path):
    from pleat.asset import read_asset
    with open(asset_path, "rb") as f:
        return read_asset(f.read())


def _asset_joint_order(asset_path, names):
    """Permutation putting `names` in the asset's joint order (the asset must have every name)."""
    asset_names = [str(n) for n in _read_asset(asset_path)["joint_names"]]
    missing = [n for n in asset_names if n not in names]
    if missing or len(asset_names) != len(names):
        raise SystemExit(f"{asset_path}: joints {missing or asset_names} do not match the body/clip joints {names}")
    return [list(names).index(n) for n in asset_names]


def export_body(body, out, beta=None, influences=4, asset_path=None):
    """PLBODY01 for pleat.body.BodyModel `body` shaped by β."""
    beta = np.zeros(body.shapedirs.shape[2]) if beta is None else np.asarray(beta, dtype=np.float64)
    beta = np.pad(beta, (0, body.shapedirs.shape[2] - beta.size))
    names = [str(n) for n in body.joint_names]
    vertices = body.v_template + body.shapedirs @ beta
    joints = np.asarray(body.J_regressor @ vertices)
    skin_indices, skin_weights = sparse_skin(body.weights, influences)
    if asset_path:
        # The renderer skins this body with the asset's joints J(β): if the asset was built from another body (or an
        # older body.npz), the body and the garment drift apart. Say so rather than render it silently.
        asset = _read_asset(asset_path)
        asset_joints = asset["joint_template"] + np.einsum("b,bjc->jc", beta[:asset["joint_shapedirs"].shape[0]],
                                                           asset["joint_shapedirs"])
        by_name = {str(n): k for k, n in enumerate(asset["joint_names"])}
        gap = max(np.linalg.norm(joints[i] - asset_joints[by_name[n]]) for i, n in enumerate(names) if n in by_name)
        if gap > 0.005:
            print(f"warning: {asset_path} has joints up to {gap * 1000:.0f} mm away from this body's; rebuild the "
                  f"asset from this body (python -m pleat.garment_asset) or use the body it was built from",
                  file=sys.stderr)
        order = _asset_joint_order(asset_path, names)  # new index i ← old index order[i]
        old_to_new = np.argsort(order)
        names, joints, skin_indices = [names[i] for i in order], joints[order], old_to_new[skin_indices]
    write_body_file(out, names, joints, vertices, body.faces, skin_indices, skin_weights, beta)
    return vertices.shape[0]


def load_clip(spec, fps):
    """A pleat.motion Clip by file path or by name on the motion loaders' search path, resampled to `fps`."""
    from pleat.motion.loaders import load_clip_at
    return load_clip_at(spec, None, fps)


def export_motion(clip, out, joint_names=None, frames=0, asset_path=None):
    """PLMOTION from a pleat.motion Clip (fps, local_rotations [T,J,4], root_translation, root_rotation)."""
    names = [str(n) for n in (getattr(clip, "joint_names", None) or joint_names)]
    rotations, root_translation, root_rotation = clip.local_rotations, clip.root_translation, clip.root_rotation
    if frames:
        rotations, root_translation, root_rotation = rotations[:frames], root_translation[:frames], root_rotation[:frames]
    if asset_path:
        order = _asset_joint_order(asset_path, names)
        names, rotations = [names[i] for i in order], rotations[:, order]
    write_motion_file(out, names, clip.fps, rotations, root_translation, root_rotation)
    return rotations.shape[0], clip.fps


def stick_body(joint_names, parents, joints, radius=0.025, sides=8):
    """A stand-in body of thin tubes along the bones, each rigidly skinned to its parent joint: for assets (e.g. the
    random golden ones) without a matching body mesh. Returns (vertices, faces, skin_indices [V,1], skin_weights)."""
    vertices, faces, indices = [], [], []
    angle = 2 * np.pi * np.arange(sides) / sides
    for k in range(1, len(joint_names)):
        a, b = joints[parents[k]], joints[k]
        axis = b - a
        length = np.linalg.norm(axis)
        if length < 1e-6:
            continue
        axis = axis / length
        helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        u = np.cross(axis, helper)
        u /= np.linalg.norm(u)
        v = np.cross(axis, u)
        ring = radius * (np.cos(angle)[:, None] * u + np.sin(angle)[:, None] * v)
        base = sum(len(x) for x in vertices)
        vertices.append(np.concatenate([a + ring, b + ring]))
        for i in range(sides):
            j = (i + 1) % sides
            faces += [[base + i, base + j, base + sides + j], [base + i, base + sides + j, base + sides + i]]
        indices += [parents[k]] * (2 * sides)
    vertices = np.concatenate(vertices)
    return vertices, np.array(faces), np.array(indices)[:, None], np.ones((len(indices), 1))


def export_stick_body(asset_path, out, beta=None):
    """PLBODY01 from an asset's own skeleton (stick_body), shaped by β, in the asset's joint order."""
    from pleat.asset import read_asset
    with open(asset_path, "rb") as f:
        asset = read_asset(f.read())
    shapedirs = np.asarray(asset["joint_shapedirs"], np.float64)
    beta = np.zeros(shapedirs.shape[0]) if beta is None else np.pad(np.asarray(beta, np.float64),
                                                                    (0, shapedirs.shape[0] - len(beta)))
    joints = asset["joint_template"] + np.einsum("b,bjc->jc", beta, shapedirs)
    names = [str(n) for n in asset["joint_names"]]
    vertices, faces, skin_indices, skin_weights = stick_body(names, asset["joint_parents"], joints)
    write_body_file(out, names, joints, vertices, faces, skin_indices, skin_weights, beta)
    return vertices.shape[0]


def export_random_motion(asset_path, out, frames, fps=30.0, seed=0):
    """PLMOTION of pleat.reference.golden's smooth random clip, in the asset's joint order (for tests)."""
    from pleat.asset import read_asset
    from pleat.reference.golden import random_motion
    with open(asset_path, "rb") as f:
        names = [str(n) for n in read_asset(f.read())["joint_names"]]
    rotations, root_translation, root_rotation, _ = random_motion(frames, len(names), seed=seed, fps=fps)
    write_motion_file(out, names, fps, rotations, root_translation, root_rotation)
    return frames, fps


def _floats(text):
    return [float(x) for x in text.split(",") if x.strip()] if text else None


def build_parser():
    parser = argparse.ArgumentParser(prog="pleat-render-export", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="what", required=True, metavar="WHAT")
    b = sub.add_parser("body", help="write a PLBODY01 body file")
    b.add_argument("--body", default=None, help="body npz (default assets/body.npz)")
    b.add_argument("--beta", default="", help="comma-separated β (missing entries 0)")
    b.add_argument("--influences", type=int, default=4, help="skin influences per vertex kept (largest first)")
    b.add_argument("--asset", default=None, help="write joints in this asset's joint order")
    b.add_argument("--stick", action="store_true", help="a stick body from --asset's skeleton instead of --body")
    b.add_argument("--out", required=True, help="output file: the PLBODY01 body file")
    add_quiet(b)
    m = sub.add_parser("motion", help="write a PLMOTION clip file")
    m.add_argument("--clip", default=None, help="clip file or name on the motion search path (e.g. humanoid3d_walk)")
    m.add_argument("--random", type=int, default=0, help="instead: N frames of a smooth random clip (needs --asset)")
    m.add_argument("--fps", type=positive_float, default=30.0, help="frame rate the clip is resampled to")
    m.add_argument("--frames", type=int, default=0, help="keep the first N frames (0 = all)")
    m.add_argument("--asset", default=None, help="write joints in this asset's joint order")
    m.add_argument("--out", required=True, help="output file: the PLMOTION clip file")
    add_quiet(m)
    st = sub.add_parser("stack", help="stack PNG images (contact sheets) top to bottom into one PNG")
    st.add_argument("images", nargs="+", help="PNG files, top first")
    st.add_argument("--out", required=True, help="output file: the stacked PNG")
    add_quiet(st)
    return parser


def stack_images(paths, out):
    """The images top to bottom on a white page as wide as the widest (scripts/demo.sh's wardrobe sheet: a row per
    garment)."""
    import io

    import matplotlib.image as mpimg

    from pleat.fileio import write_bytes
    images = [np.asarray(mpimg.imread(p))[..., :3] for p in paths]
    width = max(i.shape[1] for i in images)
    page = np.ones((sum(i.shape[0] for i in images), width, 3), np.float32)
    y = 0
    for i in images:
        page[y:y + i.shape[0], :i.shape[1]] = i
        y += i.shape[0]
    buffer = io.BytesIO()
    mpimg.imsave(buffer, page, format="png")
    write_bytes(out, buffer.getvalue())
    return page.shape


@command("pleat-render-export", build_parser)
def main(args):
    if args.what == "stack":
        h, w, _ = stack_images(args.images, args.out)
        print(f"wrote {args.out}: {len(args.images)} images stacked, {w}x{h}")
        return 0

    if args.what == "body" and args.stick:
        if not args.asset:
            raise UsageError("--stick needs --asset")
        count = export_stick_body(args.asset, args.out, _floats(args.beta))
        print(f"wrote {args.out}: stick body with {count} vertices from {args.asset}")
        return 0
    if args.what == "motion" and args.random:
        if not args.asset:
            raise UsageError("--random needs --asset")
        frames, fps = export_random_motion(args.asset, args.out, args.random, args.fps)
        print(f"wrote {args.out}: {frames} frames of random motion at {fps:g} fps")
        return 0
    if args.what == "motion" and not args.clip:
        raise UsageError("motion needs --clip or --random")
    if args.what == "body":
        from pleat.body import BodyModel
        body = BodyModel.load(args.body)           # None: pleat.paths' assets/body.npz
        count = export_body(body, args.out, _floats(args.beta), args.influences, args.asset)
        print(f"wrote {args.out}: body with {count} vertices")
    else:
        clip = load_clip(args.clip, args.fps)
        frames, fps = export_motion(clip, args.out, None, args.frames, args.asset)
        print(f"wrote {args.out}: {frames} frames at {fps:g} fps from {args.clip}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
