"""Error against time per frame for every shipped garment, from pleat-eval-suite reports (docs/pareto.md).

    PLEAT_LIBRARY=build/release/libpleat.so pleat-pareto --suite out/accuracy/suite_tshirt.json \
        out/accuracy/suite_dress.json ... --out docs [--json out/pareto/garments.json]

A panel per garment on one log time axis, with what a user could pick instead of each Pleat asset:

- every asset the reports scored for that garment (its tiers; the paper's two-stage recipe when a report has it);
- its LBS-only twin (the same garment skinned with a zero network), scored in the same runs;
- the reference simulator: its error is its own spread (a second reference started 1 µm away, scored against the
  first: pleat-eval-suite --reference-spread), its time the CPU seconds per frame its simulations took.

Errors are the reports' means over every run (clips × bodies); the bars span one standard deviation of the per-run
means over those runs, so they show how much the error moves from clip to clip and body to body, not a confidence
interval. Step times are measured here as pleat-pareto measures them (`plInstance_Step` alone, interleaved rounds,
the lowest median), so every point of one chart comes from one machine in one run. The reference's time comes from
the report (the machine that simulated it).
"""
import json
from pathlib import Path

import numpy as np

from pleat.eval import scene as S
from pleat.fileio import save_figure, write_text

KIND_STYLE = {   # marker, colour, legend
    "pleat": ("o", "tab:blue", "Pleat asset"),
    "two-stage": ("^", "tab:purple", "the paper's two-stage recipe"),
    "lbs": ("s", "tab:orange", "LBS-only (plain skinning)"),
    "simulator": ("*", "tab:green", "reference simulator (error: its own spread)"),
}


def _spread(values):
    v = np.asarray(values, np.float64)
    return dict(mean_mm=float(v.mean()), sd_mm=float(v.std()), min_mm=float(v.min()), max_mm=float(v.max()),
                runs=int(len(v)))


def _asset_kind(model):
    return "two-stage" if "two-stage" in (model or "") else "pleat"


def points_from_reports(reports):
    """{garment: [point]} from pleat-eval-suite reports ({asset: {"summary", "runs"}} each). A point: name, kind,
    vertices, the per-run error spread (_spread), and for assets and LBS twins the bytes to time."""
    from pleat.eval.front import describe_asset
    garments, seen = {}, set()
    for report in reports:
        for asset, entry in report.items():
            if asset in seen:
                continue
            seen.add(asset)
            runs = entry["runs"]
            data, w = S.read_weights(asset)
            desc = describe_asset(w)
            garment, n = str(w.get("garment_name")), desc["vertices"]
            points = garments.setdefault(garment, [])
            points.append(dict(name=Path(asset).stem, kind=_asset_kind(desc["model"]), asset=asset, vertices=n,
                               model=desc["model"], blob=data, joint_names=w["joint_names"],
                               **_spread([r["pleat"]["mean_mm"] for r in runs])))
            # one LBS-only twin and one simulator point per mesh (a tier on a coarser remesh has its own)
            if any(p["kind"] == "lbs" and p["vertices"] == n for p in points):
                continue
            points.append(dict(name=f"LBS-only, N={n}", kind="lbs", asset=asset, vertices=n, model="lbs-only",
                               blob=S.lbs_only_bytes(w), joint_names=w["joint_names"],
                               **_spread([r["lbs"]["mean_mm"] for r in runs])))
            spread = [r["reference_spread"]["mean_mm"] for r in runs if r.get("reference_spread")]
            cpu_s = [r["reference"]["summary"].get("cpu_seconds_per_frame") for r in runs]
            if len(spread) == len(runs) and all(cpu_s):
                points.append(dict(name=f"reference simulator, N={n}", kind="simulator", asset=None, vertices=n,
                                   model="pleat.sim (implicit Euler, Newton)", step_us=1e6 * float(np.mean(cpu_s)),
                                   **_spread(spread)))
    return garments


def points_from_rows(path, skip):
    """{garment: [point]} from an earlier --json (rows_for_json) for the garments not in `skip`: errors as recorded;
    the bytes to time again where the row's asset is present (an LBS-only row: its asset's twin), else the recorded
    step time, flagged `time_as_recorded`."""
    garments = {}
    for row in json.loads(Path(path).read_text()):
        p = dict(row)
        garment = p.pop("garment")
        if garment in skip:
            continue
        p.pop("time_as_recorded", None)
        if p["kind"] != "simulator":
            if p.get("asset") and Path(p["asset"]).is_file():
                data, w = S.read_weights(p["asset"])
                p.update(blob=S.lbs_only_bytes(w) if p["kind"] == "lbs" else data, joint_names=w["joint_names"])
            else:
                p["time_as_recorded"] = True
        garments.setdefault(garment, []).append(p)
    return garments


