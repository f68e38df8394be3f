#!/usr/bin/env python3
"""How far each teacher's garment creeps over the body during a clip: the reference simulations a pleat-eval-suite
report was scored against, un-skinned into the garment's rest frame (d = A⁻¹(x − a) − T(β), as the training targets
are), and the mean of d's vertical component (+Y, the body's up) on the first and the last frame of each run.

A garment that stays where the body carries it keeps that mean near its first frame's; one that rides up the torso
run after run gains it steadily, and no model that sees only the recent poses can know by how much (docs/accuracy.md,
"A second teacher").

    PYTHONPATH=tools .venv/bin/python bench/teacher_drift.py --suites SUITE_PLEAT.json SUITE_BLENDER.json \\
        --out bench/results/teacher-drift.json

Reads the simulation cache the suites wrote (the `reference.path` of each run); the suites' first asset gives the
garment's skin.
"""
import argparse
import json
import shlex
import sys
from pathlib import Path

import numpy as np


def rest_frame_rise(positions, garment, body, clip, beta):
    """Per frame, the mean over vertices of the rest-frame vertical displacement (m) of simulated `positions`."""
    from pleat.sim.scene import skinning_matrices
    from pleat.train.simdata import blend_matrices, unskin
    M = skinning_matrices(body, clip, beta, slice(0, len(positions)))
    d = unskin(blend_matrices(garment, M[:, :, :3]), positions) - garment.shaped(beta)
    return d[..., 1].mean(axis=1)


def suite_drift(path, label=None):
    """{"teacher", "label", "runs": [{clip, beta, first_mm, last_mm, rise_mm}], "mean_rise_mm", "max_rise_mm"} of
    one suite report; `label` names the teacher's setup (default: the teacher)."""
    from pleat.body import BodyModel
    from pleat.eval import scene as S
    from pleat.eval.reference import read_cached
    report = json.loads(Path(path).read_text())
    asset, result = next(iter(report.items()))
    _, weights = S.read_weights(asset)
    garment = S.garment_from_asset(weights)
    body = BodyModel.load(None)
    rows, teachers = [], set()
    for run in result["runs"]:
        ref = run["reference"]
        teachers.add(ref.get("teacher") or "pleat")
        cached = read_cached(ref["path"])
        if cached is None:
            raise FileNotFoundError(f"{ref['path']}: the reference is no longer in the simulation cache")
        clip = S.load_motion(run["clip"], body, run["fps"], run["frames"])
        rise = rest_frame_rise(np.asarray(cached[0], np.float64), garment, body, clip,
                               np.asarray(run["beta"], np.float64))
        rows.append(dict(clip=run["clip"], beta=run["beta"], frames=run["frames"],
                         first_mm=round(1e3 * float(rise[0]), 2), last_mm=round(1e3 * float(rise[-1]), 2),
                         rise_mm=round(1e3 * float(rise[-1] - rise[0]), 2)))
    if len(teachers) != 1:
        raise ValueError(f"{path}: runs against several teachers {sorted(teachers)}")
    rises = [r["rise_mm"] for r in rows]
    teacher = teachers.pop()
    return dict(suite=str(path), teacher=teacher, label=label or teacher, asset=asset, runs=rows,
                mean_rise_mm=round(float(np.mean(rises)), 2), max_rise_mm=round(float(np.max(rises)), 2))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--suites", nargs="+", required=True, help="pleat-eval-suite reports (one per teacher)")
    p.add_argument("--labels", nargs="+", help="a name per suite for its teacher's setup (default: the teacher)")
    p.add_argument("--out", required=True, help="the JSON written")
    a = p.parse_args(argv)
    labels = a.labels or [None] * len(a.suites)
    if len(labels) != len(a.suites):
        p.error(f"{len(a.suites)} suites but {len(labels)} labels")
    from pleat.fileio import write_text
    result = {"about": "The mean rest-frame vertical displacement of each teacher's simulated garment on the first and "
                       "last frame of each suite run (bench/teacher_drift.py)",
              "command": "PYTHONPATH=tools .venv/bin/python bench/teacher_drift.py "
                         + shlex.join(["--suites", *a.suites] + (["--labels", *a.labels] if a.labels else [])
                                      + ["--out", a.out]),
              "teachers": [suite_drift(path, label) for path, label in zip(a.suites, labels)]}
    write_text(a.out, json.dumps(result, indent=1) + "\n")
    for t in result["teachers"]:
        print(f"{t['label']}: the garment rises {t['mean_rise_mm']:.1f} mm on average over a run "
              f"(at most {t['max_rise_mm']:.1f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
