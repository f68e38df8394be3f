"""Assets scored on a set of clips and bodies in one run: the numbers of docs/training.md's recipe table.

    PLEAT_LIBRARY=build/eval/libpleat.so pleat-eval-suite --assets A.pleat [B.pleat ...] \
        [--clips validation | CLIP ...] [--betas 0 | "0;1.5,-1;..."] [--max-frames 60] [--reference-spread] \
        [--reference blender] --out out/suite.json

Every (asset, clip, β) is pleat-eval's `evaluate` (the C runtime against the cached reference simulation, and the
LBS-only twin of the same garment in the same run; `--reference blender`: against Blender's cloth instead of
Pleat's simulator). Per asset it reports the mean over all runs of: mean and p95
vertex error (mm), the ratio to LBS-only (mean of the paired per-run ratios, and ratio of the means), the ratio to
the reference's own spread (with --reference-spread), penetration (% of vertex-frames inside the body; and of points
sampled over the faces, surface_inside_pct, for pleat, LBS-only and the reference) and jitter;
plus the worst run's ratio to LBS-only and every run's row. `regions` holds the same per garment region
(pleat.eval.regions: the dress's skirt, the pants' crotch, ...): the means over runs of pleat's and LBS-only's mean
and p95 error, edge-strain error and penetration, and the ratio of pleat's error to LBS-only's.
"""
import json
import sys

import numpy as np

from pleat.cli import add_quiet, command, doc_parser
from pleat.fileio import write_text


def _betas(text):
    if text is None:
        return [None]
    return [np.array([float(v) for v in part.split(",")]) if part.strip() not in ("", "0") else None
            for part in text.split(";")]


def _clips(names):
    if names == ["validation"]:
        from pleat.motion.split import VALIDATION
        # humanoid3d_stealthy_walk is a 4 s cut of stealthy_walk1 (split.py): scored once, as the long take
        return [n for n in VALIDATION if not n.endswith("humanoid3d_stealthy_walk")]
    return names


def summarise(rows):
    """Aggregate rows of one asset (dicts with pleat / lbs / reference_spread reports)."""
    p = np.array([r["pleat"]["mean_mm"] for r in rows])
    lbs = np.array([r["lbs"]["mean_mm"] for r in rows])
    out = {"runs": len(rows), "mean_mm": float(p.mean()),
           "p95_mm": float(np.mean([r["pleat"]["p95_mm"] for r in rows])),
           "lbs_mean_mm": float(lbs.mean()), "lbs_p95_mm": float(np.mean([r["lbs"]["p95_mm"] for r in rows])),
           "ratio_to_lbs": float(p.mean() / lbs.mean()), "ratio_to_lbs_paired": float(np.mean(p / lbs)),
           "worst_ratio_to_lbs": float(np.max(p / lbs)),
           "clips_worse_than_lbs": [r["clip"] for r in rows if r["pleat"]["mean_mm"] > r["lbs"]["mean_mm"]],
           "penetration_pct": float(np.mean([r["pleat"]["penetration_pct"] for r in rows])),
           "lbs_penetration_pct": float(np.mean([r["lbs"]["penetration_pct"] for r in rows])),
           "reference_penetration_pct": float(np.mean([r["reference"]["penetration"]["penetration_pct"]
                                                      for r in rows])),
           "jitter": float(np.mean([r["pleat"]["jitter"] for r in rows])),
           "lbs_jitter": float(np.mean([r["lbs"]["jitter"] for r in rows])),
           "step_us": float(np.median([r["pleat"]["step_us"] for r in rows]))}
    spread = [r["reference_spread"]["mean_mm"] for r in rows if r.get("reference_spread")]
    if len(spread) == len(rows):
        out["spread_mean_mm"] = float(np.mean(spread))
        out["ratio_to_spread"] = float(p.mean() / np.mean(spread))
    if all(r.get("against_reference_mean") for r in rows):
        pm = np.array([r["against_reference_mean"]["pleat"] for r in rows])
        lm = np.array([r["against_reference_mean"]["lbs"] for r in rows])
        out.update(mean_vs_reference_mean_mm=float(pm.mean()), lbs_vs_reference_mean_mm=float(lm.mean()),
                   ratio_to_lbs_vs_reference_mean=float(pm.mean() / lm.mean()))
    if all((r["pleat"].get("surface_inside") and r["lbs"].get("surface_inside")
            and r["reference"].get("surface_inside")) for r in rows):
        # the faces' share inside the body (pleat.sim.surface), beside the vertices' share above
        for key, who in (("surface_inside_pct", "pleat"), ("lbs_surface_inside_pct", "lbs")):
            out[key] = float(np.mean([r[who]["surface_inside"]["inside_pct"] for r in rows]))
        out["reference_surface_inside_pct"] = float(np.mean([r["reference"]["surface_inside"]["inside_pct"]
                                                             for r in rows]))
    regions = summarise_regions(rows)
    if regions is not None:
        out["regions"] = regions
    return out


