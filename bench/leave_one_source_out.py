"""Leave one source out: how much accuracy a model keeps on motion from a capture source it never trained on
(docs/probes.md, "Leave one source out").

    PYTHONPATH=tools .venv/bin/python bench/leave_one_source_out.py --data EXPORT.npz --out DIR [--minutes 12] \
        [--sources deepmimic_github deepmimic_pybullet] [--garment tshirt] [--set KEY=VALUE ...] \
        [--size-controls] [--reuse NAME=RUN_DIR] [--json bench/results/leave-one-source-out.json] \
        [--page docs/probes.md]

From one exported simulated dataset (`pleat-train simsup ... --export EXPORT.npz`), the recipe's fit is run once on
every source ("all") and once without each source's training clips (`simsup.exclude_sources`), each with the same
fitting budget (`--max-minutes`, then the contact step's 1,500 iterations without a budget), so that the only
difference is the motion left out. Every model is scored on all the validation clips (β = 0, the default material,
posed error of the model free-running from a reset against the simulator, what the run's verdict prints), and the
validation clips are grouped by their source: a row per (model, source) with the mean error, LBS-only's on the same
clips and their ratio. A source's row under "without it" against its row under "all" is what leaving it out costs.
`--size-controls` adds, for each model that left a source out, a model of every source on as many segments (N of
the export's, evenly spaced, so every clip keeps its share), so that the cost of leaving a source out is not
confused with the cost of less data. `--reuse NAME=DIR` takes a finished run folder instead of training that model.
"""
import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SOURCES = ("deepmimic_github", "deepmimic_pybullet")


def train(name, run_dir, args, leave_out, segments=0):
    """The recipe's fit from the export without `leave_out`'s clips (and on `segments` of its segments, evenly
    spaced; 0: all), then its contact step."""
    bin_dir = Path(sys.executable).parent
    sets = [f"simsup.exclude_sources={json.dumps(list(leave_out))}", f"simsup.data_segments={segments}",
            "simsup.contact_iterations=0", *args.set]
    cmd = [str(bin_dir / "pleat-train"), "simsup", "--preset", "default", "--garment", args.garment, "--out",
           str(run_dir), "--max-minutes", str(args.minutes), "--workers", "2", "--data", args.data]
    for s in sets:
        cmd += ["--set", s]
    t0 = time.time()
    subprocess.run(cmd, check=True)
    subprocess.run([str(bin_dir / "pleat-train"), "simsup-contact", "--out", str(run_dir), "--data", args.data],
                   check=True)
    print(f"{name}: {time.time() - t0:.0f} s", file=sys.stderr)


def rows(name, run_dir):
    summary = json.loads((Path(run_dir) / "simsup_summary.json").read_text())
    by_source = {}
    for v in summary["validation"]:
        by_source.setdefault(v["clip"].split("/")[0], []).append(v)
    out = []
    for source, clips in sorted(by_source.items()):
        pleat = sum(c["pleat_mm"] for c in clips) / len(clips)
        lbs = sum(c["lbs_mm"] for c in clips) / len(clips)
        out.append({"model": name, "source": source, "clips": [c["clip"] for c in clips], "pleat_mm": pleat,
                    "lbs_mm": lbs, "ratio_to_lbs": pleat / lbs,
                    "ratio_to_lbs_paired": sum(c["pleat_mm"] / c["lbs_mm"] for c in clips) / len(clips),
                    "training_frames": summary["frames"], "run": str(run_dir)})
    return out


def table(result):
    lines = ["| model | validation clips from | clips | mean error (mm) | LBS-only (mm) | × LBS-only (paired) | "
             "training frames |", "|---|---|---|---|---|---|---|"]
    for r in result["rows"]:
        if r["model"].startswith("all"):
            model = "every source" + (f", {r['model'][4:]} segments" if "@" in r["model"] else "")
        else:
            model = "without " + r["model"].split(":", 1)[1]
        held_out = r["model"] == f"without:{r['source']}"
        src = f"**{r['source']}** (never trained on)" if held_out else r["source"]
        lines.append(f"| {model} | {src} | {len(r['clips'])} | {r['pleat_mm']:.1f} | {r['lbs_mm']:.1f} | "
                     f"{r['ratio_to_lbs']:.2f} ({r['ratio_to_lbs_paired']:.2f}) | {r['training_frames']:,} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, help="the exported simulated dataset (pleat-train simsup --export)")
    ap.add_argument("--out", required=True, help="folder for the run folders")
    ap.add_argument("--minutes", type=float, default=12.0, help="--max-minutes of each fit")
    ap.add_argument("--sources", nargs="+", default=list(SOURCES), help="the sources left out in turn")
    ap.add_argument("--garment", default="tshirt")
    ap.add_argument("--set", action="append", default=[], help="more --set for every fit")
    ap.add_argument("--reuse", action="append", default=[], metavar="NAME=DIR",
                    help="a finished run for NAME (all, without:SOURCE, all@SEGMENTS)")
    ap.add_argument("--size-controls", action="store_true",
                    help="also fit every source on as many segments as each model that left one out (all@N: N "
                         "segments of the export, evenly spaced), so that leaving a source out is not confused with "
                         "less data")
    ap.add_argument("--json", default=None, help="write the result here too")
    ap.add_argument("--page", default=None,
                    help="write the table into this page, between its loso:begin and loso:end markers")
    args = ap.parse_args(argv)
    reuse = dict(r.split("=", 1) for r in args.reuse)
    models = [("all", ())] + [(f"without:{s}", (s,)) for s in args.sources]
    result = {"about": "leave one source out (bench/leave_one_source_out.py): validation error per source of the "
                       "validation clips, for models fitted on every source and without each",
              "command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]]) if argv is None else None,
              "data": args.data, "minutes": args.minutes, "sets": args.set, "rows": []}
    for name, leave_out in models:
        run_dir = Path(reuse.get(name) or Path(args.out) / name.replace(":", "_"))
        if name not in reuse:
            train(name, run_dir, args, leave_out)
        result["rows"] += rows(name, run_dir)
    if args.size_controls:     # every source, on as many segments as each model that left one out
        for name, _ in models[1:]:
            count = json.loads((Path(reuse.get(name) or Path(args.out) / name.replace(":", "_")) /
                                "simsup_summary.json").read_text())["segments"]
            control = f"all@{count}"
            run_dir = Path(reuse.get(control) or Path(args.out) / control.replace("@", "_"))
            if control not in reuse:
                train(control, run_dir, args, (), count)
            result["rows"] += rows(control, run_dir)
    print(table(result))
    sys.path.insert(0, str(ROOT / "tools"))
    from pleat.fileio import write_text
    if args.json:
        write_text(args.json, json.dumps(result, indent=1) + "\n")
    if args.page:
        write_text(args.page, with_table(Path(args.page).read_text(), result))
    return 0


BEGIN = "<!-- loso:begin (written by bench/leave_one_source_out.py --page; do not edit by hand) -->"
END = "<!-- loso:end -->"


def with_table(page, result):
    """`page` with the table between BEGIN and END (both must be there)."""
    head, sep, rest = page.partition(BEGIN)
    _, sep2, tail = rest.partition(END)
    if not sep or not sep2:
        raise SystemExit(f"the page has no {BEGIN} ... {END} block")
    return f"{head}{BEGIN}\n{table(result)}\n{END}{tail}"


if __name__ == "__main__":
    sys.exit(main())
