#!/usr/bin/env python3
"""Paired per-phase A/B of two `pleat_bench_phases` builds (docs/performance.md, "A step reads bytes; arithmetic is cheap").

Alternates `pleat_bench_phases --phases` of binary A and B for ROUNDS rounds (fp32 and fp16 reference assets) and
prints, per phase, the median over rounds of each run's per-phase median.

usage: bench/ab_phases.py ROUNDS ITERATIONS wall|cpu A B
"""
import json
import os
import statistics
import subprocess
import sys


def main() -> None:
    rounds, iterations, clock = int(sys.argv[1]), sys.argv[2], sys.argv[3]
    a, b = os.path.abspath(sys.argv[4]), os.path.abspath(sys.argv[5])
    os.chdir(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    results = {a: [], b: []}
    print("load before:", open("/proc/loadavg").read().strip())
    for r in range(rounds):
        for binary in (a, b) if r % 2 == 0 else (b, a):
            out = subprocess.run([binary, "--phases", "--asset", "out/bench/asset_fp32.pleat", "--asset-fp16",
                                  "out/bench/asset_fp16.pleat", "--case", "out/bench/case.bin", "--iterations",
                                  iterations, "--warmup", "50", "--clock", clock],
                                 capture_output=True, text=True, check=True).stdout
            results[binary].append(json.loads(out))
    print("load after: ", open("/proc/loadavg").read().strip())
    for precision in ("fp32", "fp16"):
        print(f"{precision}: phase, A, B (us; median over {rounds} rounds, clock {clock})")
        for key in results[a][0][precision]:
            ma = statistics.median(x[precision][key] for x in results[a])
            mb = statistics.median(x[precision][key] for x in results[b])
            print(f"  {key:22s} {ma:8.1f} {mb:8.1f}")


if __name__ == "__main__":
    main()
