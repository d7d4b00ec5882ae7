#!/usr/bin/env python3
"""Compares builds of irr-geometry's trace benchmark one case at a time, the way
docs/performance.md measures every traversal change: the builds take turns on one core, in an
order that rotates every round, so that a shared machine's slow spells fall on all of them alike.

Usage: python3 docs/ab-trace.py SCENE:QUERY [--rounds N] [--repeats N] [--core N] BIN[:LAYOUT]...

  SCENE:QUERY  cornell or million, and a query of the bench's IRR_PROFILE (closest, occluded,
               closest-in-order, closest-stream, gather16x64, ...): see benches/trace.rs.
  BIN[:LAYOUT] a bench binary (`cargo bench -p irr-geometry --no-run` prints its path; copy it
               away before building the next version) and the layout it traces, wide8 unless
               given (builds before 8b7d972 have no wide8: give e7c4e82's default, bvh8, the
               name its bench uses). The first binary is the baseline.
  --rounds     rounds (default 16); --repeats: passes over the rays per run, the best counted
               (default 5; 3 suits the 10^6-triangle scene); --core: the core (default 1).

Prints, per binary, the median rate over the rounds, the ratio of medians to the baseline, and
the geometric mean and quartiles of the per-round ratios. A noisy series shows as quartiles far
apart; quote the ratio of medians where a few rounds are outliers.
"""

import argparse
import math
import os
import re
import statistics
import subprocess
import sys


def rate(binary, spec, repeats, core):
    env = dict(os.environ, IRR_PROFILE=spec, IRR_PROFILE_REPEATS=str(repeats))
    out = subprocess.run(
        ["taskset", "-c", str(core), binary],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    m = re.search(r"([0-9.]+) Mrays/s", out)
    if not m:
        sys.exit(f"{binary}: no rate in its output for IRR_PROFILE={spec}: {out!r}")
    return float(m.group(1))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("case", help="SCENE:QUERY, e.g. cornell:closest")
    p.add_argument("binaries", nargs="+", help="BIN[:LAYOUT], the first is the baseline")
    p.add_argument("--rounds", type=int, default=16)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--core", type=int, default=1)
    a = p.parse_args()
    if a.case.count(":") != 1:
        sys.exit(f"{a.case}: expected SCENE:QUERY")
    scene, query = a.case.split(":")
    builds = []
    for b in a.binaries:
        path, _, layout = b.partition(":")
        builds.append((path, f"{scene}:{layout or 'wide8'}:{query}"))
    if a.rounds < 1:
        sys.exit("--rounds must be at least 1")
    n = len(builds)
    rates = [[0.0] * a.rounds for _ in builds]
    for r in range(a.rounds):
        for k in range(n):
            i = (k + r) % n
            rates[i][r] = rate(builds[i][0], builds[i][1], a.repeats, a.core)
        print(f"round {r + 1}: " + "  ".join(f"{rates[i][r]:.3f}" for i in range(n)), flush=True)
    medians = [statistics.median(x) for x in rates]
    for i, (path, spec) in enumerate(builds):
        ratios = [rates[i][r] / rates[0][r] for r in range(a.rounds)]
        gmean = math.exp(sum(map(math.log, ratios)) / len(ratios))
        q = statistics.quantiles(ratios, n=4) if len(ratios) > 1 else [ratios[0]] * 3
        print(
            f"{spec} {os.path.basename(path)}: median {medians[i]:.3f} Mrays/s, "
            f"ratio of medians {medians[i] / medians[0]:.3f}, "
            f"per-round ratios gmean {gmean:.3f} (quartiles {q[0]:.3f}-{q[2]:.3f})"
        )


if __name__ == "__main__":
    main()
