"""Seed assets for the fuzz targets written by the offline tools themselves (scripts/fuzz.sh; nothing is committed).

    python tests/c/fuzz_seeds.py OUT_DIR

The C test asset builder (fuzz_asset_seed) cannot write what only pleat-pack writes, so these cover the sections and
branches it misses: PINS, the ONNX models (OXLP/OXDC of `pleat-pack --onnx`), the 24-joint SMPL skeleton with 19
input joints, no shape components (β-less: zero-row JSHP/SHPB), fp16 with ONNX, SiLU and ReLU, several layers,
int8 networks with ranged and with symmetric inputs (pleat.quantise), int8 blend shapes (BLND i8 + BLSC). Every
asset is small (tens of KB) so a fuzzer runs thousands of them a second. Each goes through
pleat.asset.write_asset, the same writer as pleat-pack, and is read back by pleat.asset.read_asset as a check.
"""
import sys
from pathlib import Path

import numpy as np

from pleat.asset import read_asset, write_asset
from pleat.quantise import quantise, quantise_blend_shapes
from pleat.reference.golden import random_weights


def seeds():
    """(file name, weights, fp16, onnx) for each seed."""
    common = dict(vertices=12, latent=6, blend=5, lp_hidden=(10,), dec_hidden=(8,), influences=4, latent_gain=0.5)
    pinned = random_weights(betas=10, seed=1, activation="relu", **common)
    pinned["pinned"] = np.array([0, 3, 7, 11])
    yield "smpl_relu_pins_meta.pleat", pinned, False, False
    yield "smpl_silu_onnx.pleat", random_weights(betas=4, seed=2, activation="silu", **common), False, True
    yield "smpl_fp16_onnx_pins.pleat", dict(random_weights(betas=2, seed=3, **common), pinned=np.array([1])), True, True
    no_beta = random_weights(betas=0, seed=4, activation="silu", **dict(common, influences=1))
    yield "smpl_no_beta.pleat", no_beta, False, False
    deep = random_weights(betas=3, seed=5, **dict(common, lp_hidden=(9, 7, 5), dec_hidden=(6, 6), influences=8))
    yield "smpl_deep_onnx.pleat", deep, False, True
    stored = read_asset(write_asset(None, random_weights(betas=3, seed=6, activation="relu",
                                                         **dict(common, lp_hidden=(9, 7)))))
    yield "smpl_int8_ranged_fp16.pleat", quantise(stored)[0], True, False
    yield "smpl_int8_symmetric.pleat", quantise(stored, ranged=False)[0], False, False
    yield "smpl_int8_blend_shapes_fp16.pleat", quantise_blend_shapes(stored)[0], True, False
    yield "smpl_int8_everything.pleat", quantise_blend_shapes(quantise(stored)[0])[0], False, False


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        print("usage: python tests/c/fuzz_seeds.py OUT_DIR", file=sys.stderr)
        return 2
    out = Path(argv[0])
    out.mkdir(parents=True, exist_ok=True)
    for name, weights, fp16, onnx in seeds():
        try:
            data = write_asset(None, weights, fp16=fp16, onnx=onnx)
        except ImportError as e:  # onnx missing: the ONNX seeds are skipped, the others still written
            print(f"fuzz_seeds: {name} skipped ({e})", file=sys.stderr)
            continue
        read_asset(data)
        (out / name).write_bytes(data)
    return 0


if __name__ == "__main__":
    sys.exit(main())