REGION_METRICS = ("mean_mm", "p95_mm", "edge_strain_error", "penetration_pct")


def _mean_or_none(values):
    return None if not values or any(v is None for v in values) else float(np.mean(values))


def summarise_regions(rows):
    """{region: means over the runs of pleat's and LBS-only's per-region numbers (lbs_ prefix), ratio_to_lbs (of
    the mean errors) and ratio_to_lbs_paired (mean of the per-run ratios)}, for the regions every run has; None when a
    run has no per-region scores. A number some run could not give (an empty region) is null."""
    if not rows or not all((r.get("pleat") or {}).get("regions") and (r.get("lbs") or {}).get("regions")
                           for r in rows):
        return None
    names = [k for k in rows[0]["pleat"]["regions"] if all(k in r["pleat"]["regions"] for r in rows)]
    out = {}
    for name in names:
        p = [r["pleat"]["regions"][name] for r in rows]
        lbs = [r["lbs"]["regions"][name] for r in rows]
        s = {"vertices": p[0]["vertices"]}
        for m in REGION_METRICS:
            s[m] = _mean_or_none([x.get(m) for x in p])
            s["lbs_" + m] = _mean_or_none([x.get(m) for x in lbs])
        pm, lm = [x["mean_mm"] for x in p], [x["mean_mm"] for x in lbs]
        ok = all(a is not None and b for a, b in zip(pm, lm))
        s["ratio_to_lbs"] = float(np.mean(pm) / np.mean(lm)) if ok else None
        s["ratio_to_lbs_paired"] = float(np.mean(np.divide(pm, lm))) if ok else None
        out[name] = s
    return out


def run(assets, clips, betas, max_frames, reference_spread, progress=False, reference="pleat"):
    from pleat import runtime
    from pleat.eval.cli import evaluate
    result = {}
    ctx = runtime.Context()
    try:
        for asset in assets:
            rows = []
            for clip in clips:
                for beta in betas:
                    rep = evaluate(asset, clip, beta, None, max_frames, context=ctx, progress=progress,
                                   reference_spread=reference_spread, reference=reference)
                    rep.pop("per_frame", None)
                    rows.append(rep)
                    if progress:
                        print(f"{asset} {clip} β={None if beta is None else list(beta)}: "
                              f"pleat {rep['pleat']['mean_mm']:.1f} mm, lbs {rep['lbs']['mean_mm']:.1f} mm",
                              file=sys.stderr)
            result[str(asset)] = {"summary": summarise(rows), "runs": rows}
    finally:
        ctx.close()
    return result


def build_parser():
    ap = doc_parser("pleat-eval-suite", __doc__)
    ap.add_argument("--assets", nargs="+", required=True, help="the .pleat assets to score")
    ap.add_argument("--clips", nargs="+", default=["validation"],
                    help="clip names or files; 'validation' = the held-out split (default)")
    ap.add_argument("--betas", default=None, help="';'-separated β vectors (comma-separated; '0' = the mean body)")
    ap.add_argument("--max-frames", type=int, default=60, help="frames scored per clip (default 60)")
    ap.add_argument("--reference-spread", action="store_true", help="also score a second reference 1 µm apart")
    ap.add_argument("--reference", default="pleat", choices=["pleat", "blender"],
                    help="the reference simulator: Pleat's (default) or Blender's cloth (needs bpy)")
    ap.add_argument("--out", required=True, help="output file: the JSON report")
    return add_quiet(ap)


@command("pleat-eval-suite", build_parser)
def main(args):
    res = run(args.assets, _clips(args.clips), _betas(args.betas), args.max_frames, args.reference_spread,
              progress=not args.quiet, reference=args.reference)
    write_text(args.out, json.dumps(res, indent=1, default=float))
    for asset, r in res.items():
        s = r["summary"]
        print(f"{asset}: {s['mean_mm']:.1f} mm (p95 {s['p95_mm']:.1f}) against LBS-only {s['lbs_mean_mm']:.1f} mm, "
              f"ratio {s['ratio_to_lbs']:.2f}; penetration {s['penetration_pct']:.2f} % "
              f"(LBS {s['lbs_penetration_pct']:.2f} %); worse than LBS on {len(s['clips_worse_than_lbs'])} runs")
        for name, g in s.get("regions", {}).items():
            if name != "all" and g["mean_mm"] is not None and g["lbs_mean_mm"] is not None:
                ratio = "" if g["ratio_to_lbs"] is None else f", ratio {g['ratio_to_lbs']:.2f}"
                print(f"  {name} ({g['vertices']} vertices): {g['mean_mm']:.1f} mm (p95 {g['p95_mm']:.1f}) against "
                      f"LBS-only {g['lbs_mean_mm']:.1f} mm{ratio}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