def time_points(garments, repeats=5, timing_frames=300):
    """step_us for every point with bytes: `repeats` interleaved rounds of 3 passes, the lowest median kept."""
    from pleat import runtime
    from pleat.body import BodyModel
    from pleat.eval.front import motion_arrays, timing_clip
    from pleat.motion.split import VALIDATION
    from pleat.motion.loaders import resolve_clip
    body = BodyModel.load()
    # the first validation clip this checkout has (a fresh one without GitHub access has only the pybullet clips)
    name = next((n for n in VALIDATION if _present(resolve_clip, n)), VALIDATION[0])
    clip = timing_clip(S.load_motion(name, body, S.EVAL_FPS, None), timing_frames)
    timed = [p for points in garments.values() for p in points if p.get("blob") is not None]
    for p in timed:
        p.pop("step_us", None)      # a kept row's recorded time is measured again
    with runtime.Context() as ctx:
        for _ in range(repeats):
            for p in timed:
                us = S.median_step_us(ctx, p["blob"], *motion_arrays(clip, p["joint_names"]), repeats=3)
                p["step_us"] = min(p.get("step_us", float("inf")), us)
    return name


def _present(resolve_clip, name):
    try:
        resolve_clip(name)
        return True
    except Exception:       # noqa: BLE001 - any failure to find it: not present
        return False


def plot(garments, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from pleat.eval.front import pareto_front
    names = sorted(garments, key=lambda g: (g != "tshirt", g))
    cols = min(3, len(names))
    rows = -(-len(names) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.4 * rows), squeeze=False, sharex=True)
    times = [p["step_us"] for ps in garments.values() for p in ps]
    for ax in axes.flat[len(names):]:
        ax.axis("off")
    for ax, g in zip(axes.flat, names):
        points = garments[g]
        tiers = sorted((p for p in points if p["kind"] == "pleat"), key=lambda p: p["step_us"])
        for p in points:
            marker, colour, _ = KIND_STYLE[p["kind"]]
            ax.errorbar(p["step_us"], p["mean_mm"], yerr=p["sd_mm"], fmt=marker, color=colour, ms=7 if marker != "*"
                        else 11, capsize=3, lw=1, zorder=3)
        if len(tiers) > 1:     # say which tier each point is; tiers of similar error sit side by side, so the
            for k, p in enumerate(tiers):       # labels go alternately above and below their points
                label = "large" if p["name"] == g else p["name"].replace(f"{g}_", "")
                ax.annotate(label, (p["step_us"], p["mean_mm"]), textcoords="offset points", ha="center",
                            xytext=(0, 9 if k % 2 else -14), fontsize=7, color=KIND_STYLE["pleat"][1])
        front = pareto_front([(p["step_us"], p["mean_mm"]) for p in points])
        pts = sorted((points[i]["step_us"], points[i]["mean_mm"]) for i in front)
        ax.step([t for t, _ in pts], [e for _, e in pts], where="post", color="k", lw=0.8, ls="--", zorder=1)
        ax.set_xscale("log")
        ax.set_xlim(0.5 * min(times), 2.0 * max(times))
        ax.set_ylim(0, 1.15 * max(p["mean_mm"] + p["sd_mm"] for p in points))
        n = max(p["vertices"] for p in points)
        ax.set_title(f"{g} ({n} vertices)", fontsize=10)
        ax.grid(True, which="major", lw=0.3, alpha=0.5)
    for ax in axes[-1]:
        ax.set_xlabel("time per frame, one CPU thread (µs, log)")
    for ax in axes[:, 0]:
        ax.set_ylabel("mean vertex error (mm)")
    handles = [plt.Line2D([], [], marker=m, color=c, ls="none", ms=8) for m, c, _ in KIND_STYLE.values()]
    handles.append(plt.Line2D([], [], color="k", lw=0.8, ls="--"))
    labels = [lab for _, _, lab in KIND_STYLE.values()] + ["Pareto front"]
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=8, frameon=False)
    fig.suptitle("Error against time per frame: each garment, and what a user would pick instead "
                 "(bars: ±1 SD over clips × bodies)", fontsize=10)
    fig.tight_layout(rect=(0, 0.12 / rows, 1, 0.97))       # the bottom strip is the shared legend's
    save_figure(fig, path, dpi=90)
    plt.close(fig)


