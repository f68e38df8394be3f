#!/usr/bin/env python3
"""Fits the scene's built-in cost model (sdk/src/scene.c, PLEAT_COST_US_*) to a `pleat_bench_crowd --scene` run.

The model, per character and frame (µs): a tier at full rate = PER_MAC · (MLP + blend-shape multiply-adds) +
PER_VERTEX · N + FIXED + PER_DISPLAY_VERTEX · N_display (only for a tier on another mesh, carried over to the
display mesh); between network updates the same without the multiply-adds; LBS-only = PER_VERTEX · N_display + FIXED.
The calibration of the run gives all of these per tier (cost_us, skin_cost_us) and for LBS-only: a least-squares fit
of the four constants to them, printed with each level's measured and modelled cost.

With every tier on one mesh but xsmall, FIXED and PER_VERTEX are hardly separable; --fixed-us holds FIXED at a
value measured elsewhere (pleat_bench_phases: validation + forward kinematics + X_c + guards + commit) and fits the
other three.

usage: bench/fit_scene_costs.py out/bench/scene.json [--fixed-us F]
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
    run = json.load(open(sys.argv[1]))
    cal = run["calibration"]
    tiers = [cal[k] for k in sorted(k for k in cal if k.startswith("tier"))]
    sizes = []
    for t in tiers:
        _, w = S.read_weights(t["path"])
        sizes.append((network_macs(w), len(w["template"])))
    display = sizes[0][1]
    rows, costs, labels = [], [], []
    for t, (macs, n) in zip(tiers, sizes):
        carry = 0.0 if n == display else float(display)
        rows.append([macs, n, 1.0, carry])
        costs.append(t["cost_us"])
        labels.append(f"{t['path']} full")
        rows.append([0.0, n, 1.0, carry])
        costs.append(t["skin_cost_us"])
        labels.append(f"{t['path']} between updates")
    rows.append([0.0, display, 1.0, 0.0])
    costs.append(cal["lbs"]["cost_us"])
    labels.append("LBS-only")
    A, y = np.array(rows), np.array(costs)
    fixed = float(sys.argv[sys.argv.index("--fixed-us") + 1]) if "--fixed-us" in sys.argv else None
    # relative least squares: every level counts by its own size, not the large tier alone
    if fixed is None:
        x, *_ = np.linalg.lstsq(A / y[:, None], np.ones_like(y), rcond=None)
    else:
        free = [0, 1, 3]
        sub, *_ = np.linalg.lstsq(A[:, free] / y[:, None], (y - fixed) / y, rcond=None)
        x = np.array([sub[0], sub[1], fixed, sub[2]])
    names = ("PLEAT_COST_US_PER_MAC", "PLEAT_COST_US_PER_VERTEX", "PLEAT_COST_US_FIXED",
             "PLEAT_COST_US_PER_DISPLAY_VERTEX")
    for name, value in zip(names, x):
        print(f"#define {name} {value:.4g}")
    print()
    for label, row, measured in zip(labels, A, y):
        print(f"{label:55s} measured {measured:8.2f} µs   model {row @ x:8.2f} µs")


if __name__ == "__main__":
    main()
