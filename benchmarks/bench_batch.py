"""Benchmark of the batch runtime: 1 simulated hour, wall time and real-time factor.

Run: .venv/bin/python benchmarks/bench_batch.py [--repeats K]
Writes benchmarks/results/batch.md. Cumberland is imported from ../shared (never copied).
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from common import header, write
from tpuaf.maps import load_map
from tpuaf.runtimes.graph import BatchRun, RunConfig

SHARED_MAPS = Path(__file__).resolve().parents[2] / "shared" / "maps" / "patrolling_sim"
CASES = [
    ("cumberland", SHARED_MAPS / "cumberland", "tpuaf", 12),
    ("cumberland", SHARED_MAPS / "cumberland", "tpuaf", 4),
    ("grid", "grid", "tpuaf", 12),
    ("grid", "grid", "tpuaf", 4),
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--duration", type=float, default=3600.0)
    args = parser.parse_args()
    lines = [header("Batch runtime benchmark (benchmarks/bench_batch.py)")]
    lines.append(
        f"One run = {args.duration:g} simulated seconds, seed 1, default settings, no results "
        f"folder written. Median and range over {args.repeats} runs. Target (issue 3): "
        ">= 5,000x real time for cumberland with 12 TPUAF robots.\n"
    )
    lines.append(
        "| map | strategy | N | visits | wall s (median) | wall s (min-max) | real-time factor (median) |"
    )
    lines.append("|---|---|---|---|---|---|---|")
    for name, source, strategy, robots in CASES:
        patrol_map = load_map(source if isinstance(source, str) else str(source))
        walls, visits = [], 0
        for _ in range(args.repeats):
            engine = BatchRun(
                RunConfig(
                    map=name, strategy=strategy, robots=robots, duration_s=args.duration, seed=1
                ),
                patrol_map,
            )
            start = time.perf_counter()
            summary = engine.run()
            walls.append(time.perf_counter() - start)
            visits = summary["visits"]
        median = statistics.median(walls)
        lines.append(
            f"| {name} | {strategy} | {robots} | {visits:,} | {median:.3f} | "
            f"{min(walls):.3f}-{max(walls):.3f} | {args.duration / median:,.0f}x |"
        )
        print(lines[-1], flush=True)
    write("batch.md", "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
