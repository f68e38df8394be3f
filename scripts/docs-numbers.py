#!/usr/bin/env python3
"""Write the numbers blocks of README.md and docs/accuracy.md from measured JSON, so that no figure on the front
page or in the accuracy tables is typed by hand.

    scripts/docs-numbers.py                      # rewrite both blocks from the committed JSON
    scripts/docs-numbers.py --check              # exit 1 if a block is not what the JSON gives
    scripts/docs-numbers.py --print              # print README.md's block
    scripts/docs-numbers.py --bench out/bench/step.json --print   # the block for your own scripts/bench.sh run
    scripts/docs-numbers.py --garments-from SUITE.json [SUITE2.json ...] [--machine "CPU, cores"]
                                                 # bench/results/accuracy-garments.json from pleat-eval-suite
                                                 # reports, then the blocks
    scripts/docs-numbers.py --surface-from out/ref/*/summary.json
                                                 # bench/results/reference-surface.json from pleat-sim summaries
                                                 # (docs/garments.md's table), then the blocks
    scripts/docs-numbers.py --wardrobe-from SERIAL/wardrobe.json RAY/wardrobe.json
                                                 # bench/results/wardrobe.json from pleat-wardrobe reports
                                                 # (docs/training-speed.md's table), then the blocks
    scripts/docs-numbers.py --teachers-from SUITE_PLEAT.json SUITE_BLENDER.json
                                                 # bench/results/accuracy-teachers.json from pleat-eval-suite
                                                 # reports against each teacher (docs/accuracy.md, "A second
                                                 # teacher"), then the blocks

Inputs: bench/results/cpu-reference.json (step times, keys as in out/bench/step.json, plus a "machine" object
naming the CPU, the kernels chosen and the load), bench/results/accuracy-reference.json (errors against the
reference simulator, README.md's accuracy paragraph) and bench/results/accuracy-garments.json (a row per garment and
tier: a trimmed pleat-eval-suite summary, docs/accuracy.md's tables; format in garments_from_suites). Each block
sits between its markers (BEGIN / END, GARMENTS_BEGIN / GARMENTS_END below); everything outside them is left alone.
tests/python/test_docs_numbers.py fails when a page and the committed JSON disagree.
"""
import argparse
import json
import os
import platform
import shlex
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BENCH_JSON = ROOT / "bench" / "results" / "cpu-reference.json"
ACCURACY_JSON = ROOT / "bench" / "results" / "accuracy-reference.json"
GARMENTS_JSON = ROOT / "bench" / "results" / "accuracy-garments.json"
README = ROOT / "README.md"
ACCURACY_PAGE = ROOT / "docs" / "accuracy.md"
BEGIN = "<!-- numbers:begin (written by scripts/docs-numbers.py from bench/results/*.json; do not edit by hand) -->"
END = "<!-- numbers:end -->"
GARMENTS_BEGIN = ("<!-- garments:begin (written by scripts/docs-numbers.py from bench/results/accuracy-garments.json; "
                  "do not edit by hand) -->")
GARMENTS_END = "<!-- garments:end -->"
SURFACE_JSON = ROOT / "bench" / "results" / "reference-surface.json"
GARMENTS_PAGE = ROOT / "docs" / "garments.md"
SURFACE_BEGIN = ("<!-- surface:begin (written by scripts/docs-numbers.py from bench/results/reference-surface.json; "
                 "do not edit by hand) -->")
SURFACE_END = "<!-- surface:end -->"
WARDROBE_JSON = ROOT / "bench" / "results" / "wardrobe.json"
TRAINING_PAGE = ROOT / "docs" / "training-speed.md"
WARDROBE_BEGIN = ("<!-- wardrobe:begin (written by scripts/docs-numbers.py from bench/results/wardrobe.json; "
                  "do not edit by hand) -->")
WARDROBE_END = "<!-- wardrobe:end -->"
TEACHERS_JSON = ROOT / "bench" / "results" / "accuracy-teachers.json"
TEACHERS_BEGIN = ("<!-- teachers:begin (written by scripts/docs-numbers.py from bench/results/accuracy-teachers.json; "
                  "do not edit by hand) -->")
TEACHERS_END = "<!-- teachers:end -->"
INT8_JSON = ROOT / "bench" / "results" / "int8-accuracy.json"
PERFORMANCE_PAGE = ROOT / "docs" / "performance.md"
INT8_BEGIN = ("<!-- int8:begin (written by scripts/docs-numbers.py from bench/results/int8-accuracy.json; "
              "do not edit by hand) -->")
INT8_END = "<!-- int8:end -->"
INT8_BENCH_JSON = ROOT / "bench" / "results" / "cpu-int8.json"
INT8_SPEED_BEGIN = ("<!-- int8-speed:begin (written by scripts/docs-numbers.py from bench/results/cpu-int8.json; "
                    "do not edit by hand) -->")
INT8_SPEED_END = "<!-- int8-speed:end -->"


def _num(value, digits=1):
    """A scalar as text, or a [low, high] range over runs as 'low–high'."""
    if isinstance(value, (list, tuple)):
        lo, hi = value
        return f"{_num(lo, digits)}–{_num(hi, digits)}"
    if isinstance(value, float):
        text = f"{value:.{digits}f}"
        return text
    return str(value)


def _machine_line(bench):
    m = bench.get("machine") or {}
    cpu = m.get("cpu", "CPU not recorded in the JSON")
    isa = m.get("isa", bench.get("isa", "ISA not recorded"))
    load = m.get("load", "not recorded")
    date = m.get("date")
    batch = m.get("batch_isa")
    parts = [cpu, f"single-step kernels {isa}"]
    if batch:
        parts.append(f"crowd batches {batch}")
    parts.append(f"load average {load}")
    if date:
        parts.append(date)
    return "; ".join(parts)


