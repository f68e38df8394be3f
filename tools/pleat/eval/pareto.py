"""Error against time per frame for garment assets and quality tiers, with the Pareto front (docs/pareto.md).

    PLEAT_LIBRARY=build/eval/libpleat.so python -m pleat.eval.pareto --assets A1.pleat A2.pleat ... \
        --motion CLIP [CLIP ...] --out docs/ [--max-frames 30] [--no-tiers] [--no-error]

For each asset: the median CPU step time (plInstance_Step through pleat.runtime, timed around the C call alone,
single thread) and the mean / p95 vertex error against the reference simulator on the clips (pleat-eval's
`evaluate`, reference cached in out/cache/sim/), plus the LBS-only twin of each asset's garment. For each tier of
`pleat.eval.tiers`: its shipped asset (`Tier.asset`) when it exists and is trained — scored like any asset — else the
step time of that configuration with random weights (golden.random_weights), speed only. Writes OUT/pareto.png and
OUT/pareto.md (table + this command).

With --suite REPORT.json ... the chart is made from pleat-eval-suite reports instead, a panel per garment
(pleat.eval.pareto_garments): that is how docs/pareto.md is made.
"""
import argparse
import json
import os
import shlex
import sys
from pathlib import Path

import numpy as np

from pleat.cli import add_quiet, command
from pleat.eval import scene as S
from pleat.fileio import finish_figure, write_text
from pleat.eval import tiers as tiers_mod
from pleat.eval.front import motion_arrays, timing_clip, describe_asset, pareto_front  # noqa: F401 (importers)


def trained_tier_assets(overrides=None):
    """{tier name: asset path} for the tiers whose shipped asset (or the path in `overrides`) exists and has a trained
    network."""
    from pleat import REPO_ROOT
    out = {}
    overrides = overrides or {}
    for t in tiers_mod.SHIPPED:
        p = Path(overrides[t.name]).resolve() if t.name in overrides else (REPO_ROOT / t.asset if t.asset else None)
        if p is not None and p.is_file() and not S.is_lbs_only(S.read_weights(str(p))[1]):
            p = p.resolve()
            out[t.name] = str(p.relative_to(Path.cwd())) if p.is_relative_to(Path.cwd()) else str(p)
    return out


def measure(assets, motions, max_frames=30, with_tiers=True, with_error=True, timing_frames=300, progress=True,
            speed_assets=(), tier_assets=None, repeats=5):
    from pleat import runtime
    from pleat.body import BodyModel
    from pleat.eval.cli import evaluate
    body = BodyModel.load()
    clips = [S.load_motion(m, body, S.EVAL_FPS, None) for m in motions]
    timing = timing_clip(clips[0], timing_frames)
    rows = []
    tier_of = {}
    if with_tiers:
        found = trained_tier_assets(tier_assets)
        for name, p in found.items():
            tier_of[str(Path(p).resolve())] = name
        assets = list(assets) + [p for p in found.values()
                                 if str(Path(p).resolve()) not in {str(Path(a).resolve()) for a in assets}]
    timed = []     # (row, asset bytes, motion): timed together at the end, in interleaved rounds
    with runtime.Context() as ctx:
        for path in list(assets) + list(speed_assets):
            data, w = S.read_weights(path)
            desc = describe_asset(w)
            tname = tier_of.get(str(Path(path).resolve()))
            base = dict(name=f"tier {tname} ({Path(path).name})" if tname else Path(path).stem, asset=str(path),
                        tier=tname, **desc)
            variants = [("lbs" if S.is_lbs_only(w) else "asset", data)]
            if not S.is_lbs_only(w):
                variants.append(("lbs", S.lbs_only_bytes(w)))
            for kind, blob in variants:
                row = dict(base, kind=kind, garment=str(w.get("garment_name")))
                if kind == "lbs":
                    if any(r["kind"] == "lbs" and r["garment"] == row["garment"]
                           and r["vertices"] == row["vertices"] for r in rows):
                        continue
                    row.update(name=f"LBS-only ({row['garment']}, N={desc['vertices']})", latent=1, blend=1,
                               lp_hidden=[], dec_hidden=[], model="lbs-only", tier=None)
                timed.append((row, blob, motion_arrays(timing, w["joint_names"])))
                if with_error and path not in speed_assets:
                    reps = [evaluate(blob, m, max_frames=max_frames, progress=progress, context=ctx)
                            for m in motions]
                    row["mean_mm"] = float(np.mean([r["pleat"]["mean_mm"] for r in reps]))
                    row["p95_mm"] = float(np.mean([r["pleat"]["p95_mm"] for r in reps]))
                    row["frames"] = int(sum(r["frames"] for r in reps))
                rows.append(row)
        if with_tiers:
            for t in tiers_mod.SHIPPED:
                if any(r.get("tier") == t.name for r in rows):
                    continue
                from pleat.asset import write_asset
                w = tiers_mod.random_tier_weights(t.name)
                blob = write_asset(None, w)
                rows.append(dict(tiers_mod.as_dict(t), name=f"tier {t.name}", kind="tier-random",
                                 macs=t.macs(), model="random weights (untrained): speed only"))
                timed.append((rows[-1], blob, motion_arrays(timing, w["joint_names"])))
        # Step times: `repeats` rounds, each timing every asset for 3 passes, the lowest median kept. Interleaving
        # spreads each asset's passes over the whole measurement, so a burst of another job on the shared machine
        # cannot spoil all of one asset's passes.
        for _ in range(repeats):
            for row, blob, motion in timed:
                us = S.median_step_us(ctx, blob, *motion, repeats=3)
                row["step_us"] = min(row.get("step_us", float("inf")), us)
    return rows, [c.name for c in clips]


def plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7.5, 4.6))
    scored = [r for r in rows if r.get("mean_mm") is not None]
    front = set(pareto_front([(r["step_us"], r["mean_mm"]) for r in scored]))
    for i, r in enumerate(scored):
        marker = "s" if r["kind"] == "lbs" else "o"
        ax.scatter(r["step_us"], r["mean_mm"], marker=marker, s=60, zorder=3,
                   edgecolors="k" if i in front else "none", linewidths=1.5)
        # alternate label heights: rows of similar error (tiers on one mesh) would print on top of each other
        ax.annotate(r["name"], (r["step_us"], r["mean_mm"]), textcoords="offset points",
                    xytext=(-20, 8 + 11 * (i % 3)) if i % 2 else (-20, -14 - 11 * (i % 3)), fontsize=7)
    if front:
        pts = sorted((scored[i]["step_us"], scored[i]["mean_mm"]) for i in front)
        ax.step([p[0] for p in pts], [p[1] for p in pts], where="post", color="k", lw=1, ls="--",
                label="Pareto front (measured error)")
    tier_rows = [r for r in rows if r["kind"] == "tier-random"]
    for r in tier_rows:
        ax.axvline(r["step_us"], color="tab:gray", lw=0.8, ls=":")
        ax.annotate(f"{r['name']}\n(speed only)", (r["step_us"], 0.02), xycoords=("data", "axes fraction"),
                    fontsize=7, rotation=90, va="bottom", ha="right", color="tab:gray")
    ax.set_xscale("log")
    ax.set_xlabel("median CPU step time per frame (µs, log)")
    ax.set_ylabel("mean vertex error vs reference (mm)")
    ax.set_title("Pleat: error vs time per frame")
    if scored:
        ax.set_ylim(0, 1.25 * max(r["mean_mm"] for r in scored))
    if front:
        ax.legend(fontsize=7, loc="upper right")
    finish_figure(fig, path, dpi=90)


def _fmt(v, digits=1):
    return "—" if v is None else f"{v:.{digits}f}"


