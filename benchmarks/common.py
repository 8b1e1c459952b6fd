"""Shared helpers of the benchmark scripts: timing medians and the machine/commit header."""

from __future__ import annotations

import datetime as dt
import json
import os
import platform
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"


def median_rate(fn: Callable[[], None], work: float, repeats: int = 7, min_time_s: float = 0.2):
    """Median over `repeats` of work units per second; each repeat loops fn for >= min_time_s."""
    rates = []
    for _ in range(repeats):
        count, start = 0, time.perf_counter()
        while True:
            fn()
            count += 1
            elapsed = time.perf_counter() - start
            if elapsed >= min_time_s:
                break
        rates.append(count * work / elapsed)
    rates.sort()
    return rates[len(rates) // 2]


def header(title: str) -> str:
    try:
        commit = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            cwd=RESULTS.parent,
            check=False,
        ).stdout.strip()
    except OSError:
        commit = "unknown"
    cpu = platform.processor() or platform.machine()
    return (
        f"# {title}\n\nMeasured {dt.datetime.now().strftime('%Y-%m-%d %H:%M')} on "
        f"{os.cpu_count()} cores ({cpu}), commit {commit}. Medians of repeated runs.\n\n"
    )


def write(name: str | Path, text: str) -> Path:
    """Write `text` to RESULTS/name (or to `name` itself when it is a path), print both."""
    path = RESULTS / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    print(text)
    print(f"written to {path}")
    return path


def write_report(stem: str, text: str, data) -> Path:
    """RESULTS/stem.md (`text`, printed) and RESULTS/stem.json (`data`, indented)."""
    path = write(f"{stem}.md", text)
    (RESULTS / f"{stem}.json").write_text(json.dumps(data, indent=2) + "\n")
    return path


def drop_edges_keeping_connected(n_vertices: int, edges: list[tuple[int, int]], count: int,
                                 seed: int) -> set[int]:
    """Indices of `count` edges to drop, tried in a seeded random order, each dropped only when
    the graph stays connected without it (the generated benchmark lattices)."""
    import numpy as np

    adjacency: dict[int, set[int]] = {v: set() for v in range(n_vertices)}
    for u, v in edges:
        adjacency[u].add(v)
        adjacency[v].add(u)

    def connected(u: int, v: int) -> bool:
        seen, stack = {u}, [u]
        while stack:
            w = stack.pop()
            if w == v:
                return True
            for x in adjacency[w] - seen:
                seen.add(x)
                stack.append(x)
        return False

    dropped: set[int] = set()
    for k in np.random.default_rng(seed).permutation(len(edges)).tolist():
        if len(dropped) >= count:
            break
        u, v = edges[k]
        adjacency[u].discard(v)
        adjacency[v].discard(u)
        if connected(u, v):
            dropped.add(k)
        else:
            adjacency[u].add(v)
            adjacency[v].add(u)
    return dropped


def visit_rule_reference(patrol_map, n_robots: int) -> float:
    """[s] the better reference tour's worst idleness (tours.reference_tours at the map's speed)
    under the visit rule: a part of one vertex is driven out and back, as standing makes no
    visit. patrol_bounds.csv's best-known tours count a robot parked on a vertex as idleness 0,
    below what any strategy obeying the rule reaches on crowded maps (1r5, ctcv at N >= 8)."""
    from tpuaf.maps.tours import reference_tours

    speed = float(patrol_map.settings.nominal_speed)
    return float(reference_tours(patrol_map, n_robots, speed)["best_worst_idleness_s"])
