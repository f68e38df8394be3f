"""Contact sheet of a trained asset beside the LBS-only baseline and the reference simulation, to look at.

    pleat-preview --asset out/train/default/tshirt.pleat --motion humanoid3d_long_walk3 \
        --frames 10,30,59 --out out/train/default/preview.png [--max-frames 60] [--yaw 0]

Rows are frames; columns: reference (pleat.sim, from pleat-eval's cache: run pleat-eval first or wait), LBS-only,
the asset through the C runtime, and any --extra assets. Body and garments are posed for the same β (0) and the
asset's default material, exactly as pleat-eval does.
"""
import argparse
import sys

import numpy as np

from pleat.cli import add_quiet, command
from pleat.fileio import save_figure


def build_parser():
    ap = argparse.ArgumentParser(prog="pleat-preview", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--asset", required=True, help="the trained .pleat asset (second column)")
    ap.add_argument("--extra", action="append", default=[], help="further assets, one column each")
    ap.add_argument("--motion", required=True, help="clip name or file")
    ap.add_argument("--frames", default="10,30,59", help="comma-separated frame indices, one row each")
    ap.add_argument("--max-frames", type=int, default=60, help="frames of the clip simulated and stepped")
    ap.add_argument("--yaw", type=float, default=0.0, help="camera yaw about +Y, degrees (0 = from the front)")
    ap.add_argument("--out", required=True, help="output file: the PNG contact sheet")
    add_quiet(ap)
    return ap


@command("pleat-preview")
def main(argv=None):
    args = build_parser().parse_args(argv)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pleat import runtime
    from pleat.body import BodyModel
    from pleat.eval import scene as S
    from pleat.eval.reference import cached_simulate
    from pleat.draw import BODY_COLOR, GARMENT_COLORS, draw_meshes

    data, weights = S.read_weights(args.asset)
    body = BodyModel.load(None)
    clip = S.load_motion(args.motion, body, S.EVAL_FPS, args.max_frames)
    beta = np.zeros(len(weights["shape_blend"]))
    material = np.asarray(weights["material_default"], np.float64)
    garment = S.garment_from_asset(weights)
    columns = {}
    ref, _ = cached_simulate(garment, body, clip, beta, material, clip.num_frames, progress=False)
    columns["reference sim"] = ref
    with runtime.Context() as ctx:
        columns["LBS only"] = S.clip_rollout(ctx, S.lbs_only_bytes(weights), weights, clip, beta, material).positions
        columns[args.asset.split("/")[-1]] = S.clip_rollout(ctx, data, weights, clip, beta, material).positions
        for extra in args.extra:
            d, w = S.read_weights(extra)
            columns[extra.split("/")[-1]] = S.clip_rollout(ctx, d, w, clip, beta, material).positions
    body_v, _ = S.posed_body(body, clip, beta)
    faces = np.asarray(weights["faces"], np.int64).reshape(-1, 3)
    frames = [min(int(f), clip.num_frames - 1) for f in args.frames.split(",")]
    fig, axes = plt.subplots(len(frames), len(columns), figsize=(2.6 * len(columns), 4.2 * len(frames)), dpi=100,
                             squeeze=False)
    for r, f in enumerate(frames):
        for c, (name, pos) in enumerate(columns.items()):
            meshes = [(body_v[f], body.faces, BODY_COLOR), (pos[f], faces, GARMENT_COLORS[c % len(GARMENT_COLORS)])]
            draw_meshes(axes[r, c], meshes, yaw_deg=args.yaw)
            err = np.linalg.norm(pos[f] - ref[f], axis=1).mean() * 1e3
            axes[r, c].set_title(f"{name}\nframe {f}" + ("" if c == 0 else f", {err:.1f} mm"), fontsize=8)
    fig.tight_layout()
    save_figure(fig, args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
