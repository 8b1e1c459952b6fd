"""What the lane layer changes: lab, TurtleBot3 Burgers, physics runtime, N = 1-4, lanes on / off.

For TPUAF and tpuaf_plus, the same seeds with and without lane locks (docs/LANES.md): the time
means of instantaneous idleness I_ins and of uncertainty X, visits, goal failures, give-ways
and lane waits (count, seconds), medians over the seeds.

    .venv/bin/python benchmarks/bench_lanes.py [--duration 600] [--seeds 2] [--workers 2]

Writes benchmarks/results/lanes.md.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import header, write  # noqa: E402

STRATEGIES = ("tpuaf", "tpuaf_plus")
TEAMS = (1, 2, 3, 4)
KEYS = ("ins", "x", "visits", "failures", "give_ways", "waits", "wait_s")


def one(case: tuple[str, int, int, float, bool]) -> tuple[tuple, dict]:
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    strategy, n, seed, duration, lanes = case
    run = PhysicsRun(PhysicsConfig(map="lab", strategy=strategy, robots=n, duration_s=duration,
                                   seed=seed, robot="burger", lanes=lanes))
    s = run.run()
    return case, {"ins": s["idleness_ins_mean_s"], "x": s["uncertainty_mean"],
                  "visits": s["visits"], "failures": s.get("goal_failures", 0),
                  "give_ways": sum(a.navigator.give_ways for a in run.agents),
                  "waits": s.get("lane_waits", 0), "wait_s": s.get("lane_wait_s", 0.0)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    seeds = range(1, args.seeds + 1)
    cases = [(s, n, seed, args.duration, lanes) for s in STRATEGIES for n in TEAMS
             for seed in seeds for lanes in (False, True)]
    start = time.perf_counter()
    with ProcessPoolExecutor(args.workers) as pool:
        results = dict(pool.map(one, cases))
    wall = time.perf_counter() - start

    def med(s, n, lanes, key):
        return statistics.median(results[(s, n, seed, args.duration, lanes)][key]
                                 for seed in seeds)

    lines = [header("Lanes on the lab: physics, Burgers, N = 1-4, lane locks off / on"),
             f"{args.duration:g} s per run, seeds 1-{args.seeds}, medians; wall {wall:.0f} s "
             f"with {args.workers} workers, load average {os.getloadavg()[0]:.1f}. Runs: "
             "`tpuaf run --runtime physics --map lab --robot burger` (PhysicsConfig.lanes "
             "off / on). Command: `.venv/bin/python benchmarks/bench_lanes.py "
             f"--duration {args.duration:g} --seeds {args.seeds}`.\n",
             "| strategy | N | lanes | I_ins [s] | X | visits | goal failures | give-ways | "
             "lane waits | lane wait [s] |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for s in STRATEGIES:
        for n in TEAMS:
            for lanes in (False, True):
                v = {k: med(s, n, lanes, k) for k in KEYS}
                lines.append(f"| {s} | {n} | {'on' if lanes else 'off'} | {v['ins']:.1f} | "
                             f"{v['x']:.3f} | {v['visits']:.0f} | {v['failures']:.0f} | "
                             f"{v['give_ways']:.0f} | {v['waits']:.0f} | {v['wait_s']:.0f} |")
    verdicts = []
    for s in STRATEGIES:
        for lanes in (False, True):
            ins = [med(s, n, lanes, "ins") for n in TEAMS]
            falls = all(b < a for a, b in zip(ins, ins[1:], strict=False))
            verdicts.append(f"- {s}, lanes {'on' if lanes else 'off'}: I_ins falls at every "
                            f"step of N: **{'yes' if falls else 'no'}** ("
                            + " -> ".join(f"{v:.1f}" for v in ins) + " s).")
    write("lanes.md", "\n".join(lines) + "\n\n" + "\n".join(verdicts) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
