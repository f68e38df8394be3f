"""Chart of docs/scene-budget.md: scene cost against accuracy for several budgets.

python bench/plot_scene_budget.py SCENE.json OUT.png [SCENE_FEEDBACK.json]

SCENE.json is `pleat_bench_crowd --scene` output: per budget the measured median frame time of the scene, the plan's
importance-weighted mean error and the details the characters ended on; the calibration gives the all-one-detail
references (every character on the most accurate tier, every character LBS-only), drawn as lines. A second file (the
same run with --report-costs: the scene corrects its cost model from measured frames) is drawn as a second series.
"""
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) < 2:
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        return 2
    scene = json.loads(Path(argv[0]).read_text())
    n = scene["characters"]
    cal = scene["calibration"]
    tiers = sorted((k for k in cal if k.startswith("tier")), key=lambda k: int(k[4:]))
    budgets = [b for b in scene["budgets"] if b["ok"]]
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.2), gridspec_kw={"width_ratios": [3, 2]})
    xs = [b["frame_median_us"] / 1000.0 for b in budgets]
    ys = [b["weighted_error_mm"] for b in budgets]
    ax.plot(xs, ys, "o-", color="#2a6fb0", label="policy, calibrated costs: measured median frame")
    if len(argv) > 2:
        fb = [b for b in json.loads(Path(argv[2]).read_text())["budgets"] if b["ok"]]
        ax.plot([b["frame_median_us"] / 1000.0 for b in fb], [b["weighted_error_mm"] for b in fb], "s--",
                color="#e67e22", label="policy, costs corrected from measured frames")
    for b, x, y in zip(budgets, xs, ys):
        label = "no budget" if b["budget_us"] <= 0 else f"{b['budget_us'] / 1000.0:g} ms"
        ax.annotate(label, (x, y), textcoords="offset points", xytext=(6, 6), fontsize=8)
        if b["budget_us"] > 0:
            ax.plot([b["budget_us"] / 1000.0], [y], "|", color="#999999", markersize=12)
    best = min(tiers, key=lambda k: (cal[k]["error_mm"], cal[k]["cost_us"]))
    top = cal[tiers[0]]
    ax.axhline(cal["lbs"]["error_mm"], color="#888888", ls="--", lw=1,
               label=f"all LBS-only: {cal['lbs']['error_mm']:.1f} mm, {n * cal['lbs']['cost_us'] / 1000:.2f} ms")
    ax.axhline(top["error_mm"], color="#b03a2e", ls=":", lw=1,
               label=f"all {tiers[0]} (largest): {top['error_mm']:.1f} mm, {n * top['cost_us'] / 1000:.2f} ms")
    if best != tiers[0]:
        ax.axhline(cal[best]["error_mm"], color="#2e8b57", ls=":", lw=1,
                   label=f"all {best}: {cal[best]['error_mm']:.1f} mm, {n * cal[best]['cost_us'] / 1000:.2f} ms")
    ax.set_xlabel(f"scene cost per frame, {n} characters, one core (ms, {scene['clock']} clock)")
    ax.set_ylabel("importance-weighted mean error (mm)")
    ax.set_title("Scene cost against accuracy (| = the budget)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper right")
    # The details each budget ended on.
    names = [f"tier {k[4:]}" for k in tiers] + ["LBS"]
    colours = ["#2a6fb0", "#3aa05a", "#e69a2e", "#c0392b", "#8e44ad", "#16a085", "#7f8c8d", "#34495e"][: len(tiers)]
    colours.append("#8c8c8c")
    labels = ["none" if b["budget_us"] <= 0 else f"{b['budget_us'] / 1000.0:g}" for b in budgets]
    bottom = [0] * len(budgets)
    for i, name in enumerate(names):
        counts = [b["details"][i] for b in budgets]
        bx.bar(labels, counts, bottom=bottom, color=colours[i], label=name)
        bottom = [a + c for a, c in zip(bottom, counts)]
    bx.set_xlabel("budget (ms)")
    bx.set_ylabel("characters")
    bx.set_title("Details chosen")
    bx.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(argv[1], dpi=110)
    print(f"plot_scene_budget: wrote {argv[1]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