def render(bench, accuracy):
    """The README block (without the markers) for one benchmark JSON and one accuracy JSON."""
    m = bench.get("machine") or {}
    machine = _machine_line(bench)
    lines = [f"Measured on: {machine}."]
    crowd = bench.get("crowd") or {}
    by_asset = {r["asset"]: r for r in crowd.get("results", []) if "single_step_us" in r}
    tshirt = by_asset.get("tshirt_fp16")
    if tshirt:
        lines += [
            "",
            f"- **The shipped t-shirt** (`assets/tshirt.pleat`, 1,004 vertices, fp16, full body contact): "
            f"**{_num(tshirt['single_step_us'])} µs** a step on one thread "
            f"({m.get('cpu', 'CPU not recorded')}, {m.get('isa', 'ISA not recorded')}, "
            f"load {crowd.get('load', m.get('load', 'not recorded'))}).",
        ]
    tiers = bench.get("tier_step_us")
    if tiers:
        lines.append(
            f"- Its four tiers, large / medium / small / xsmall: {_num(tiers['large'])} / {_num(tiers['medium'])} / "
            f"{_num(tiers['small'])} / {_num(tiers['xsmall'])} µs a step, one thread "
            f"({m.get('cpu', 'CPU not recorded')}, {m.get('isa', 'ISA not recorded')}; "
            f"{tiers.get('tool', 'tool not recorded')}).")
    ref = bench.get("reference_sizes", "the reference sizes of bench/make_assets.py")
    lines.append(
        f"- **The reference sizes** that `scripts/bench.sh` measures ({ref}): `pleat_step_us` "
        f"{_num(bench['pleat_step_us'])} µs on one thread, `pleat_step_fp16_us` {_num(bench['pleat_step_fp16_us'])} µs, "
        f"`pleat_step_2workers_us` {_num(bench['pleat_step_2workers_us'])} µs on two cores through the host's task hooks "
        f"({m.get('cpu', 'CPU not recorded')}, {m.get('isa', 'ISA not recorded')}, load {m.get('load', 'not recorded')}); "
        f"the bare streaming read of the weights alone, `stream_floor_us`, {_num(bench['stream_floor_us'])} µs.")
    lines.append(
        f"- **Against ONNX Runtime** on the same two networks and weights (fp32, one thread): Pleat "
        f"{_num(bench['pleat_mlp_us'])} µs, ONNX Runtime {_num(bench['ort_mlp_us'])} µs, "
        f"`mlp_speedup` **{_num(bench['mlp_speedup'], 2)}×** ({m.get('cpu', 'CPU not recorded')}, "
        f"{m.get('isa', 'ISA not recorded')}, load {m.get('load', 'not recorded')}).")
    if by_asset:
        rows = []
        for name, label in (("tshirt_fp16", "t-shirt fp16"), ("tshirt_fp32", "t-shirt fp32"),
                             ("reference_fp16", "reference fp16"), ("reference_fp32", "reference fp32")):
            r = by_asset.get(name)
            if r:
                ratio = r["batch_vs_single_step_1_worker"]
                rows.append(f"{label} {_num(ratio['1'], 3)}× / {_num(ratio['2'], 3)}×")
        lines.append(
            f"- **Crowds** (`plStepInstances`, {crowd.get('instances', 64)} instances, per instance against the "
            f"one-thread single step, one / two workers, medians of {crowd.get('rounds', '?')} rounds, "
            f"{m.get('cpu', 'CPU not recorded')}, {m.get('isa', 'ISA not recorded')} single steps, crowd batches "
            f"{m.get('batch_isa', 'ISA not recorded')}, load {crowd.get('load', 'not recorded')}, bit-identical to "
            f"stepping one by one): " + "; ".join(rows) + ".")
    lines += [
        "",
        "**Comparing your machine:** run `scripts/bench.sh` and compare the ratios in `out/bench/step.json` "
        "(`mlp_speedup`, `pleat_step_fp16_us` ÷ `pleat_step_us`, the crowd's `batch_vs_single_step_1_worker`), not "
        "the µs: a step streams megabytes of weights, so its time follows the memory system, the clock and the "
        "machine's load, and `bench.sh` times the 4,424-vertex reference sizes, not the 1,004-vertex t-shirt "
        "(docs/benchmarks.md, \"Comparing machines\").",
    ]
    b0 = accuracy["beta0"]
    two = accuracy["two_bodies"]
    tiers_mm = accuracy.get("tiers_beta0_mm", {})
    lines += [
        "",
        f"**Accuracy** against the reference simulator ({accuracy['validation_clips']} held-out validation clips, "
        f"{accuracy['frames_per_clip']} frames each, the C runtime; `{accuracy['tool']}`): "
        f"at β = 0 **{_num(b0['pleat_mm'])} mm** mean error against {_num(b0['lbs_mm'])} mm for LBS-only "
        f"({_num(b0['ratio'], 2)}×, worst clip {_num(b0['worst_clip_ratio'], 2)}×); over two bodies "
        f"({two['runs']} runs) {_num(two['pleat_mm'])} mm against {_num(two['lbs_mm'])} mm "
        f"({_num(two['paired_ratio'], 2)}× paired), {_num(two['penetration_pct'], 2)} % of vertex-frames inside the "
        f"body (LBS-only {_num(two['lbs_penetration_pct'], 2)} %, the simulator itself "
        f"{_num(two['reference_penetration_pct'], 2)} %). Two equally valid simulations differ by "
        f"{_num(accuracy['reference_spread_mm'])} mm on the same clips.",
    ]
    if tiers_mm:
        xs = accuracy.get("xsmall")
        text = (f"The tiers at β = 0: large {_num(tiers_mm['large'], 2)}, medium {_num(tiers_mm['medium'], 2)}, "
                f"small {_num(tiers_mm['small'], 2)} mm")
        if xs:
            text += f"; xsmall {_num(xs['pleat_mm'])} mm against {_num(xs['lbs_mm'])} for LBS-only ({xs['note']})"
        lines.append(text + " (docs/accuracy.md, docs/tiers.md).")
    return "\n".join(lines) + "\n"


def splice(readme_text, block, begin=BEGIN, end_marker=END, page="README.md"):
    """The page's text with the block between the markers replaced; ValueError when the markers are missing."""
    start = readme_text.find(begin)
    end = readme_text.find(end_marker)
    if start < 0 or end < 0 or end < start:
        raise ValueError(f"{page} has no numbers block (the line {begin!r} ... {end_marker!r})")
    return readme_text[:start] + begin + "\n" + block + readme_text[end:]


