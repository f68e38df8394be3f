#!/usr/bin/env python3
"""Paired A/B of `pleat_bench_step --step-only` builds on a shared, noisy machine (docs/benchmarks.md).

Each round runs every binary once (the order reverses every round), so each pair of runs sees the same load; the
report gives per-binary medians and the median of the per-round ratios to the first binary, which is the number to
quote. A "binary" may be a wrapper script that adds flags (e.g. `exec pleat_bench_step --small-pages "$@"`).

usage: bench/ab_step.py ROUNDS ITERATIONS wall|cpu ASSET BIN [BIN ...] [--workers 2]
"""
import json
import os
import statistics
import subprocess
import sys


def main() -> None:
    rounds, iterations, clock, asset = int(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[4]
    binaries, extra = [], []
    args = sys.argv[5:]
    i = 0
    while i < len(args):
        if args[i] == "--workers":
            extra += args[i:i + 2]
            i += 2
        elif args[i].startswith("--"):
            extra.append(args[i])
            i += 1
        else:
            binaries.append(os.path.abspath(args[i]))
            i += 1
    os.chdir(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    results = {b: [] for b in binaries}
    print("load before:", open("/proc/loadavg").read().strip())
    for r in range(rounds):
        for b in binaries if r % 2 == 0 else binaries[::-1]:
            out = subprocess.run([b, "--asset", asset, "--case", "out/bench/case.bin", "--step-only", "--iterations",
                                  iterations, "--warmup", "50", "--clock", clock] + extra,
                                 capture_output=True, text=True, check=True).stdout
            results[b].append(json.loads(out)["pleat_step_us"])
    print("load after: ", open("/proc/loadavg").read().strip())
    first = results[binaries[0]]
    for b in binaries:
        ratios = [x / y for x, y in zip(results[b], first)]
        print(f"{b}: median {statistics.median(results[b]):.1f} us, min {min(results[b]):.1f}, "
              f"ratio to first (median of rounds) {statistics.median(ratios):.3f}")


if __name__ == "__main__":
    main()
