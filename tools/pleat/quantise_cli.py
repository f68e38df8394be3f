"""`pleat-quantise`: int8 calibration rows and quantisation-aware fine-tuning (pleat.quantise, pleat.train.qat).

    pleat-quantise collect ASSET.pleat --clips CLIP ... --out calibration.npz   # X_c rows of clips, for
    pleat-pack WEIGHTS --int8 --calibration calibration.npz --out OUT.pleat
    pleat-quantise finetune ASSET.pleat --out OUT.pleat       # quantisation-aware fine-tune, then int8
                                                              # (needs PyTorch; docs/performance.md "int8 networks")

finetune's defaults are the best measured (docs/performance.md): random-row calibration, then the input scales
learnt with the weights, the mean vertex distance over windows of 16 frames plus 3 × its second difference over
frames, 1,000 iterations at 5·10⁻⁶.
"""
import argparse
import sys

from pleat import quantise as pq
from pleat.cli import add_quiet, command, doc_parser


def build_parser():
    p = doc_parser("pleat-quantise", __doc__)
    sub = p.add_subparsers(dest="command", required=True)
    c = sub.add_parser("collect", help="X_c rows of clips run through an asset's float networks (calibration npz)")
    c.add_argument("asset", help="a float (fp32/fp16) .pleat")
    c.add_argument("--clips", nargs="+", required=True, help="clip names or files (pleat.motion)")
    c.add_argument("--max-frames", type=int, default=None, help="frames per clip at most (default: all)")
    c.add_argument("--out", required=True, help="output file (.npz with x_c [M, I], for pleat-pack --calibration)")
    add_quiet(c)
    f = sub.add_parser("finetune", help="quantisation-aware fine-tune of a float asset's networks, written as int8 "
                                        "(pleat.train.qat; needs PyTorch)")
    f.add_argument("asset", help="a float (fp32/fp16) .pleat: the teacher and the starting point")
    f.add_argument("--out", required=True, help="output file: the int8 .pleat (its calibration rows beside it)")
    f.add_argument("--frames", type=int, default=20000, help="frames of training motion (default %(default)s)")
    f.add_argument("--iterations", type=int, default=1000, help="Adam iterations (default %(default)s)")
    f.add_argument("--window", type=int, default=16, help="frames each window runs free (default %(default)s)")
    f.add_argument("--batch", type=int, default=32, help="windows per iteration (default %(default)s)")
    f.add_argument("--lr", type=float, default=5e-6, help="Adam learning rate (default %(default)s)")
    f.add_argument("--percentile", type=float, default=100.0,
                   help="each layer's input range: this percentile of |value| (default 100: the largest)")
    f.add_argument("--calibration", choices=("motion", "random"), default="random",
                   help="each layer's input range from the float model's own X_c rows on the motion, or from random "
                        "normalised rows as pleat-pack's default (default %(default)s)")
    f.add_argument("--learn-scales", action=argparse.BooleanOptionalAction, default=True,
                   help="learn each layer's input scale with the weights (LSQ), starting from the calibration's "
                        "(default: yes)")
    f.add_argument("--objective", choices=("mse", "distance"), default="distance",
                   help="the windows' loss: squared displacement error (mse) or mean per-vertex distance (distance, "
                        "what bench/int8_accuracy.py reports)")
    f.add_argument("--symmetric-inputs", action="store_true",
                   help="every layer's input quantised to -127..127, as the first int8 assets (default: ranged "
                        "inputs where the networks are ReLU)")
    f.add_argument("--smoothness", type=float, default=3.0,
                   help="with --objective distance: this weight on the error's second difference over frames, the "
                        "noise that adds jitter (default %(default)s)")
    f.add_argument("--seed", type=int, default=0, help="seed of the motion plan and the batches (default 0)")
    add_quiet(f)
    return p


@command("pleat-quantise", build_parser)
def main(a):
    from pathlib import Path

    from pleat import asset as pa
    from pleat.fileio import save_npz
    weights = pa.read_asset(Path(a.asset).read_bytes())
    pq.require_float(weights)
    if a.command == "finetune":
        try:
            from pleat.train import qat
        except ImportError:
            print("pleat-quantise finetune needs PyTorch: pip install 'pleat-tools[train]'", file=sys.stderr)
            return 2
        log = None if a.quiet else (lambda m: print(m, file=sys.stderr, flush=True))
        tuned, x_norm, report = qat.finetune(weights, a.frames, a.iterations, a.window, a.batch, a.lr, a.percentile,
                                             seed=a.seed, log=log, calibration=a.calibration,
                                             learn_scales=a.learn_scales, objective=a.objective,
                                             smoothness=a.smoothness,
                                             ranged=False if a.symmetric_inputs else None)
        qat.write(weights, tuned, x_norm, report, a.out, a.percentile)
        if not a.quiet:
            print(f"wrote {a.out} ({report['time_s']:.0f} s)", file=sys.stderr)
        return 0
    x_c = pq.collect_inputs(weights, a.clips, a.max_frames)
    save_npz(a.out, **{pq.CALIBRATION_KEY: x_c})
    if not a.quiet:
        print(f"wrote {a.out}: {len(x_c)} rows", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