def load(bench_path=BENCH_JSON, accuracy_path=ACCURACY_JSON):
    return json.loads(Path(bench_path).read_text()), json.loads(Path(accuracy_path).read_text())


def load_garments(path=GARMENTS_JSON):
    return json.loads(Path(path).read_text())


# --- docs/accuracy.md: a row per garment and tier -------------------------------------------------------------------

TIER_ORDER = ("large", "medium", "small", "xsmall")
# the pleat-eval-suite summary keys a row keeps, as the suite names them (pleat.eval.suite.summarise)
SUMMARY_KEYS = ("runs", "mean_mm", "p95_mm", "lbs_mean_mm", "ratio_to_lbs", "ratio_to_lbs_paired",
                "worst_ratio_to_lbs", "clips_worse_than_lbs", "spread_mean_mm", "ratio_to_spread",
                "penetration_pct", "lbs_penetration_pct", "reference_penetration_pct", "step_us")
REGION_KEYS = ("vertices", "mean_mm", "p95_mm", "lbs_mean_mm", "ratio_to_lbs", "ratio_to_lbs_paired",
               "edge_strain_error", "lbs_edge_strain_error", "penetration_pct", "lbs_penetration_pct")


def _rounded(value, digits=4):
    return round(float(value), digits) if isinstance(value, float) else value


def _meta_of(asset_path):
    """The META JSON of a packed asset as a dict, or {} when the file cannot be read (the suite's report then names
    the garment, and the file name the tier)."""
    for base in (Path.cwd(), ROOT):
        path = base / asset_path
        if path.is_file():
            break
    else:
        return {}
    try:
        sys.path.insert(0, str(ROOT / "tools"))
        from pleat.asset import read_asset
        meta = read_asset(path.read_bytes()).get("metadata_json")
    except Exception:   # noqa: BLE001 - an unreadable asset falls back to the report's fields
        return {}
    finally:
        sys.path.remove(str(ROOT / "tools"))
    if isinstance(meta, (bytes, str)):
        try:
            meta = json.loads(meta)
        except ValueError:
            return {}
    return meta if isinstance(meta, dict) else {}


def _tier_from_name(stem, garment):
    """The tier a file name says: GARMENT.pleat is the top tier, GARMENT_TIER.pleat the cheaper ones."""
    if garment and stem.startswith(garment + "_") and stem[len(garment) + 1:] in TIER_ORDER:
        return stem[len(garment) + 1:]
    for t in TIER_ORDER:
        if stem.endswith("_" + t):
            return t
    return "large"


def _suite_command(report):
    """The pleat-eval-suite command a report came from, rebuilt from its runs (the report does not store it)."""
    runs = [r for a in report.values() for r in a.get("runs", [])]
    parts = ["PLEAT_LIBRARY=build/eval/libpleat.so", "pleat-eval-suite", "--assets", *report.keys()]
    clips = list(dict.fromkeys(r["clip"] for r in runs))
    try:
        sys.path.insert(0, str(ROOT / "tools"))
        from pleat.eval.suite import _clips
        validation = _clips(["validation"])
    except Exception:   # noqa: BLE001 - without the package the clips are named one by one
        validation = None
    finally:
        sys.path.remove(str(ROOT / "tools"))
    if clips and clips != validation:
        parts += ["--clips", *clips]
    betas = []
    for r in runs:
        b = [float(v) for v in r.get("beta") or []]
        while b and b[-1] == 0.0:
            b.pop()
        text = ",".join(f"{v:g}" for v in b) or "0"
        if text not in betas:
            betas.append(text)
    if betas != ["0"]:
        parts += ["--betas", ";".join(betas)]
    frames = max((int(r.get("frames", 0)) for r in runs), default=60)
    if frames != 60:
        parts += ["--max-frames", str(frames)]
    if runs and all(r.get("reference_spread") for r in runs):
        parts.append("--reference-spread")
    teacher = _reference_teacher(runs)
    if teacher != "pleat":
        parts += ["--reference", teacher]
    parts += ["--out", "SUITE.json"]
    return " ".join(p if p.startswith("PLEAT_LIBRARY=") else shlex.quote(p) for p in parts)


def _reference_teacher(runs):
    """The simulator a suite's runs were scored against (pleat-eval --reference; "pleat" in reports without it)."""
    teachers = {(r.get("reference") or {}).get("teacher") or "pleat" for r in runs} or {"pleat"}
    if len(teachers) != 1:
        raise ValueError(f"one suite scored against several references: {sorted(teachers)}")
    return teachers.pop()


