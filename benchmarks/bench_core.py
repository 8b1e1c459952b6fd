"""Benchmark of the C++ core: uncertainty updates and TPUAF utility evaluations per second.

Run: .venv/bin/python benchmarks/bench_core.py   (writes benchmarks/results/core.md)
"""

from __future__ import annotations

import numpy as np
import tpuaf_core as core
from common import header, median_rate, write


def field_case(n_targets: int, n_robots: int):
    rng = np.random.default_rng(1)
    side = 10.0 * np.sqrt(n_targets)
    targets = rng.uniform(0, side, (n_targets, 2))
    robots = rng.uniform(0, side, (n_robots, 2))
    field = core.UncertaintyField(targets, np.full(n_targets, 0.01), np.ones(n_targets))
    peaks, radii = np.ones(n_robots), np.full(n_robots, 5.0)
    calls = median_rate(lambda: field.advance(0.1, robots, peaks, radii), 1.0)
    return calls, calls * n_targets * n_robots


def utility_case(n_vertices: int, candidates: str):
    rng = np.random.default_rng(2)
    side = int(np.sqrt(n_vertices))
    positions = np.array([[5.7 * (i % side), 5.7 * (i // side)] for i in range(side * side)])
    edges = []
    for i in range(side * side):
        if i % side + 1 < side:
            edges.append((i, i + 1))
        if i + side < side * side:
            edges.append((i, i + side))
    graph = core.PatrolGraph(positions, edges)
    n = graph.num_vertices
    current = n // 2
    cands = (
        list(graph.neighbours(current))
        if candidates == "neighbours"
        else [v for v in range(n) if v != current]
    )
    model = core.UncertaintyModel()
    args = (
        graph,
        np.full(n, 0.01),
        model,
        100.0,
        current,
        cands,
        1.0,
        rng.uniform(0, 100, n),
        rng.uniform(0, 5, n),
        np.full(n, np.inf),
        np.zeros(n),
    )
    any_vertex = candidates != "neighbours"
    calls = median_rate(lambda: core.tpuaf_utilities(*args, use_path_length=any_vertex), 1.0)
    return calls, calls * len(cands), len(cands)


def main() -> None:
    lines = [header("C++ core benchmark (benchmarks/bench_core.py)")]
    lines.append("## Uncertainty field update (`UncertaintyField.advance`, Eq. 1-3)\n")
    lines.append("| targets x robots | calls/s | target-robot updates/s |")
    lines.append("|---|---|---|")
    for n_t, n_r in [(40, 12), (1000, 100)]:
        calls, pairs = field_case(n_t, n_r)
        lines.append(f"| {n_t} x {n_r} | {calls:,.0f} | {pairs:,.0f} |")
    lines.append("\n## TPUAF utility (`tpuaf_utilities`, Eq. 6-14), one robot, one call\n")
    lines.append("| graph | candidates | calls/s | utility evaluations/s |")
    lines.append("|---|---|---|---|")
    for n, which in [(25, "neighbours"), (25, "all"), (1024, "all")]:
        calls, evals, k = utility_case(n, which)
        lines.append(f"| {n}-vertex lattice | {which} ({k}) | {calls:,.0f} | {evals:,.0f} |")
    write("core.md", "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