def write_markdown(rows, clips, command, library, path, max_frames, notes=(), repeats=5, image="pareto.png"):
    scored = [r for r in rows if r.get("mean_mm") is not None]
    front = {id(scored[i]) for i in pareto_front([(r["step_us"], r["mean_mm"]) for r in scored])}
    lines = [
        "# Pareto chart: error against time per frame",
        "",
        f"![error vs step time]({image})",
        "",
        "Made by `python -m pleat.eval.pareto` (tools/pleat/eval/pareto.py). Step time: median of "
        "`plInstance_Step` alone (timed around the C call through `pleat.runtime`, one thread, the first 30 steps "
        f"of each pass dropped), the lowest of the medians of {3 * repeats} passes over 300 poses, taken in "
        f"{repeats} rounds that interleave the assets (the machine is shared; a "
        f"pass slowed by other jobs is rejected that way); library `{library}`. Error: mean and 95th-percentile "
        f"per-vertex distance to the reference simulation (`pleat.sim`, cached in out/cache/sim/) over the first "
        f"{max_frames} frames of {', '.join(f'`{c}`' for c in clips)} at 30 fps, β = 0, the asset's default "
        "material (pleat-eval's numbers, docs/accuracy.md).",
        "",
        "| row | kind | N | L | D | LP hidden | decoder hidden | step (µs) | mean error (mm) | p95 (mm) | front |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append("| {name} | {kind} | {N} | {L} | {D} | {lp} | {dec} | {us} | {mean} | {p95} | {front} |".format(
            name=r["name"], kind=r["model"] if r["kind"] != "tier-random" else "random weights, untrained",
            N=r["vertices"], L=r["latent"], D=r["blend"], lp="×".join(map(str, r["lp_hidden"])) or "—",
            dec="×".join(map(str, r["dec_hidden"])) or "—", us=_fmt(r["step_us"]), mean=_fmt(r.get("mean_mm"), 2),
            p95=_fmt(r.get("p95_mm")), front="★" if id(r) in front else ""))
    tiers = [r for r in rows if r["kind"] == "tier-random" or (r.get("tier") and r["kind"] == "asset")]
    trained = [r for r in tiers if r["kind"] == "asset"]
    if tiers:
        ratio = max(r["step_us"] for r in tiers) / min(r["step_us"] for r in tiers)
        how = ("trained tier assets" if len(trained) == len(tiers) else
               f"{len(trained)} trained tier assets, the others random weights at the tier's sizes")
        lines += ["", f"The {len(tiers)} tiers span **{ratio:.1f}×** in measured step time ({how}; "
                  "`pleat.eval.tiers.SHIPPED`)."]
    lines += ["", "## What each row is", ""]
    lines += ["- Step times are measured, for every row.",
              "- Rows of kind `lbs-only` are the garment skinned by LBS with a zero network: a real baseline (one "
              "per mesh: the tiers on a coarser remesh have their own LBS row and their own reference simulation, "
              "so their error is measured against the reference on *their* mesh)."]
    if trained:
        lines += ["- Rows `tier …` are the shipped tier assets (`Tier.asset`). `large` is the default asset itself; "
                  "the smaller tiers are **distilled from a teacher** named in each asset's META (`teacher`): a "
                  "tier is a smaller inference block trained to reproduce the teacher's garment — the paper's stage 2 "
                  "generalised. For a simulator-supervised `large` the teacher is that model rolled out from a reset "
                  "over its training sequences (`pleat-train simsup-tiers`); for a two-stage one, its stage-1 "
                  "network Φ (`pleat.train.distill`). The tier's D' blend shapes are the top-D' principal "
                  "components of the teacher's per-frame garment displacements (transferred by barycentric "
                  "interpolation for a tier on a coarser remesh), its latent Z' the top-L' principal coefficients, "
                  "f_dec' maps Z' to the D' coefficients and f_LP' is trained on X_c as stage 2 trains f_LP (Z_0 = 0, "
                  "windows fed its own predictions). The teacher also labels training motion nobody simulated "
                  "(`simsup.tier_teacher_frames`), and a tier with `Tier.mean_of` (medium) is the mean of two such "
                  "students at that tier's sizes, packed as one network whose zero blocks the runtime skips."]
    if any(r["kind"] == "tier-random" for r in rows):
        lines += ["- Rows of kind `random weights, untrained` have the tier's sizes but random weights: their speed "
                  "is what a trained tier of that size costs; they have no error."]
    lines += ["- Any asset whose model says `tiny` is a smoke-test network trained for minutes on a 300-vertex "
              "garment: its error is not representative of the method."]
    dist = [r for r in trained if r.get("distillation")]
    if dist:
        lines += ["", "Distillation of each tier (`pleat.train.distill`; RMS per-coordinate displacement error in the "
                  "rest frame against the teacher on held-out validation rollouts, the tier free-running from "
                  "Z'_0 = 0 as the runtime runs it; `zero` = what LBS alone scores against the teacher, `projection` = its "
                  "displacement projected on the tier's blend shapes, the best any f_LP' could do):", "",
                  "| tier | N | PCA energy kept | train frames | RMS vs teacher (mm) | zero (mm) | projection (mm) | "
                  "train time (s) |", "|---|---|---|---|---|---|---|---|"]
        for r in dist:
            d = r["distillation"]
            v = d.get("validation") or d.get("train") or {}
            tier, members = d["tier"], d.get("members") or []
            if members:     # an ensemble (pleat.train.ensemble): its members' fits, the mean not scored here
                tier = f"{tier} (mean of {len(members)} {d['ensemble_of'][0]} fits)"
                d = dict(d, pca_energy=float(np.mean([m["pca_energy"] for m in members])),
                         train_frames=members[0]["train_frames"],
                         train_time_s=sum(m["train_time_s"] for m in members))
            lines.append(f"| {tier} | {d['vertices']} | {100 * d['pca_energy']:.2f} % | {d['train_frames']} | "
                         f"{_fmt(v.get('rms_mm'), 2)} | {_fmt(v.get('rms_zero_mm'), 2)} | "
                         f"{_fmt(v.get('rms_projection_mm'), 2)} | {d['train_time_s']:.0f} |")
    if notes:
        lines += ["", "## Notes", ""] + [f"- {n}" for n in notes]
    lines += ["", "## Remake", "", "```", command, "```", ""]
    made = [r for r in rows if r["kind"] == "lbs" and not str(r.get("asset", "")).startswith("assets/")
            and r.get("asset") and r["model"].startswith("lbs-only")]
    if made:
        lines += ["LBS-only assets outside assets/ are made first with:", "", "```"]
        lines += [f"python -m pleat.garment_asset --garment {r['garment']} --vertices {r['vertices']} --out {r['asset']}"
                  "   # remeshing lands within a few vertices of the request" for r in made]
        lines += ["```", ""]
    write_text(path, "\n".join(lines))


