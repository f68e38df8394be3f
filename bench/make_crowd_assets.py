"""Crowd benchmark inputs (scripts/bench.sh): the shipped t-shirt in both precisions.

python bench/make_crowd_assets.py SHIPPED.pleat OUT_DIR writes OUT_DIR/tshirt_fp32.pleat and OUT_DIR/tshirt_fp16.pleat:
the same garment, networks and blend shapes, stored as fp32 and as fp16 (whichever the shipped file uses is kept
as it is; the other is converted), so the crowd keys compare the shipped garment at both precisions like the
reference-size assets of make_assets.py.
"""
import sys
from pathlib import Path

import numpy as np

from pleat.asset import read_asset, write_asset


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 2:
        print(__doc__.split("\n\n")[1].split(" writes")[0], file=sys.stderr)
        return 2
    shipped, out = Path(argv[0]), Path(argv[1])
    out.mkdir(parents=True, exist_ok=True)
    weights = read_asset(shipped.read_bytes())
    as_fp32 = {k: (v.astype(np.float32) if isinstance(v, np.ndarray) and v.dtype == np.float16 else v)
               for k, v in weights.items()}
    for key in ("onnx_latent_predictor", "onnx_decoder"):
        as_fp32.pop(key, None)
    write_asset(out / "tshirt_fp32.pleat", as_fp32)
    write_asset(out / "tshirt_fp16.pleat", as_fp32, fp16=True)
    print(f"make_crowd_assets: {shipped.name} as fp32 and fp16 in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