def this_machine():
    """'CPU model, N logical CPUs' of the machine this runs on (what a suite's step times were measured on when it
    ran here; --machine says otherwise)."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} logical CPUs"


def garment_row(asset, summary, runs, command, machine, meta=None):
    """One row of accuracy-garments.json from one asset of a pleat-eval-suite report."""
    meta = _meta_of(asset) if meta is None else meta
    garment = meta.get("garment") or next((r.get("garment") for r in runs if r.get("garment")), None)
    stem = Path(asset).stem
    garment = garment if garment and garment != "None" else stem.split("_")[0]
    tier = meta.get("tier") or _tier_from_name(stem, garment)
    training = meta.get("training") if isinstance(meta.get("training"), dict) else {}
    row = {"garment": garment, "tier": tier, "asset": str(asset),
           "vertices": meta.get("vertices") or next((r.get("vertices") for r in runs if r.get("vertices")), None),
           "clips": len({r["clip"] for r in runs}) if runs else None,
           "betas": len({json.dumps(r.get("beta")) for r in runs}) if runs else None}
    for k in SUMMARY_KEYS:
        row[k] = _rounded(summary.get(k))
    everything = (summary.get("regions") or {}).get("all") or {}
    row["edge_strain_error"] = _rounded(everything.get("edge_strain_error"), 5)
    row["lbs_edge_strain_error"] = _rounded(everything.get("lbs_edge_strain_error"), 5)
    row["step_machine"] = machine
    row["training_cpu_hours"] = _rounded(training.get("cpu_hours"), 2)
    row["simulation_cpu_hours"] = _rounded(training.get("simulation_cpu_h"), 2)
    distillation = meta.get("distillation") if isinstance(meta.get("distillation"), dict) else {}
    if row["training_cpu_hours"] is None and distillation.get("fit_wall_s"):
        # a distilled tier: its fit ran on one thread; the model it learnt from cost the large row's hours
        row["training_cpu_hours"] = _rounded(float(distillation["fit_wall_s"]) / 3600.0, 2)
        row["distilled"] = True
    row["regions"] = {name: {k: _rounded(g.get(k), 5 if "strain" in k else 4) for k in REGION_KEYS}
                      for name, g in (summary.get("regions") or {}).items() if name != "all"}
    row["command"] = command
    return row


def _row_order(row):
    tier = row["tier"]
    return (row["garment"], TIER_ORDER.index(tier) if tier in TIER_ORDER else len(TIER_ORDER), tier)


def garments_from_suites(paths, machine=None, metas=None):
    """accuracy-garments.json from pleat-eval-suite reports: {"about", "rows"}, a row per asset (a later report's
    row replaces an earlier one of the same garment and tier), sorted by garment and tier. A row holds the garment,
    tier, asset, vertices, the numbers of clips and bodies, the suite summary's SUMMARY_KEYS (null where the suite
    gave none, e.g. the spread without --reference-spread), the "all" region's edge-strain errors, the machine of
    step_us, the training CPU-hours from the asset's META (training.cpu_hours, simulation included, and
    training.simulation_cpu_h; null where META does not record them), every other region's REGION_KEYS and the
    suite command. metas: {asset: META dict} instead of reading the asset files (tests)."""
    machine = machine or this_machine()
    rows = {}
    for path in paths:
        report = json.loads(Path(path).read_text())
        command = _suite_command(report)
        for asset, result in report.items():
            meta = (metas or {}).get(asset)
            row = garment_row(asset, result["summary"], result.get("runs", []), command, machine, meta)
            rows[(row["garment"], row["tier"])] = row
    return {"about": ("Accuracy of the shipped garments against the reference simulator, a row per garment and "
                      "tier: pleat-eval-suite's summary, trimmed (scripts/docs-numbers.py --garments-from writes "
                      "it, and docs/accuracy.md's tables from it). mm = mean posed vertex distance; ratios are "
                      "Pleat's error over LBS-only's (paired: the mean of per-run ratios); penetration = % of "
                      "vertex-frames inside the posed body; step_us = median plInstance_Step of the suite (one "
                      "thread, through ctypes) on step_machine; training_cpu_hours from the asset's META, "
                      "simulation included."),
            "rows": sorted(rows.values(), key=_row_order)}


def merged(old, new):
    """new's rows, plus old's rows of the (garment, tier) pairs new has none of: a suite of one garment refreshes its
    rows and leaves the other garments' as they were measured."""
    have = {(r["garment"], r["tier"]) for r in new["rows"]}
    rows = new["rows"] + [r for r in old["rows"] if (r["garment"], r["tier"]) not in have]
    return dict(new, rows=sorted(rows, key=_row_order))


def _cell(value, digits=1, suffix=""):
    if value is None:
        return "—"
    if digits == 0:
        return f"{int(round(float(value))):,}{suffix}"
    return f"{_num(float(value), digits)}{suffix}"


