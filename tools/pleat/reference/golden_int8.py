"""Golden data for the int8 networks: a random asset quantised by pleat.quantise, and rows through both of its int8
MLPs as pleat.reference.mlp.mlp_int8 computes them — the C runtime's bits (tests/c/test_int8_matches_reference.c).
Twice: with ranged inputs (pleat-pack's default for ReLU networks) and with the symmetric ones of the first int8
assets.

    pleat-golden-int8 --out DIR     # DIR/asset.pleat, DIR/mlp_case.bin (ranged inputs),
                                    # DIR/asset_symmetric.pleat, DIR/mlp_case_symmetric.bin

mlp_case.bin: b"PLINT8MC", u32 version 1, rows M, I, L, D, then float32 x [M, I] (f_LP's normalised inputs),
y [M, L] (f_LP's outputs), z [M, L] (decoder inputs) and w [M, D] (its outputs). Some rows are scaled far past the
calibrated ranges, so the clamps run too.
"""
import struct
import sys
from pathlib import Path

import numpy as np

from pleat.asset import read_asset, write_asset
from pleat.cli import add_quiet, command, doc_parser
from pleat.quantise import normalised_inputs, quantise
from pleat.reference.golden import random_weights
from pleat.reference.latent_guard import latent_guard
from pleat.reference.mlp import int8_layers, mlp_int8


def generate(out_dir, rows=24, seed=0, vertices=300):
    """Both cases; returns the ranged one's (asset, x, y, z, w)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    # hidden widths with tails past every SIMD step (16, 32, 64) and odd row counts
    weights = random_weights(vertices=vertices, seed=seed, lp_hidden=(200, 97), dec_hidden=(133,), blend=40,
                             body_contact=False)
    stored = read_asset(write_asset(None, weights))            # the float weights as stored (fp32)
    symmetric = _case(stored, out_dir, "_symmetric", False, rows, seed)
    ranged = _case(stored, out_dir, "", True, rows, seed)
    assert not np.array_equal(symmetric[2], ranged[2])       # the two schemes are different arithmetic
    return ranged


def _case(stored, out_dir, suffix, ranged, rows, seed):
    q, _ = quantise(stored, normalised_inputs(stored, count=512, seed=seed), ranged=ranged)
    asset = read_asset(write_asset(out_dir / f"asset{suffix}.pleat", q))
    rng = np.random.default_rng(seed + 1)
    I, L = len(asset["x_mean"]), len(asset["z_mean"])
    x = rng.standard_normal((rows, I)).astype(np.float32)
    x[: rows // 4] *= 20.0                                      # past the calibrated range: the clamp
    lp, dec = int8_layers(asset, "lp"), int8_layers(asset, "dec")
    y = mlp_int8(x, lp, asset["lp_activation"])
    z = latent_guard(y, asset["z_mean"], asset["z_std"], asset["z_min"], asset["z_max"]).astype(np.float32)
    w = mlp_int8(z, dec, asset["dec_activation"])
    with open(out_dir / f"mlp_case{suffix}.bin", "wb") as f:
        f.write(b"PLINT8MC" + struct.pack("<5I", 1, rows, I, L, w.shape[1]))
        for a in (x, y, z, w):
            f.write(np.ascontiguousarray(a, np.float32).tobytes())
    return asset, x, y, z, w


def build_parser():
    p = doc_parser("pleat-golden-int8", __doc__)
    p.add_argument("--out", required=True, help="output folder (asset[_symmetric].pleat, mlp_case[_symmetric].bin)")
    p.add_argument("--rows", type=int, default=24, help="input rows through each network")
    p.add_argument("--seed", type=int, default=0, help="seed of the random weights and rows")
    return add_quiet(p)


@command("pleat-golden-int8", build_parser)
def main(a):
    generate(a.out, a.rows, a.seed)
    if not a.quiet:
        print(f"wrote {a.out}/asset[_symmetric].pleat and mlp_case[_symmetric].bin", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
