"""Helpers shared by the baseline strategies (BASELINES.md): ties, idleness tables, waiting."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import tpuaf_core

TIE_TOL = 1e-9  # scores within this are a tie (broken at random with ctx.rng)
IDLE_RETRY_S = 1.0  # [s] a robot with nowhere to go asks to decide again after this


def pick_max(candidates: Sequence[int], scores: Sequence[float], rng: np.random.Generator) -> int:
    """Candidate with the largest score; ties at random with the run's generator."""
    s = np.asarray(scores, dtype=float)
    best = np.flatnonzero(s >= s.max() - TIE_TOL * max(1.0, abs(float(s.max()))))
    if best.size == 1:
        return int(candidates[int(best[0])])
    return int(candidates[int(best[rng.integers(best.size)])])


def neighbours(ctx: Any, vertex: int | None = None) -> list[int]:
    """Distinct neighbours of `vertex` (default: the current vertex), never the vertex itself."""
    v = ctx.current_vertex if vertex is None else vertex
    return sorted({int(w) for w in ctx.patrol_map.graph.neighbours(v) if int(w) != v})


def wait_nowhere_to_go(ctx: Any) -> None:
    """A single-vertex graph: no goal other than the current vertex; decide again later."""
    ctx.wake_at(ctx.now + IDLE_RETRY_S)


class IdlenessTable:
    """last_visit[v] [s]; idleness I[v] = now - last_visit[v]. All clocks start at start time."""

    def __init__(self, n: int, t0: float):
        self.last_visit = np.full(n, float(t0))

    def visit(self, vertex: int, time: float) -> None:
        if 0 <= vertex < self.last_visit.size:
            self.last_visit[vertex] = max(self.last_visit[vertex], float(time))

    def idleness(self, now: float) -> np.ndarray:
        return np.maximum(float(now) - self.last_visit, 0.0)


def dijkstra_path(adjacency: dict[int, list[int]], weight, source: int, target: int) -> list[int]:
    """Path source..target (both included) minimising sum weight(u, w) >= 0 (the core's search;
    ties by settling order); [source] when the target cannot be reached."""
    tails, heads, weights = [], [], []
    for u, nbrs in adjacency.items():
        for w in nbrs:
            tails.append(u)
            heads.append(w)
            weights.append(float(weight(u, w)))
    n = max(max(adjacency, default=0), max(heads, default=0), source, target) + 1
    dist, parent, _ = tpuaf_core.dijkstra(n, tails, heads, weights, [source], -1e-12, [], target)
    if not dist[target] < np.inf:
        return [source]
    path = [target]
    while path[-1] != source:
        path.append(parent[path[-1]])
    return path[::-1]


def adjacency(graph: Any) -> dict[int, list[int]]:
    return {
        v: sorted({int(w) for w in graph.neighbours(v) if int(w) != v})
        for v in range(graph.num_vertices)
    }
