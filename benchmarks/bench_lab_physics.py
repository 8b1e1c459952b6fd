"""The paper's Table 4 in the physics runtime: lab, TurtleBot3 Burgers, N = 1-4.

For TPUAF and tpuaf_plus, the physics runtime (C++ world, lasers, the agents' navigator on
planned paths) and the graph runtime, same seeds: the time means of instantaneous idleness
I_ins and of uncertainty X, medians over the seeds. The paper's claim: both fall as N grows.

    .venv/bin/python benchmarks/bench_lab_physics.py [--duration 1800] [--seeds 3]

Writes benchmarks/results/lab_physics.md.
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


def one(case: tuple[str, str, int, int, float]) -> tuple[tuple, dict]:
    from tpuaf.runtimes.config import PhysicsConfig, RunConfig
    from tpuaf.runtimes.graph import make_run
    from tpuaf.runtimes.physics import PhysicsRun

    runtime, strategy, n, seed, duration = case
    common = dict(map="lab", strategy=strategy, robots=n, duration_s=duration, seed=seed)
    if runtime == "physics":
        s = PhysicsRun(PhysicsConfig(**common, robot="burger")).run()
    else:
        run = make_run(RunConfig(**common))
        s = run.run()
    return case, {"ins": s["idleness_ins_mean_s"], "x": s["uncertainty_mean"],
                  "visits": s["visits"], "failures": s.get("goal_failures", 0)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=1800.0)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    cases = [(rt, s, n, seed, args.duration) for rt in ("graph", "physics") for s in STRATEGIES
             for n in (1, 2, 3, 4) for seed in range(1, args.seeds + 1)]
    start = time.perf_counter()
    with ProcessPoolExecutor(args.workers) as pool:
        results = dict(pool.map(one, cases))
    wall = time.perf_counter() - start

    def med(rt, s, n, key):
        return statistics.median(results[(rt, s, n, seed, args.duration)][key]
                                 for seed in range(1, args.seeds + 1))

    lines = [header("Table 4 in the physics runtime: lab, Burgers, N = 1-4"),
             f"{args.duration:g} s per run, seeds 1-{args.seeds}, medians; wall {wall:.0f} s "
             f"with {args.workers} workers, load average {os.getloadavg()[0]:.1f}. Physics: "
             "`tpuaf run --runtime physics --map lab --robot burger`; graph: `tpuaf run --map "
             "lab` (declared lengths). Command: `.venv/bin/python "
             "benchmarks/bench_lab_physics.py`.\n",
             "| strategy | N | physics I_ins [s] | physics X | physics visits | goal failures | "
             "graph I_ins [s] | graph X |",
             "|---|---|---|---|---|---|---|---|"]
    verdicts = []
    for s in STRATEGIES:
        ins = [med("physics", s, n, "ins") for n in (1, 2, 3, 4)]
        xs = [med("physics", s, n, "x") for n in (1, 2, 3, 4)]
        for k, n in enumerate((1, 2, 3, 4)):
            lines.append(f"| {s} | {n} | {ins[k]:.1f} | {xs[k]:.3f} | "
                         f"{med('physics', s, n, 'visits'):.0f} | "
                         f"{med('physics', s, n, 'failures'):.0f} | "
                         f"{med('graph', s, n, 'ins'):.1f} | {med('graph', s, n, 'x'):.3f} |")
        falls = all(b < a for a, b in zip(ins, ins[1:], strict=False)) and \
            all(b < a for a, b in zip(xs, xs[1:], strict=False))
        verdicts.append(f"- {s}: I_ins and X fall at every step of N in the physics runtime: "
                        f"**{'yes' if falls else 'no'}** (I_ins "
                        + " -> ".join(f"{v:.1f}" for v in ins) + " s; X "
                        + " -> ".join(f"{v:.3f}" for v in xs) + ").")
    write("lab_physics.md", "\n".join(lines) + "\n\n" + "\n".join(verdicts) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
