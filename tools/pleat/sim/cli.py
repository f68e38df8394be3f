"""pleat-sim: the reference simulation of a garment on the body playing a clip → DIR/sim.npz, DIR/summary.json."""
import argparse
import json
import sys
from pathlib import Path

import numpy as np

from pleat.cli import UsageError, add_quiet, command, positive_float
from pleat.fileio import save_npz, write_text


def build_parser():
    parser = argparse.ArgumentParser(prog="pleat-sim", description=__doc__.split(": ", 1)[1])
    parser.add_argument("--garment", required=True, help="garment npz (pleat-garment) or garment name")
    parser.add_argument("--motion", required=True, help="clip name or file (pleat-motion list)")
    parser.add_argument("--out", required=True, help="output folder (sim.npz, summary.json)")
    parser.add_argument("--frames", type=int, default=None, help="simulate only the first N frames")
    parser.add_argument("--fps", type=positive_float, default=30.0,
                        help="frame rate the clip is resampled to (dt = 1/fps)")
    parser.add_argument("--beta", default=None, help="comma-separated body shape β (up to 10 values)")
    parser.add_argument("--material", default=None,
                        help="m,mu,lambda,k (areal density kg/m², Lamé μ, λ, bending k); default HOOD's cotton")
    parser.add_argument("--body", default=None, help="body npz (default assets/body.npz)")
    parser.add_argument("--no-body", action="store_true", help="do not store body vertices in sim.npz")
    parser.add_argument("--lead-in", type=int, default=None, metavar="N",
                        help="frames from the rest pose to the clip's first pose before frame 0 (default 15; 0: start "
                             "from the garment skinned onto frame 0)")
    parser.add_argument("--hold", type=int, default=None, metavar="N",
                        help="frames the first pose is held after the lead-in (default 5)")
    return add_quiet(parser)


@command("pleat-sim", build_parser)
def main(args):
    from ..physics import Material
    from .scene import HOLD_FRAMES, LEAD_IN_FRAMES, load_body, load_garment_spec, load_motion, simulate
    try:
        material = Material.parse(args.material) if args.material else Material()
        beta = None if args.beta is None else np.array([float(b) for b in args.beta.split(",")])
    except ValueError as e:
        raise UsageError(str(e)) from None
    if args.frames is not None and args.frames < 1:
        raise UsageError("--frames must be at least 1")
    body = load_body(args.body)
    clip = load_motion(args.motion, body, fps=args.fps)          # a bad clip fails here, before any work
    garment = load_garment_spec(args.garment, body)
    positions, body_v, summary = simulate(garment, body, clip, beta=beta, material=material, frames=args.frames,
                                          progress=not args.quiet, keep_body=not args.no_body,
                                          lead_in_frames=LEAD_IN_FRAMES if args.lead_in is None else args.lead_in,
                                          hold_frames=HOLD_FRAMES if args.hold is None else args.hold)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    arrays = dict(positions=positions, faces=garment.faces, fps=np.float64(clip.fps), garment=np.array(garment.name),
                  motion=np.array(clip.name))
    if beta is not None:
        arrays["beta"] = beta.astype(np.float32)
    if body_v is not None:
        arrays["body_vertices"] = body_v
    save_npz(out / "sim.npz", compressed=True, **arrays)
    summary["motion"] = clip.name
    keys = ["frames", "seconds_per_frame", "max_penetration_mm", "final_gradient_norm", "steps_not_converged"]
    if body_v is not None:
        # the cloth's faces, not only its vertices (pleat.sim.surface): on up to 10 frames spread over the run
        from .surface import surface_inside
        idx = np.unique(np.linspace(0, len(positions) - 1, min(10, len(positions))).round().astype(int))
        summary["surface_inside"] = surface_inside(body_v[idx], body.faces, positions[idx], garment.faces,
                                                   garment.body_collision_mask(body))
        keys.append("surface_inside")
    write_text(out / "summary.json", json.dumps(summary, indent=2) + "\n")
    print(json.dumps({k: summary[k] for k in keys}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
