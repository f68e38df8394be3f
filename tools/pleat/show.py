"""pleat-show: body + garment for a few frames of a clip or a simulation, rendered to a PNG with matplotlib.

Drawn by pleat.draw: flat-shaded triangles sorted back to front (painter's algorithm), orthographic view from the
front (+Z) or any yaw.

    pleat-show --garment data/garments/tshirt.npz --motion humanoid3d_walk --frames 0,30,60 --out walk.png
    pleat-show --garment data/garments/tshirt.npz --sim out/jump --frames 0,20,40 --out jump.png
    pleat-show --garment tshirt,pants,dress --frames 0 --out sheet.png     (several garments: one column each)
"""
import argparse
import sys
import zipfile
from pathlib import Path

import numpy as np

from pleat.cli import InputError, UsageError, add_quiet, command
from pleat.draw import (BODY_COLOR, GARMENT_COLORS, LIGHT, contact_sheet, draw_meshes,  # noqa: F401
                        project)  # (importers of pleat.show find the drawing here)


def _frames(text):
    frames = [int(t) for t in str(text).split(",") if t.strip() != ""]
    if not frames or min(frames) < 0:
        raise ValueError(f"--frames needs comma-separated frame indices >= 0, got {text!r}")
    return frames


def build_parser():
    parser = argparse.ArgumentParser(prog="pleat-show", description=__doc__.split("\n\n")[0])
    parser.add_argument("--garment", required=True,
                        help="garment npz, or garment name(s) (comma-separated) to generate or find in data/garments")
    parser.add_argument("--sim", default=None, help="simulation folder with sim.npz (pleat-sim --out)")
    parser.add_argument("--motion", default=None, help="motion clip (name or file) to pose body and garment by LBS")
    parser.add_argument("--frames", default="0", help="comma-separated frame indices")
    parser.add_argument("--beta", default=None, help="comma-separated shape β")
    parser.add_argument("--yaw", type=float, default=0.0, help="camera yaw about +Y, degrees (0 = from the front)")
    parser.add_argument("--body", default=None, help="body npz (default assets/body.npz)")
    parser.add_argument("--out", required=True, help="output file: the PNG")
    return add_quiet(parser)


def _read_sim(folder):
    path = Path(folder) / "sim.npz"
    if not path.is_file():
        raise InputError(folder, "no sim.npz in it (pleat-sim --out FOLDER writes one)")
    try:
        with np.load(path, allow_pickle=False) as z:
            pos = np.asarray(z["positions"])
            body_v = np.asarray(z["body_vertices"]) if "body_vertices" in z.files else None
    except (ValueError, KeyError, OSError, EOFError, zipfile.BadZipFile) as exc:
        raise InputError(path, f"not a pleat-sim output ({type(exc).__name__}: {exc})") from None
    if pos.ndim != 3 or pos.shape[-1] != 3 or not np.isfinite(pos).all():
        raise InputError(path, f"positions must be finite [T, N, 3], got shape {pos.shape}")
    return pos, body_v


@command("pleat-show", build_parser)
def main(args):
    try:
        frames = _frames(args.frames)
        beta = None if args.beta is None else np.array([float(b) for b in args.beta.split(",")])
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    from .motion.loaders import load_clip_at
    from .sim.scene import load_body, load_garment_spec, posed_sequence
    body = load_body(args.body)
    # every input is read and checked before the garments are made and before anything is drawn or written
    clip = None
    if args.sim is not None:
        pos, body_v = _read_sim(args.sim)
        if max(frames) >= len(pos):
            raise InputError(args.sim, f"frame {max(frames)} is beyond the simulation's {len(pos)} frames")
    elif args.motion is not None:
        clip = load_clip_at(args.motion, body, 30.0)
        if max(frames) >= clip.num_frames:
            raise InputError(args.motion, f"frame {max(frames)} is beyond the clip's {clip.num_frames} frames "
                                          "(at 30 fps)")
    garments = [load_garment_spec(s, body) for s in args.garment.split(",")]
    panels, titles = [], []
    if args.sim is not None:
        g = garments[0]
        if pos.shape[1] != g.num_vertices:
            raise InputError(args.sim, f"simulates {pos.shape[1]} vertices; garment {g.name} has {g.num_vertices}")
        for t in frames:
            meshes = [(pos[t], g.faces, GARMENT_COLORS[0])]
            if body_v is not None:
                meshes.insert(0, (body_v[t], body.faces, BODY_COLOR))
            panels.append((meshes, args.yaw))
            titles.append(f"{g.name} sim frame {t}")
    else:
        for k, g in enumerate(garments):
            body_seq, garment_seq = posed_sequence(body, g, clip, frames, beta)
            for i, t in enumerate(frames):
                panels.append(([(body_seq[i], body.faces, BODY_COLOR),
                                (garment_seq[i], g.faces, GARMENT_COLORS[k % len(GARMENT_COLORS)])], args.yaw))
                titles.append(f"{g.name}" + (f" frame {t}" if args.motion else ""))
    contact_sheet(panels, args.out, titles)
    print(f"pleat-show: wrote {args.out} ({len(panels)} panels)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