def build_parser():
    ap = argparse.ArgumentParser(prog="pleat-pareto", description=__doc__.split("\n\n")[0])
    ap.add_argument("--assets", nargs="*", default=[], help=".pleat assets (trained tiers, LBS-only, tiny)")
    ap.add_argument("--speed-assets", nargs="*", default=[],
                    help="assets timed but not scored (their reference would take too long here)")
    ap.add_argument("--motion", nargs="+", default=["deepmimic_pybullet/humanoid3d_punch"],
                    help="validation clips (pleat.motion.split.VALIDATION)")
    ap.add_argument("--out", default="docs", help="output folder (pareto.png, pareto.md)")
    ap.add_argument("--max-frames", type=int, default=30, help="frames per clip scored against the reference")
    ap.add_argument("--no-tiers", action="store_true", help="skip the tiers (their assets and random-weight timings)")
    ap.add_argument("--tier-asset", nargs="*", default=[], metavar="NAME=PATH",
                    help="use PATH as tier NAME's asset instead of Tier.asset (e.g. a candidate not yet shipped)")
    ap.add_argument("--no-error", action="store_true", help="times only (no reference simulation)")
    ap.add_argument("--json", default=None, help="also write the rows to this JSON file")
    ap.add_argument("--repeats", type=int, default=5, help="timing rounds (3 passes per asset each; the lowest median is kept)")
    ap.add_argument("--note", action="append", default=[], help="a line for the page's Notes section (repeatable)")
    ap.add_argument("--suite", nargs="+", default=None, metavar="REPORT.json",
                    help="chart every garment from pleat-eval-suite reports instead (a panel per garment, with "
                         "LBS-only, the reference simulator and error bars over clips and bodies; "
                         "pleat.eval.pareto_garments); --assets, --motion and the tier options are then unused")
    ap.add_argument("--machine", default=None, help="with --suite: the machine the times were taken on, for the page")
    ap.add_argument("--keep", default=None, metavar="ROWS.json",
                    help="with --suite: the garments none of the reports scored come from this earlier --json "
                         "(their errors as recorded; their step times measured again where the asset is present)")
    ap.add_argument("--page", default="pareto", help="file name (no extension) of the page and chart in --out "
                                                     "(default pareto: pareto.md, pareto.png)")
    return add_quiet(ap)


@command("pleat-pareto")
def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)     # the page quotes the command line
    args = build_parser().parse_args(argv)
    if args.suite:
        from pleat.eval import pareto_garments
        return pareto_garments.main(args, argv)
    from pleat import runtime
    from pleat.motion.split import VALIDATION
    for m in args.motion:
        if m not in VALIDATION:
            print(f"note: {m} is not a validation clip (pleat.motion.split.VALIDATION)", file=sys.stderr)
    rows, clips = measure(args.assets, args.motion, args.max_frames, not args.no_tiers, not args.no_error,
                          progress=not args.quiet, speed_assets=args.speed_assets,
                          tier_assets=dict(a.split("=", 1) for a in args.tier_asset), repeats=args.repeats)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    plot(rows, out / f"{args.page}.png")
    lib = str(runtime.find_library())
    env = f"PLEAT_LIBRARY={os.environ['PLEAT_LIBRARY']} " if os.environ.get("PLEAT_LIBRARY") else ""
    cmdline = env + "pleat-pareto " + " ".join(shlex.quote(a) for a in argv)
    write_markdown(rows, clips, cmdline, lib, out / f"{args.page}.md", args.max_frames, args.note, args.repeats,
                   image=f"{args.page}.png")
    if args.json:
        write_text(args.json, json.dumps(rows, indent=1))
    for r in rows:
        print(f"{r['name']:40s} {r['step_us']:9.1f} us  {_fmt(r.get('mean_mm'), 2):>7s} mm")
    return 0


if __name__ == "__main__":
    sys.exit(main())
