"""Every method on one chart: error against time per frame, log time axis (docs/pareto.md, "Methods").

    PLEAT_LIBRARY=build/eval/libpleat.so pleat-methods --suite out/suite.json [more.json ...] \
        [--label PATH=NAME ...] [--rows EARLIER.json] --out docs/methods.png [--json out/methods.json]

`--rows EARLIER.json` starts from the rows and Φ time of an earlier `--json` (a chart whose suites need not be at
hand any more) and adds the suites' asset rows to it; LBS-only and the reference stay the earlier ones (the suites
must be of the same clips and bodies for the rows to compare).

Inputs are pleat-eval-suite reports (`pleat.eval.suite`, run with --reference-spread) so that every number is
measured the same way on the same clips and bodies:
- each asset: its median step time (the C runtime, one thread) and its mean vertex error over the runs, with
  error bars from the runs' spread (min and max over clips and β);
- LBS-only: the same garment with the zero network, scored in the same runs;
- the reference simulator: its CPU time per frame (from the cached simulations' own summaries) and, as its error,
  the reference spread (a second simulation started 1 µm away, scored against the first): the floor under which
  no error means anything;
- Φ, the stage-1 network, timed per frame in torch (one thread) on the same garment: speed only (its error is that
  of the two-stage recipe's teacher, not measured here).
"""
import json
import sys
import time

import numpy as np

from pleat.cli import add_quiet, command, doc_parser
from pleat.fileio import finish_figure, write_text


def phi_seconds_per_frame(preset="default", garment="tshirt", frames=20):
    """Φ's forward pass per frame (graph features, encoder, processor, compressor, decoder, blend shapes) in torch,
    one thread, random weights (time does not depend on them), on a window of a training clip."""
    import torch
    from pleat.train import core, sources
    torch.set_num_threads(1)
    cfg = core.load_config(preset)
    setup = core.Setup(cfg, garment)
    model = core.Stage1Model(setup).eval()
    clip = sources.clips("train", cfg["fps"], 1, None, setup.body)[0]
    rng = np.random.default_rng(0)
    win, beta, mat, mat01 = core.sample_window(setup, [clip], rng, frames + 3)
    window = core.Window(setup, win, beta, mat, mat01)
    times = []
    with torch.no_grad():
        for f in range(3, len(win["dt"])):
            t0 = time.perf_counter()
            node, edges, body, recv = window.features(f)
            _, disp = model(node, edges, body, recv, setup.levels)
            window.advance(f, disp)
            times.append(time.perf_counter() - t0)
    return float(np.median(times[2:] or times))


def rows_from_suites(paths, labels=None):
    labels = labels or {}
    rows, lbs, ref = [], [], []
    for p in paths:
        with open(p) as fh:
            suite = json.load(fh)
        for asset, r in suite.items():
            runs = r["runs"]
            e = np.array([x["pleat"]["mean_mm"] for x in runs])
            rows.append(dict(name=labels.get(asset, asset), kind="asset", asset=asset,
                             us=float(np.median([x["pleat"]["step_us"] for x in runs])), mean_mm=float(e.mean()),
                             lo=float(e.min()), hi=float(e.max()), runs=len(runs)))
            lbs.append((float(np.median([x["lbs"]["step_us"] for x in runs])),
                        np.array([x["lbs"]["mean_mm"] for x in runs])))
            for x in runs:
                s = x["reference"].get("summary") or {}
                spread = (x.get("reference_spread") or {}).get("mean_mm")
                ref.append((s.get("cpu_seconds_per_frame"), spread))
    if lbs:
        e = lbs[0][1]
        rows.append(dict(name="LBS-only", kind="lbs", us=float(np.median([u for u, _ in lbs])),
                         mean_mm=float(e.mean()), lo=float(e.min()), hi=float(e.max()), runs=len(e)))
    secs = [s for s, _ in ref if s]
    spreads = [d for _, d in ref if d is not None]
    if secs and spreads:
        rows.append(dict(name="reference simulator (error: its own spread)", kind="reference",
                         us=1e6 * float(np.median(secs)), mean_mm=float(np.mean(spreads)), lo=float(np.min(spreads)),
                         hi=float(np.max(spreads)), runs=len(spreads)))
    return rows


