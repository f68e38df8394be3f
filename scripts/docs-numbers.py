#!/usr/bin/env python3
"""Write the numbers block of README.md from measured JSON, so that no figure on the front page is typed by hand.

    scripts/docs-numbers.py                      # rewrite README.md from the committed JSON
    scripts/docs-numbers.py --check              # exit 1 if README.md's block is not what the JSON gives
    scripts/docs-numbers.py --print              # print the block
    scripts/docs-numbers.py --bench out/bench/step.json --print   # the block for your own scripts/bench.sh run

Inputs: bench/results/cpu-reference.json (step times, keys as in out/bench/step.json, plus a "machine" object
naming the CPU, the kernels chosen and the load) and bench/results/accuracy-reference.json (errors against the
reference simulator). The block sits between the markers BEGIN and END below; everything outside it is left alone.
tests/python/test_docs_numbers.py fails when README.md and the committed JSON disagree.
"""
import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BENCH_JSON = ROOT / "bench" / "results" / "cpu-reference.json"
ACCURACY_JSON = ROOT / "bench" / "results" / "accuracy-reference.json"
README = ROOT / "README.md"
BEGIN = "<!-- numbers:begin (written by scripts/docs-numbers.py from bench/results/*.json; do not edit by hand) -->"
END = "<!-- numbers:end -->"


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
        lines.append(text + " (docs/accuracy.md, docs/pareto.md).")
    return "\n".join(lines) + "\n"


def splice(readme_text, block):
    """README text with the block between the markers replaced; ValueError when the markers are missing."""
    start = readme_text.find(BEGIN)
    end = readme_text.find(END)
    if start < 0 or end < 0 or end < start:
        raise ValueError(f"README.md has no numbers block (the line {BEGIN!r} ... {END!r})")
    return readme_text[:start] + BEGIN + "\n" + block + readme_text[end:]


def load(bench_path=BENCH_JSON, accuracy_path=ACCURACY_JSON):
    return json.loads(Path(bench_path).read_text()), json.loads(Path(accuracy_path).read_text())


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--bench", default=str(BENCH_JSON), help="benchmark JSON (default: %(default)s)")
    p.add_argument("--accuracy", default=str(ACCURACY_JSON), help="accuracy JSON (default: %(default)s)")
    p.add_argument("--readme", default=str(README))
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--check", action="store_true", help="exit 1 if the README block is out of date")
    mode.add_argument("--print", action="store_true", help="print the block instead of writing README.md")
    a = p.parse_args(argv)
    try:
        bench, accuracy = load(a.bench, a.accuracy)
        block = render(bench, accuracy)
    except (OSError, ValueError, KeyError) as e:
        print(f"docs-numbers: error: {e}", file=sys.stderr)
        return 2
    if a.print:
        sys.stdout.write(block)
        return 0
    readme = Path(a.readme)
    text = readme.read_text()
    try:
        new = splice(text, block)
    except ValueError as e:
        print(f"docs-numbers: error: {e}", file=sys.stderr)
        return 2
    if a.check:
        if new != text:
            print(f"docs-numbers: {readme} is out of date: run scripts/docs-numbers.py", file=sys.stderr)
            return 1
        return 0
    if new != text:
        readme.write_text(new)
    return 0


if __name__ == "__main__":
    sys.exit(main())
