#!/usr/bin/env python3
"""Fits the scene's built-in cost model (sdk/src/scene/scene.c, PLEAT_COST_US_*) to a `pleat_bench_crowd --scene` run.

The model, per character and frame (µs): a tier at full rate = PER_MAC · (MLP + blend-shape multiply-adds) +
PER_VERTEX · N + FIXED + PER_DISPLAY_VERTEX · N_display (only for a tier on another mesh, carried over to the
display mesh); between network updates the same without the multiply-adds; LBS-only = LBS_PER_VERTEX · N_display +
FIXED (its own constant: the scene's LBS-only level runs the batched geometry kernels, a tier's step
between updates does not). The calibration of each run gives all of these per tier (cost_us, skin_cost_us) and for
LBS-only: a least-squares fit of the five constants to the levels of every run given, printed with each level's
measured and modelled cost.

With every tier on one mesh but xsmall, FIXED and PER_VERTEX are hardly separable; --fixed-us holds FIXED at a
value measured elsewhere (pleat_bench_phases: validation + forward kinematics + X_c + guards + commit) and fits the
other three.

usage: bench/fit_scene_costs.py out/bench/scene.json [more.json ...] [--fixed-us F]
"""
import json
import sys

import numpy as np


def network_macs(weights):
    """Multiply-adds of f_LP, f_dec and the blend shapes per step, as plNetworkMacs counts them."""
    macs = float(np.prod(weights["blend_shapes"].shape))
    for prefix in ("lp", "dec"):
        i = 0
        while f"{prefix}.{i}.weight" in weights:
            macs += float(np.prod(weights[f"{prefix}.{i}.weight"].shape))
            i += 1
    return macs


def main():
    from pleat.eval import scene as S
    args = sys.argv[1:]
    fixed = None
    if "--fixed-us" in args:
        k = args.index("--fixed-us")
        fixed = float(args[k + 1])
        del args[k:k + 2]
    rows, costs, labels = [], [], []
    for path in args:
        cal = json.load(open(path))["calibration"]
        tiers = [cal[k] for k in sorted(k for k in cal if k.startswith("tier"))]
        sizes = []
        for t in tiers:
            _, w = S.read_weights(t["path"])
            sizes.append((network_macs(w), len(w["template"])))
        display = sizes[0][1]
        for t, (macs, n) in zip(tiers, sizes):
            carry = 0.0 if n == display else float(display)
            rows.append([macs, n, 1.0, carry, 0.0])
            costs.append(t["cost_us"])
            labels.append(f"{t['path']} full")
            rows.append([0.0, n, 1.0, carry, 0.0])
            costs.append(t["skin_cost_us"])
            labels.append(f"{t['path']} between updates")
        rows.append([0.0, 0.0, 1.0, 0.0, display])
        costs.append(cal["lbs"]["cost_us"])
        labels.append("LBS-only")
    A, y = np.array(rows), np.array(costs)
    # relative least squares: every level counts by its own size, not the large tier alone
    if fixed is None:
        x, *_ = np.linalg.lstsq(A / y[:, None], np.ones_like(y), rcond=None)
    else:
        free = [0, 1, 3, 4]
        sub, *_ = np.linalg.lstsq(A[:, free] / y[:, None], (y - fixed) / y, rcond=None)
        x = np.array([sub[0], sub[1], fixed, sub[2], sub[3]])
    names = ("PLEAT_COST_US_PER_MAC", "PLEAT_COST_US_PER_VERTEX", "PLEAT_COST_US_FIXED",
             "PLEAT_COST_US_PER_DISPLAY_VERTEX", "PLEAT_COST_US_LBS_PER_VERTEX")
    for name, value in zip(names, x):
        print(f"#define {name} {value:.4g}")
    print()
    for label, row, measured in zip(labels, A, y):
        print(f"{label:55s} measured {measured:8.2f} µs   model {row @ x:8.2f} µs")


if __name__ == "__main__":
    main()