def render_garments(garments):
    """docs/accuracy.md's block (without the markers): the table of garments and tiers, then their regions."""
    rows = garments["rows"]
    machines = list(dict.fromkeys(r.get("step_machine") for r in rows if r.get("step_us") is not None))
    one_machine = len(machines) == 1
    lines = ["| garment | tier | vertices | runs | mean / p95 (mm) | × LBS-only (paired; worst run) | "
             "× reference spread (spread mm) | inside the body %: Pleat / LBS-only / reference | "
             "edge-strain error: Pleat / LBS-only | step (µs) | training CPU-hours |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        step = _cell(r.get("step_us"))
        if r.get("step_us") is not None and not one_machine:
            step += f" ({r.get('step_machine')})"
        cpu = _cell(r.get("training_cpu_hours"), 2)
        if r.get("simulation_cpu_hours") is not None:
            cpu += f" ({_num(float(r['simulation_cpu_hours']), 2)} of them simulating)"
        elif r.get("distilled"):
            cpu += " (its distillation, from the large asset)"
        worse = r.get("clips_worse_than_lbs")
        worst = _cell(r.get("worst_ratio_to_lbs"), 2)
        if worse:
            worst += f", {len(worse)} worse than LBS-only"
        lines.append(
            f"| {r['garment']} | {r['tier']} | {_cell(r.get('vertices'), 0)} | {_cell(r.get('runs'), 0)} | "
            f"**{_cell(r.get('mean_mm'))}** / {_cell(r.get('p95_mm'))} | {_cell(r.get('ratio_to_lbs'), 2)} "
            f"({_cell(r.get('ratio_to_lbs_paired'), 2)}; {worst}) | {_cell(r.get('ratio_to_spread'), 2)} "
            f"({_cell(r.get('spread_mean_mm'))}) | {_cell(r.get('penetration_pct'), 2)} / "
            f"{_cell(r.get('lbs_penetration_pct'), 2)} / {_cell(r.get('reference_penetration_pct'), 2)} | "
            f"{_cell(r.get('edge_strain_error'), 3)} / {_cell(r.get('lbs_edge_strain_error'), 3)} | {step} | {cpu} |")
    lines.append("")
    if one_machine:
        lines.append(f"Step times: the suite's median `plInstance_Step`, one thread, measured on {machines[0]}.")
    elif not machines:
        lines.append("No step time in these rows yet (docs/benchmarks.md has the shipped assets' step times).")
    commands = list(dict.fromkeys(r.get("command") for r in rows if r.get("command")))
    lines.append("Made with " + "; ".join(f"`{c}`" for c in commands) + "." if commands else
                 "The command that made these rows is not recorded.")
    regional = [(r, name, g) for r in rows for name, g in (r.get("regions") or {}).items()]
    lines.append("")
    if not regional:
        lines.append("No per-region numbers in bench/results/accuracy-garments.json yet: its rows were not made "
                     "from a `pleat-eval-suite` report with regions.")
        return "\n".join(lines) + "\n"
    lines += ["Per region (the regions of [Regions](#regions)), hardest first within each garment and tier (the "
              "highest error against LBS-only's):", "",
              "| garment | tier | region | vertices | mean / p95 (mm) | LBS-only mean (mm) | × LBS-only (paired) | "
              "edge-strain error: Pleat / LBS-only | inside the body %: Pleat / LBS-only |",
              "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        regions = sorted((r.get("regions") or {}).items(), key=lambda kv: -(kv[1].get("ratio_to_lbs_paired") or 0.0))
        for name, g in regions:
            lines.append(
                f"| {r['garment']} | {r['tier']} | {name} | {_cell(g.get('vertices'), 0)} | "
                f"{_cell(g.get('mean_mm'))} / {_cell(g.get('p95_mm'))} | {_cell(g.get('lbs_mean_mm'))} | "
                f"{_cell(g.get('ratio_to_lbs'), 2)} ({_cell(g.get('ratio_to_lbs_paired'), 2)}) | "
                f"{_cell(g.get('edge_strain_error'), 3)} / {_cell(g.get('lbs_edge_strain_error'), 3)} | "
                f"{_cell(g.get('penetration_pct'), 2)} / {_cell(g.get('lbs_penetration_pct'), 2)} |")
    return "\n".join(lines) + "\n"


def surface_from_summaries(paths):
    """bench/results/reference-surface.json from pleat-sim summaries (DIR/summary.json): a row per garment with the
    share of its surface inside the body (pleat.sim.surface)."""
    rows = []
    for path in paths:
        summary = json.loads(Path(path).read_text())
        if "surface_inside" not in summary:
            raise ValueError(f"{path}: no surface_inside (a pleat-sim summary from before it was measured)")
        s = summary["surface_inside"]
        rows.append(dict(garment=summary["garment"], vertices=summary["vertices"], motion=summary.get("motion"),
                         frames=summary["frames"], **{k: _rounded(s[k], 3) for k in (
                             "inside_pct", "worst_frame_inside_pct", "median_depth_mm", "max_depth_mm")},
                         samples_per_face=s["samples_per_face"], depth_mm=s["depth_mm"]))
    return {"about": "The share of each garment's reference simulation's surface inside the body (pleat-sim's "
                     "surface_inside, pleat.sim.surface); scripts/docs-numbers.py --surface-from writes this file "
                     "from pleat-sim summaries and docs/garments.md's table from it",
            "command": "pleat-garment NAME --vertices 1000 --out data/garments/NAME_1k.npz; pleat-sim --garment "
                       "data/garments/NAME_1k.npz --motion humanoid3d_walk --frames 30 --out out/ref/NAME",
            "rows": rows}


def render_surface(surface):
    lines = ["| garment | vertices | points > 1 mm inside (%) | worst frame (%) | median depth (mm) | deepest (mm) |",
             "|---|---|---|---|---|---|"]
    for r in surface["rows"]:
        lines.append(f"| {r['garment']} | {r['vertices']:,} | {_cell(r['inside_pct'], 2)} | "
                     f"{_cell(r['worst_frame_inside_pct'], 2)} | {_cell(r['median_depth_mm'])} | "
                     f"{_cell(r['max_depth_mm'])} |")
    return "\n".join(lines) + "\n"


def wardrobe_from_reports(paths, command=None, machine=None):
    """bench/results/wardrobe.json from pleat-wardrobe reports (OUT/wardrobe.json) of the same garments: a row per
    run (runner, CPUs, wall time, per garment wall time and verdict)."""
    runs = []
    for path in paths:
        r = json.loads(Path(path).read_text())
        runs.append(dict(runner=r["runner"], cpus=r["cpus"], preset=r["preset"], overrides=r.get("overrides", {}),
                         tiers=r["tiers"], wall_s=_rounded(r["wall_s"], 1), hardware=r.get("hardware"),
                         garments=[dict(garment=g["garment"], wall_s=_rounded(g["wall_s"], 1),
                                        segments=g["segments"], frames=g["frames"],
                                        simulation_cpu_h=_rounded(g["simulation_cpu_h"], 4),
                                        verdict=g["verdict"]) for g in r["garments"]]))
    names = {tuple(g["garment"] for g in run["garments"]) for run in runs}
    if len(names) != 1:
        raise ValueError("the wardrobe reports built different garments: " + "; ".join(map(",".join, names)))
    return {"about": "pleat-wardrobe's wall time, serial against Ray, on one machine (docs/training-speed.md, \"Many "
                     "garments, many machines\"); scripts/docs-numbers.py --wardrobe-from writes this file from the "
                     "commands' wardrobe.json",
            "command": command, "machine": machine, "runs": runs}


def teachers_from_suites(paths, machine=None, metas=None):
    """bench/results/accuracy-teachers.json from pleat-eval-suite reports scored against different teachers
    (pleat-eval-suite --reference): a garments row (garment_row) per (asset, reference), plus `trained_on` (the
    simulator of its training data: META training.simulator, else simsup.teacher in the config_simsup.json of the
    run folder the asset sits in, else "pleat"), `reference` and `training_frames`."""
    machine = machine or this_machine()
    rows = []
    for path in paths:
        report = json.loads(Path(path).read_text())
        command = _suite_command(report)
        for asset, result in report.items():
            meta = (metas or {}).get(asset)
            meta = _meta_of(asset) if meta is None else meta
            runs = result.get("runs", [])
            row = garment_row(asset, result["summary"], runs, command, machine, meta)
            training = meta.get("training") if isinstance(meta.get("training"), dict) else {}
            row.pop("regions")
            row.update(trained_on=training.get("simulator") or _run_teacher(asset) or "pleat",
                       reference=_reference_teacher(runs),
                       training_frames=training.get("frames"))
            rows.append(row)
    return {"about": ("Assets trained on different teachers (Pleat's simulator, Blender's cloth), each scored "
                      "against each teacher on the same held-out clips and bodies: pleat-eval-suite summaries, "
                      "trimmed (scripts/docs-numbers.py --teachers-from writes it, and docs/accuracy.md's table "
                      "\"A second teacher\" from it); the columns are accuracy-garments.json's."),
            "rows": sorted(rows, key=lambda r: (r["reference"] != "blender", r["trained_on"] != r["reference"],
                                                r["asset"]))}


def _run_teacher(asset_path):
    """simsup.teacher of the pleat-train run folder an asset sits in (its config_simsup.json), or None: assets
    packed before META recorded the simulator."""
    for base in (Path.cwd(), ROOT):
        config = (base / asset_path).parent / "config_simsup.json"
        if config.is_file():
            try:
                return json.loads(config.read_text())["config"]["simsup"].get("teacher")
            except (KeyError, TypeError, ValueError):
                return None
    return None


TEACHER_NAMES = {"pleat": "Pleat's simulator", "blender": "Blender's cloth"}


def render_teachers(teachers):
    """docs/accuracy.md's table of assets and teachers (without the markers)."""
    lines = ["| scored against | asset | trained on (simulated frames) | runs | mean / p95 (mm) | "
             "× LBS-only (paired; worst run) | × reference spread (spread mm) | "
             "inside the body %: Pleat / LBS-only / reference | edge-strain error: Pleat / LBS-only | "
             "training CPU-hours |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in teachers["rows"]:
        worse = r.get("clips_worse_than_lbs")
        worst = _cell(r.get("worst_ratio_to_lbs"), 2)
        if worse:
            worst += f", {len(worse)} worse than LBS-only"
        name = lambda t: TEACHER_NAMES.get(t, t)      # noqa: E731
        asset = f"`{r['asset']}`" if r["asset"].startswith("assets/") else f"not shipped (`{Path(r['asset']).name}`)"
        lines.append(
            f"| {name(r['reference'])} | {asset} | {name(r['trained_on'])} "
            f"({_cell(r.get('training_frames'), 0)}) | {_cell(r.get('runs'), 0)} | "
            f"**{_cell(r.get('mean_mm'))}** / {_cell(r.get('p95_mm'))} | {_cell(r.get('ratio_to_lbs'), 2)} "
            f"({_cell(r.get('ratio_to_lbs_paired'), 2)}; {worst}) | {_cell(r.get('ratio_to_spread'), 2)} "
            f"({_cell(r.get('spread_mean_mm'))}) | {_cell(r.get('penetration_pct'), 2)} / "
            f"{_cell(r.get('lbs_penetration_pct'), 2)} / {_cell(r.get('reference_penetration_pct'), 2)} | "
            f"{_cell(r.get('edge_strain_error'), 3)} / {_cell(r.get('lbs_edge_strain_error'), 3)} | "
            f"{_cell(r.get('training_cpu_hours'), 2)} |")
    commands = list(dict.fromkeys(r.get("command") for r in teachers["rows"] if r.get("command")))
    lines.append("")
    lines.append("Made with " + "; ".join(f"`{c}`" for c in commands) + "." if commands else
                 "The commands that made these rows are not recorded.")
    return "\n".join(lines) + "\n"


def int8_from_reports(paths, suite_paths, machine=None, metas=None):
    """bench/results/int8-accuracy.json from bench/int8_accuracy.py reports (--json: an int8 asset's distance to the
    float one it came from, over whole rollouts) and pleat-eval-suite reports that scored the float asset and the int8
    ones against the simulation (mean error, jitter). How each int8 asset was made comes from its META."""
    suites = {}
    for path in suite_paths:
        report = json.loads(Path(path).read_text())
        for asset, result in report.items():
            suites[asset] = dict(result["summary"], command=_suite_command(report))
    rows, floats = [], set()
    for path in paths:
        r = json.loads(Path(path).read_text())
        floats.add(r["float_asset"])
        meta = (metas or {}).get(r["int8_asset"])
        meta = _meta_of(r["int8_asset"]) if meta is None else meta
        record, tune = meta.get("int8"), meta.get("int8_finetune")
        if tune:
            made = (f"pleat-quantise finetune --smoothness {tune.get('smoothness', 0.0):g}"
                    + ("" if tune.get("ranged", True) else " --symmetric-inputs"))
        elif record:
            made = "pleat-pack --int8" + ("" if record.get("inputs") == "ranged" else " --symmetric-inputs")
        else:
            made = "pleat-pack --fp16"                    # float networks: only the blend shapes are int8
        if meta.get("int8_blend_shapes"):
            made += " --int8-blend-shapes"
        inputs = (record or {}).get("inputs", "symmetric") if record or tune else "—"
        s = suites.get(r["int8_asset"], {})
        rows.append(dict(asset=r["int8_asset"], made=made, inputs=inputs,
                         mean_mm=r["mean_mm"], p99_mm=r["p99_mm"], max_mm=r["max_mm"],
                         error_mm=s.get("mean_mm"), jitter=s.get("jitter")))
    if len(floats) != 1:
        raise ValueError(f"the int8 reports compare with different float assets: {sorted(floats)}")
    float_asset = floats.pop()
    f = suites.get(float_asset)
    if f is None:
        raise ValueError(f"no suite report scored the float asset {float_asset}")
    return {"about": ("int8 assets against the float asset they were quantised from (bench/int8_accuracy.py: the "
                      "C runtime's whole rollouts on the validation clips, distance to the float network's "
                      "vertices) and against the simulation (pleat-eval-suite); scripts/docs-numbers.py --int8-from "
                      "writes it, and docs/performance.md's table from it"),
            "float_asset": float_asset, "float_error_mm": f["mean_mm"], "float_jitter": f["jitter"],
            "suite_commands": sorted({s["command"] for s in suites.values()}), "machine": machine or this_machine(),
            "rows": rows}


def merged_int8(old, new):
    """new's rows, plus old's rows of assets new has none of (the same float asset): a report of a few int8 assets
    adds or refreshes their rows and keeps the others as they were measured."""
    if old["float_asset"] != new["float_asset"]:
        return new
    have = {r["asset"] for r in new["rows"]}
    return dict(new, suite_commands=sorted(set(old["suite_commands"]) | set(new["suite_commands"])),
                rows=[r for r in old["rows"] if r["asset"] not in have] + new["rows"])


def render_int8(int8):
    """docs/performance.md's table of int8 assets (without the markers)."""
    lines = ["| int8 asset | inputs | distance to the float network: mean / p99 / worst (mm) | error against the "
             "simulation (mm) | jitter (m/s²) |",
             "|---|---|---|---|---|",
             f"| the float asset (`{int8['float_asset']}`) | — | — | {_cell(int8['float_error_mm'], 2)} | "
             f"{_cell(int8['float_jitter'], 3)} |"]
    for r in int8["rows"]:
        lines.append(f"| `{r['made']}` | {r['inputs']} | **{_cell(r['mean_mm'], 3)}** / {_cell(r['p99_mm'], 2)} / "
                     f"{_cell(r['max_mm'], 1)} | {_cell(r['error_mm'], 2)} | {_cell(r['jitter'], 3)} |")
    lines.append("")
    lines.append("Distances: `bench/int8_accuracy.py FLOAT.pleat INT8.pleat --json OUT.json` (the seven validation "
                 "clips, up to 300 frames each, β = 0, mean over clips). Error and jitter: "
                 + "; ".join(f"`{c}`" for c in int8["suite_commands"]) + f". {int8['machine']}.")
    return "\n".join(lines) + "\n"


def render_int8_speed(bench, machine):
    """docs/performance.md's table of single steps and 64-instance crowds per precision, from a scripts/bench.sh
    step.json whose crowd sweep has the int8 keys (one worker; per instance; ratios to the fp32 single step)."""
    crowd = bench["crowd"]
    rows = {(r["asset"], r["instances"]): r for r in crowd["results"] if r["workers"] == 1}
    lines = ["| asset | precision | single step (µs) | × fp16 single | 64 instances, per instance (µs) | "
             "× fp32 single |", "|---|---|---|---|---|---|"]
    for asset, label in (("tshirt", "shipped t-shirt (1,004 vertices)"), ("reference", "reference sizes (4,424)")):
        fp32 = rows[(f"{asset}_fp32", 1)]["one_by_one_us_per_instance"]
        fp16 = rows[(f"{asset}_fp16", 1)]["one_by_one_us_per_instance"]
        for precision, name in (("fp32", "fp32"), ("fp16", "fp16"), ("int8", "int8"),
                                ("int8s", "int8, int8 blend shapes")):
            if (f"{asset}_{precision}", 1) not in rows:
                continue                                  # (a step.json from before the int8s keys)
            step = rows[(f"{asset}_{precision}", 1)]["one_by_one_us_per_instance"]
            many = rows.get((f"{asset}_{precision}", 64))
            crowd_cells = (f"{_cell(many['batch_us_per_instance'])} | {many['batch_us_per_instance'] / fp32:.2f}"
                           if many else "— | —")
            lines.append(f"| {label} | {name} | {_cell(step)} | {step / fp16:.2f} | {crowd_cells} |")
    lines.append("")
    lines.append(f"`scripts/bench.sh` (`crowd` in its step.json: medians over three rounds, {crowd['clock']} clock, "
                 f"one worker; int8 = ranged inputs and fp16 blend shapes"
                 + (", the next row int8 blend shapes too (`pleat-pack --int8 --fp16 --int8-blend-shapes`)"
                    if any(a.endswith("_int8s") for a, _ in rows) else "") + "); single-step kernels "
                 f"{crowd['isa']}, crowd batches {crowd['batch_isa']}, int8 through AVX-512 VNNI; load "
                 f"{crowd.get('loadavg_start')}–{crowd.get('loadavg_end')}. {machine}.")
    return "\n".join(lines) + "\n"


def render_wardrobe(wardrobe):
    runs = wardrobe["runs"]
    garments = [g["garment"] for g in runs[0]["garments"]]
    serial = next((r for r in runs if r["runner"] == "serial"), None)
    lines = ["| runner | CPUs | " + " | ".join(garments) + " | all garments (s) | × serial |",
             "|---|---|" + "---|" * len(garments) + "---|---|"]
    for r in runs:
        ratio = f"{serial['wall_s'] / r['wall_s']:.2f}× faster" if serial and r is not serial else "1"
        lines.append(f"| {r['runner']} | {r['cpus']} | " + " | ".join(_cell(g["wall_s"], 0) for g in r["garments"])
                     + f" | **{_cell(r['wall_s'], 0)}** | {ratio} |")
    sets = " ".join(f"--set {k}={json.dumps(v)}" for k, v in runs[0]["overrides"].items())
    lines.append("")
    lines.append(f"Per garment: its own wall time (side by side on Ray, so they overlap); {len(garments)} garments, "
                 f"preset `{runs[0]['preset']}` {sets}, tiers {' '.join(runs[0]['tiers']) or 'none'}; "
                 f"{wardrobe.get('machine')}. Commands: `{wardrobe.get('command')}`.")
    return "\n".join(lines) + "\n"


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--bench", default=str(BENCH_JSON), help="benchmark JSON (default: %(default)s)")
    p.add_argument("--accuracy", default=str(ACCURACY_JSON), help="accuracy JSON (default: %(default)s)")
    p.add_argument("--garments", default=str(GARMENTS_JSON),
                   help="garments accuracy JSON (default: %(default)s)")
    p.add_argument("--readme", default=str(README))
    p.add_argument("--accuracy-page", default=str(ACCURACY_PAGE))
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--check", action="store_true", help="exit 1 if a block is out of date")
    mode.add_argument("--print", action="store_true", help="print README.md's block instead of writing the pages")
    mode.add_argument("--garments-from", nargs="+", metavar="SUITE.json",
                      help="write --garments from these pleat-eval-suite reports (their garments' and tiers' rows "
                           "replace the file's; the other rows stay), then the pages")
    mode.add_argument("--surface-from", nargs="+", metavar="SUMMARY.json",
                      help="write --surface from these pleat-sim summaries (one per garment), then the pages")
    mode.add_argument("--wardrobe-from", nargs="+", metavar="WARDROBE.json",
                      help="write --wardrobe from these pleat-wardrobe reports (serial and Ray), then the pages")
    mode.add_argument("--teachers-from", nargs="+", metavar="SUITE.json",
                      help="write --teachers from these pleat-eval-suite reports (against each teacher), then the "
                           "pages")
    mode.add_argument("--int8-from", nargs="+", metavar="INT8_ACCURACY.json",
                      help="write --int8 from these bench/int8_accuracy.py reports and --int8-suites, then the pages")
    p.add_argument("--int8-suites", nargs="+", metavar="SUITE.json", default=[],
                   help="with --int8-from: pleat-eval-suite reports scoring the float asset and the int8 ones")
    p.add_argument("--int8", default=str(INT8_JSON), help="int8 accuracy JSON (default: %(default)s)")
    p.add_argument("--performance-page", default=str(PERFORMANCE_PAGE))
    p.add_argument("--int8-bench", default=str(INT8_BENCH_JSON),
                   help="a scripts/bench.sh step.json with int8 crowd keys (default: %(default)s)")
    p.add_argument("--teachers", default=str(TEACHERS_JSON), help="teachers accuracy JSON (default: %(default)s)")
    p.add_argument("--wardrobe-command", default=None, help="with --wardrobe-from: the commands that made them")
    p.add_argument("--surface", default=str(SURFACE_JSON), help="reference surface JSON (default: %(default)s)")
    p.add_argument("--wardrobe", default=str(WARDROBE_JSON), help="wardrobe timing JSON (default: %(default)s)")
    p.add_argument("--training-page", default=str(TRAINING_PAGE))
    p.add_argument("--garments-page", default=str(GARMENTS_PAGE))
    p.add_argument("--machine", default=None,
                   help="with --garments-from (--wardrobe-from): the machine the suites' step times (the builds) were "
                        "measured on "
                        "(default: this one's CPU model and count)")
    a = p.parse_args(argv)
    try:
        if a.garments_from:
            garments = garments_from_suites(a.garments_from, a.machine)
            if Path(a.garments).is_file():      # the rows of garments and tiers these suites did not score stay
                garments = merged(load_garments(a.garments), garments)
            Path(a.garments).write_text(json.dumps(garments, indent=1, ensure_ascii=False) + "\n")
        if a.surface_from:
            Path(a.surface).write_text(json.dumps(surface_from_summaries(a.surface_from), indent=1) + "\n")
        if a.teachers_from:
            Path(a.teachers).write_text(json.dumps(teachers_from_suites(a.teachers_from, a.machine), indent=1,
                                                   ensure_ascii=False) + "\n")
        if a.int8_from:
            int8 = int8_from_reports(a.int8_from, a.int8_suites, a.machine)
            if Path(a.int8).is_file():      # the rows of int8 assets these reports did not measure stay
                int8 = merged_int8(json.loads(Path(a.int8).read_text()), int8)
            Path(a.int8).write_text(json.dumps(int8, indent=1, ensure_ascii=False) + "\n")
        if a.wardrobe_from:
            Path(a.wardrobe).write_text(json.dumps(wardrobe_from_reports(
                a.wardrobe_from, a.wardrobe_command, a.machine or this_machine()), indent=1) + "\n")
        bench, accuracy = load(a.bench, a.accuracy)
        block = render(bench, accuracy)
        garments_block = render_garments(load_garments(a.garments))
        surface_block = render_surface(json.loads(Path(a.surface).read_text())) if Path(a.surface).is_file() \
            else None
        wardrobe_block = render_wardrobe(json.loads(Path(a.wardrobe).read_text())) if Path(a.wardrobe).is_file() \
            else None
        teachers_block = render_teachers(json.loads(Path(a.teachers).read_text())) if Path(a.teachers).is_file() \
            else None
        int8_block = render_int8(json.loads(Path(a.int8).read_text())) if Path(a.int8).is_file() else None
        int8_speed_block = None
        if Path(a.int8_bench).is_file():
            int8_bench = json.loads(Path(a.int8_bench).read_text())
            int8_speed_block = render_int8_speed(int8_bench, int8_bench.get("machine", "machine not recorded"))
    except (OSError, ValueError, KeyError) as e:
        print(f"docs-numbers: error: {e}", file=sys.stderr)
        return 2
    if a.print:
        sys.stdout.write(block)
        return 0
    pages = [(Path(a.readme), block, BEGIN, END), (Path(a.accuracy_page), garments_block, GARMENTS_BEGIN, GARMENTS_END)]
    if surface_block is not None:
        pages.append((Path(a.garments_page), surface_block, SURFACE_BEGIN, SURFACE_END))
    if wardrobe_block is not None:
        pages.append((Path(a.training_page), wardrobe_block, WARDROBE_BEGIN, WARDROBE_END))
    if teachers_block is not None:
        pages.append((Path(a.accuracy_page), teachers_block, TEACHERS_BEGIN, TEACHERS_END))
    if int8_block is not None:
        pages.append((Path(a.performance_page), int8_block, INT8_BEGIN, INT8_END))
    if int8_speed_block is not None:
        pages.append((Path(a.performance_page), int8_speed_block, INT8_SPEED_BEGIN, INT8_SPEED_END))
    updates = {}        # path → (text on disk, text with its blocks spliced; a page may hold several blocks)
    for path, text_block, begin, end in pages:
        text, new = updates.get(path) or (path.read_text(),) * 2
        try:
            updates[path] = (text, splice(new, text_block, begin, end, path.name))
        except ValueError as e:
            print(f"docs-numbers: error: {e}", file=sys.stderr)
            return 2
    if a.check:
        stale = [path for path, (text, new) in updates.items() if new != text]
        for path in stale:
            print(f"docs-numbers: {path} is out of date: run scripts/docs-numbers.py", file=sys.stderr)
        return 1 if stale else 0
    for path, (text, new) in updates.items():
        if new != text:
            path.write_text(new)
    return 0


if __name__ == "__main__":
    sys.exit(main())