def rows_for_json(garments):
    return [dict(garment=g, **{k: v for k, v in p.items() if k not in ("blob", "joint_names")})
            for g, points in garments.items() for p in points]


def write_markdown(garments, reports, command, library, timing_clip, path, machine=None, image="pareto.png",
                   keep=None):
    from pleat.eval.front import pareto_front
    lines = [
        "# Pareto chart: error against time per frame",
        "",
        f"![error vs time per frame, a panel per garment]({image})",
        "",
        "Made by `pleat-pareto --suite` (tools/pleat/eval/pareto_garments.py) from the pleat-eval-suite reports "
        f"{', '.join(f'`{r}`' for r in reports)}"
        + (f" and, for the garments none of them scored, the rows of `{keep}` (errors as recorded there, step "
           "times measured again in this run where the asset is in the checkout)" if keep else "")
        + ". Error: the mean per-vertex distance to the reference simulation over every run of the report (the "
        "validation clips × the bodies it names, first 60 frames each), ± one standard deviation of the per-run means (clip-to-clip and body-to-body variation, not a confidence "
        "interval). Step time: `plInstance_Step` alone, one thread, the lowest of the medians of 15 passes over 300 "
        f"poses of `{timing_clip}` taken in 5 interleaved rounds, library `{library}`"
        + (f", {machine}" if machine else "") + ". The reference simulator's time is the CPU time per frame its "
        "simulations took (pleat.sim, one thread) and its error its own spread: a second simulation started 1 µm "
        "away, scored against the first — no method's error below it means anything.",
        "",
        "| garment | row | kind | N | time per frame (µs) | mean error (mm) | ± SD (mm) | min–max over runs (mm) | "
        "runs | front |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for g in sorted(garments, key=lambda g: (g != "tshirt", g)):
        points = garments[g]
        front = set(pareto_front([(p["step_us"], p["mean_mm"]) for p in points]))
        for i, p in sorted(enumerate(points), key=lambda ip: ip[1]["step_us"]):
            us = f"{p['step_us']:,.0f}" + (" (as recorded)" if p.get("time_as_recorded") else "")
            lines.append(f"| {g} | {p['name']} | {p['kind']} | {p['vertices']} | {us} | {p['mean_mm']:.1f} | "
                         f"{p['sd_mm']:.1f} | "
                         f"{p['min_mm']:.1f}–{p['max_mm']:.1f} | {p['runs']} | {'★' if i in front else ''} |")
    lines += ["", "## What each row is", "",
              "- `pleat`: a shipped asset (the large tier is `assets/GARMENT.pleat`; `_medium`, `_small`, `_xsmall` "
              "are its cheaper tiers, docs/scene-budget.md).",
              "- `two-stage`: the paper's self-supervised two-stage recipe (stage 1 with physics losses, stage 2 the "
              "latent predictor) on the same garment, when a report scored one.",
              "- `lbs`: the same garment skinned by LBS with a zero network, one per mesh (a tier on a coarser remesh "
              "has its own); what an engine does without Pleat.",
              "- `simulator`: the reference simulator itself, the teacher; ~10⁵ µs per frame.",
              "", "## Remake", "", "```", command, "```", ""]
    write_text(path, "\n".join(lines))


def main(args, argv):
    import os
    import shlex
    from pleat import runtime
    reports = [json.loads(Path(p).read_text()) for p in args.suite]
    garments = points_from_reports(reports)
    if args.keep:
        garments = dict(points_from_rows(args.keep, set(garments)), **garments)
    clip = time_points(garments, repeats=args.repeats)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    plot(garments, out / f"{args.page}.png")
    env = f"PLEAT_LIBRARY={os.environ['PLEAT_LIBRARY']} " if os.environ.get("PLEAT_LIBRARY") else ""
    command = env + "pleat-pareto " + " ".join(shlex.quote(a) for a in argv)
    write_markdown(garments, args.suite, command, str(runtime.find_library()), clip, out / f"{args.page}.md",
                   args.machine, image=f"{args.page}.png", keep=args.keep)
    if args.json:
        write_text(args.json, json.dumps(rows_for_json(garments), indent=1))
    for g, points in garments.items():
        for p in points:
            print(f"{g:12s} {p['name']:32s} {p['step_us']:11.1f} us  {p['mean_mm']:6.2f} ± {p['sd_mm']:5.2f} mm")
    return 0
