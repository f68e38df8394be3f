"""`pleat-garment scene`: everything a DCC tool needs to model a garment on the Pleat body and simulate it on a
Pleat motion, so that the point cache it exports can train an asset (docs/training.md, "Your own simulation").

    pleat-garment scene --out kit/                                     # body.obj: the rest pose to model on
    pleat-garment scene --out kit/ --garment shirt.npz --motion humanoid3d_walk --units cm

Writes, in the chosen units and up axis:
- body.obj — the body at rest (β as given, default the mean body), the A-pose of docs/body.md;
- garment.obj, garment_start.obj (with --garment) — the garment at rest, and on the first frame of the animation
  (the rest pose carried rigidly to where the motion starts): simulate garment_start.obj; both have the garment's
  vertex order, so the cache you export lines up with it;
- body.pc2 and motion.bvh (with --motion) — the body's vertices per frame and the same motion on the Pleat
  skeleton: a lead-in from the rest pose to the motion's first pose (the reference simulator's: 15 frames of
  smoothstep, 5 held), then the motion, at --fps;
- user_sim.json — the manifest `pleat-train simsup --user-sim` reads, expecting your cache as garment_sim.pc2;
  the lead-in is left out of training (skip_frames).
"""
import argparse
import json
from pathlib import Path

import numpy as np

from pleat.cli import InputError, add_quiet, parse_floats


def build_scene_parser():
    from .meshio import UNITS_M
    p = argparse.ArgumentParser(prog="pleat-garment scene",
                                description="the body, garment and motion for a DCC tool (OBJ, PC2, BVH) and the "
                                            "manifest for pleat-train simsup --user-sim")
    p.add_argument("--out", required=True, help="output folder: body.obj, garment*.obj, body.pc2, motion.bvh, "
                                                "user_sim.json")
    p.add_argument("--garment", default=None, help="garment npz (pleat-garment import) to write as garment.obj and "
                                                   "garment_start.obj")
    p.add_argument("--motion", default=None, help="clip name or motion file: writes body.pc2 and motion.bvh")
    p.add_argument("--frames", type=int, default=None, help="motion frames to use (default: all)")
    p.add_argument("--fps", type=float, default=30.0, help="frame rate of the animation (default 30, the training "
                                                           "rate)")
    p.add_argument("--beta", default=None, help="body shape β, comma-separated (default: the mean body)")
    p.add_argument("--units", default="m", choices=list(UNITS_M), help="length unit of the files (default m)")
    p.add_argument("--up", default="y", choices=["y", "z"], help="up axis of the files (default y)")
    p.add_argument("--start-frame", type=float, default=1.0,
                   help="scene frame of the first animation frame (PC2 start frame; default 1, as Blender)")
    p.add_argument("--body", default=None, help="body npz (default assets/body.npz)")
    add_quiet(p)
    return p


def kit_clip(clip):
    """The reference simulator's lead-in (rest pose → the clip's first pose), then the clip: (clip, lead-in
    frames before the clip's frame 0)."""
    from dataclasses import replace
    from pleat.sim.scene import lead_in_clip
    lead = lead_in_clip(clip)
    n = lead.num_frames - 1                     # its last frame is the clip's frame 0
    cat = lambda a, b: np.concatenate([a[:n], b])        # noqa: E731
    return replace(clip, name=clip.name, local_rotations=cat(lead.local_rotations, clip.local_rotations),
                   root_translation=cat(lead.root_translation, clip.root_translation),
                   root_rotation=cat(lead.root_rotation, clip.root_rotation)), n


def scene_main(argv):
    from pleat.fileio import write_text
    from pleat.motion.bvh_export import write_bvh
    from pleat.sim.scene import load_body, load_garment_spec, skinning_matrices
    from pleat.train.pointcache import load_motion, write_pc2
    from .meshio import from_pleat_axes, write_obj
    args = build_scene_parser().parse_args(argv)
    body = load_body(args.body)
    beta = np.zeros(body.num_betas)
    if args.beta:
        try:
            values = parse_floats(args.beta, what="--beta")
        except argparse.ArgumentTypeError as exc:
            raise InputError(None, str(exc)) from None
        if len(values) > body.num_betas:
            raise InputError(None, f"--beta has {len(values)} values; the body has {body.num_betas}")
        beta[:len(values)] = values
    garment = load_garment_spec(args.garment, body) if args.garment else None
    clip = None
    if args.motion:
        clip = load_motion(args.motion, body)
        if abs(clip.fps - args.fps) > 1e-6:
            clip = clip.resample(args.fps)
        if args.frames:
            if args.frames < 2:
                raise InputError(None, "--frames must be at least 2")
            clip = clip.frames_at(slice(0, args.frames))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    def conv(x):
        return from_pleat_axes(x, args.up, args.units)

    written = []
    write_obj(out / "body.obj", conv(body.shaped_vertices(beta)), body.faces,
              header=f"Pleat body at rest (A-pose), beta {beta.tolist()}, units {args.units}, up {args.up}")
    written.append("body.obj")
    if garment is not None:
        write_obj(out / "garment.obj", conv(garment.shaped(beta)), garment.faces,
                  header=f"garment {garment.name} at rest, {garment.num_vertices} vertices in the garment's order")
        written.append("garment.obj")
    lead = 0
    if clip is not None:
        kit, lead = kit_clip(clip)
        M = skinning_matrices(body, kit, beta)
        posed = body.skin(kit.local_matrices(), kit.root_translation, kit.root_matrices(), beta)
        write_pc2(out / "body.pc2", conv(posed).astype(np.float32), args.start_frame, 1.0)
        write_bvh(out / "motion.bvh", kit, body, units="cm" if args.units != "m" else "m")
        written += ["body.pc2", "motion.bvh"]
        if garment is not None:
            start = garment.skin(M[:1], beta)[0]
            write_obj(out / "garment_start.obj", conv(start), garment.faces,
                      header=f"garment {garment.name} on the first animation frame: simulate this mesh")
            written.append("garment_start.obj")
            manifest = {"simulations": [{
                "name": f"{garment.name}_{Path(str(args.motion)).stem}", "cache": "garment_sim.pc2",
                "motion": "motion.bvh", "garment_obj": "garment.obj", "units": args.units, "up": args.up,
                "beta": beta.tolist(), "motion_start_frame": args.start_frame, "skip_frames": lead}]}
            write_text(out / "user_sim.json", json.dumps(manifest, indent=1) + "\n")
            written.append("user_sim.json")
    frames = "" if clip is None else f", {clip.num_frames} motion frames after a {lead}-frame lead-in at " \
                                     f"{args.fps:g} fps from scene frame {args.start_frame:g}"
    print(f"pleat-garment scene: wrote {', '.join(written)} to {out} (units {args.units}, up {args.up}{frames})")
    if clip is not None and garment is not None:
        print("pleat-garment scene: next: simulate garment_start.obj as cloth against body.obj animated by body.pc2, "
              f"export the garment's point cache as {out / 'garment_sim.pc2'}, then pleat-train simsup --garment "
              f"{args.garment} --user-sim {out / 'user_sim.json'}")
    return 0
