"""Step times of several assets in one run, interleaved (docs/pareto.md): `pleat.eval.scene.median_step_us` (the
timing pleat-pareto uses: plInstance_Step alone, one thread) over 300 poses of a validation clip, `--rounds` rounds
in which every asset is timed once, medians over rounds. Not a test, a benchmark.

usage: PLEAT_LIBRARY=build/eval/libpleat.so PYTHONPATH=tools .venv/bin/python bench/tier_steps.py ASSET ... \\
           [--clip deepmimic_github/humanoid3d_long_walk3] [--rounds 3]
"""
import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))

from pleat import runtime  # noqa: E402
from pleat.body import BodyModel  # noqa: E402
from pleat.eval import scene as S  # noqa: E402


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("assets", nargs="+")
    p.add_argument("--clip", default="deepmimic_github/humanoid3d_long_walk3")
    p.add_argument("--rounds", type=int, default=3)
    a = p.parse_args()
    clip = S.load_motion(a.clip, BodyModel.load(), S.EVAL_FPS, 300)
    times = {path: [] for path in a.assets}
    with runtime.Context() as ctx:
        for _ in range(a.rounds):
            for path in a.assets:
                data, w = S.read_weights(path)
                rot = S.clip_rotations_for(clip, w["joint_names"])
                times[path].append(S.median_step_us(ctx, data, rot, clip.root_translation, clip.root_rotation,
                                                    1.0 / clip.fps, repeats=3))
    for path, us in times.items():
        print(f"{path}: {float(np.median(us)):.1f} us (rounds {', '.join(f'{u:.1f}' for u in us)})")


if __name__ == "__main__":
    main()