def merge_rows(earlier, rows):
    """The earlier chart's rows, then the new asset rows (a new row replaces an earlier one of the same asset), LBS-only
    and the reference last, from the earlier chart where it has them."""
    new_assets = [r for r in rows if r["kind"] == "asset"]
    replaced = {r["asset"] for r in new_assets}
    kept = [r for r in earlier if r["kind"] == "asset" and r.get("asset") not in replaced]
    baselines = [r for r in earlier if r["kind"] != "asset"]
    have = {r["kind"] for r in baselines}
    baselines += [r for r in rows if r["kind"] != "asset" and r["kind"] not in have]
    return kept + new_assets + baselines


def plot(rows, path, phi_us=None):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(10.5, 5))
    markers = {"asset": "o", "lbs": "s", "reference": "D"}
    cycle = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    if len(rows) > len(cycle):      # no two rows in one colour: a 20-colour map
        cycle = [plt.get_cmap("tab20")(i) for i in range(20)]
    for i, r in enumerate(rows):
        # a small horizontal jitter keeps rows of the same step time (the sizes of one network) apart
        x = r["us"] * (1.0 + 0.04 * (i % 5 - 2))
        ax.errorbar(x, r["mean_mm"], yerr=[[r["mean_mm"] - r["lo"]], [r["hi"] - r["mean_mm"]]],
                    fmt=markers.get(r["kind"], "o"), color=cycle[i % len(cycle)], capsize=3, ms=6, zorder=3,
                    label=f"{r['name']}: {r['mean_mm']:.1f} mm, {r['us']:.0f} µs")
    if phi_us:
        ax.axvline(phi_us, color="k", ls=":", lw=1, label=f"Φ, the stage-1 network (torch): {phi_us:.0f} µs, "
                                                          "speed only")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    ax.set_xscale("log")
    ax.set_xlabel("time per frame on one CPU core (µs, log)")
    ax.set_ylabel("mean vertex error vs reference (mm)\n(bars: min–max over clips and bodies)")
    ax.set_title("Error against cost: every method, measured on the same runs")
    ax.set_ylim(0, 1.15 * max(r["hi"] for r in rows))
    finish_figure(fig, path, dpi=90)


def build_parser():
    ap = doc_parser("pleat-methods", __doc__)
    ap.add_argument("--suite", nargs="+", required=True, help="pleat-eval-suite JSON reports")
    ap.add_argument("--rows", default=None, metavar="EARLIER.json",
                    help="start from the rows and Φ time of an earlier --json; the suites add their assets")
    ap.add_argument("--label", action="append", default=[], metavar="ASSET=NAME", help="a row's name (repeatable)")
    ap.add_argument("--no-phi", action="store_true", help="do not time Φ (needs torch)")
    ap.add_argument("--out", required=True, help="output file: the chart (PNG)")
    ap.add_argument("--json", default=None, help="output file: the rows as JSON")
    return add_quiet(ap)


@command("pleat-methods", build_parser)
def main(args):
    rows = rows_from_suites(args.suite, dict(x.split("=", 1) for x in args.label))
    earlier = None
    if args.rows:
        with open(args.rows) as fh:
            earlier = json.load(fh)
        rows = merge_rows(earlier["rows"], rows)
    if args.no_phi:
        phi_us = None
    elif earlier is not None and earlier.get("phi_us"):
        phi_us = earlier["phi_us"]
    else:
        phi_us = 1e6 * phi_seconds_per_frame()
    plot(rows, args.out, phi_us)
    if args.json:
        write_text(args.json, json.dumps({"rows": rows, "phi_us": phi_us}, indent=1))
    for r in rows:
        print(f"{r['name']}: {r['us']:.1f} µs/frame, {r['mean_mm']:.1f} mm ({r['lo']:.1f}–{r['hi']:.1f})")
    if phi_us:
        print(f"Φ (torch, 1 thread): {phi_us:.0f} µs/frame")
    return 0


if __name__ == "__main__":
    sys.exit(main())
