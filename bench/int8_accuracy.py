"""int8 networks against the float asset they were quantised from: the C runtime's positions on the same clips.

    PLEAT_LIBRARY=build/release/libpleat.so python bench/int8_accuracy.py FLOAT.pleat INT8.pleat [--clips validation]
        [--max-frames 300] [--json OUT.json]

Per clip (β = 0, 30 fps, the networks every step, as pleat-eval): the mean and p99 over vertex-frames of the distance
between the two assets' vertices (mm), and the largest. Both run the whole autoregressive rollout, so a difference in
the latent carries into later frames as it would in use.
"""
import argparse
import json
import sys
from pathlib import Path

import numpy as np


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("float_asset")
    ap.add_argument("int8_asset")
    ap.add_argument("--clips", nargs="+", default=["validation"])
    ap.add_argument("--max-frames", type=int, default=300)
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    from pleat import runtime
    from pleat.body import BodyModel
    from pleat.eval import scene as S
    from pleat.eval.suite import _clips
    body = BodyModel.load(None)
    datas = [Path(p).read_bytes() for p in (a.float_asset, a.int8_asset)]
    _, weights = S.read_weights(a.float_asset)
    rows = []
    ctx = runtime.Context()
    try:
        for name in _clips(a.clips):
            clip = S.load_motion(name, body, S.EVAL_FPS, a.max_frames)
            runs = [S.clip_rollout(ctx, d, weights, clip).positions for d in datas]
            d_mm = np.linalg.norm(runs[1] - runs[0], axis=-1) * 1000.0
            rows.append(dict(clip=str(name), frames=int(len(d_mm)), mean_mm=float(d_mm.mean()),
                             p99_mm=float(np.percentile(d_mm, 99)), max_mm=float(d_mm.max()),
                             first_frame_mean_mm=float(d_mm[0].mean())))
            print(f"{rows[-1]['clip']:55s} {rows[-1]['frames']:4d} frames  mean {rows[-1]['mean_mm']:.3f} mm  "
                  f"p99 {rows[-1]['p99_mm']:.3f}  max {rows[-1]['max_mm']:.3f}", flush=True)
    finally:
        ctx.close()
    summary = dict(float_asset=a.float_asset, int8_asset=a.int8_asset,
                   mean_mm=float(np.mean([r["mean_mm"] for r in rows])),
                   p99_mm=float(np.mean([r["p99_mm"] for r in rows])),
                   max_mm=float(np.max([r["max_mm"] for r in rows])), clips=rows)
    print(f"over {len(rows)} clips: mean {summary['mean_mm']:.3f} mm, mean p99 {summary['p99_mm']:.3f} mm, "
          f"max {summary['max_mm']:.3f} mm")
    if a.json:
        Path(a.json).write_text(json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
