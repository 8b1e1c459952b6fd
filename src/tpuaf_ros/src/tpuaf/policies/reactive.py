"""Reactive baselines of BASELINES.md: RAND, CR, HCR, HPCC. Local idleness, no messages."""

from __future__ import annotations

import numpy as np

from tpuaf.policies.base import Policy, register
from tpuaf.policies.common import (
    IdlenessTable,
    adjacency,
    dijkstra_path,
    neighbours,
    pick_max,
    wait_nowhere_to_go,
)


def neighbour_choice(ctx) -> tuple[list[int], int | None]:
    """The neighbours of the current vertex, and the decision when there is no real choice:
    the single neighbour, or None (after asking to decide again) when there is none."""
    cands = neighbours(ctx)
    if not cands:
        wait_nowhere_to_go(ctx)
        return cands, None
    return cands, cands[0] if len(cands) == 1 else None


@register
class RandomPolicy(Policy):
    """RAND: a uniformly random neighbour."""

    name = "rand"
    description = "Random reactive: a uniformly random neighbour of the current vertex."
    parameters = {}

    def decide(self, ctx):
        cands, forced = neighbour_choice(ctx)
        if len(cands) <= 1:
            return forced
        return cands[int(ctx.rng.integers(len(cands)))]


class _LocalIdleness(Policy):
    """Keeps last_visit from the robot's own visits only (local idleness)."""

    def start(self, ctx):
        self.table = IdlenessTable(ctx.patrol_map.graph.num_vertices, ctx.now)

    def _arrived(self, ctx) -> np.ndarray:
        if not hasattr(self, "table"):
            self.start(ctx)
        self.table.visit(ctx.current_vertex, ctx.now)
        return self.table.idleness(ctx.now)


@register
class ConscientiousReactive(_LocalIdleness):
    """CR: the neighbour with the largest local idleness."""

    name = "cr"
    description = "Conscientious reactive: neighbour with the largest local idleness."
    parameters = {}

    def decide(self, ctx):
        idle = self._arrived(ctx)
        cands, forced = neighbour_choice(ctx)
        if len(cands) <= 1:
            return forced
        return pick_max(cands, idle[cands], ctx.rng)


def hcr_scores(costs: np.ndarray, idleness: np.ndarray) -> np.ndarray:
    """(c_max - c_n)/c_max + I[n]/I_max over the candidates; a term is 0 when its max is 0."""
    c_max, i_max = float(costs.max()), float(idleness.max())
    dist_term = (c_max - costs) / c_max if c_max > 0 else np.zeros_like(costs)
    idle_term = idleness / i_max if i_max > 0 else np.zeros_like(idleness)
    return dist_term + idle_term


@register
class HeuristicConscientiousReactive(_LocalIdleness):
    """HCR: argmax over neighbours of normalised closeness + normalised local idleness."""

    name = "hcr"
    description = "Heuristic conscientious reactive: (c_max-c_n)/c_max + I_n/I_max over neighbours."
    parameters = {}

    def decide(self, ctx):
        idle = self._arrived(ctx)
        cands, forced = neighbour_choice(ctx)
        if len(cands) <= 1:
            return forced
        g, here = ctx.patrol_map.graph, ctx.current_vertex
        costs = np.array([g.edge_length(here, n) for n in cands])
        return pick_max(cands, hcr_scores(costs, idle[cands]), ctx.rng)


@register
class HeuristicPathfinderConscientiousCognitive(_LocalIdleness):
    """HPCC: goal anywhere by closeness + idleness, reached over idleness-weighted edges."""

    name = "hpcc"
    description = (
        "Heuristic pathfinder conscientious cognitive: global goal by (D_max-d)/D_max + I/I_max, "
        "path over edge weights (I_max-I_j)/I_max + (c_ij-c_min)/(c_max-c_min), each step a visit."
    )
    parameters = {}

    def start(self, ctx):
        super().start(ctx)
        self.plan: list[int] = []  # remaining vertices of the current path, next first
        self.adj = adjacency(ctx.patrol_map.graph)

    def on_goal_failed(self, vertex, ctx):
        self.plan = []  # replan from wherever the robot is

    def goal_scores(self, ctx, idle: np.ndarray) -> tuple[list[int], np.ndarray]:
        g, here = ctx.patrol_map.graph, ctx.current_vertex
        d = np.asarray(g.distances)[here]
        cands = [v for v in range(g.num_vertices) if v != here]
        d_max, i_max = float(d.max()), float(idle.max())
        dc, ic = d[cands], idle[cands]
        score = ((d_max - dc) / d_max if d_max > 0 else 0.0) + (ic / i_max if i_max > 0 else 0.0)
        return cands, np.asarray(score, dtype=float) + np.zeros(len(cands))

    def path_to(self, ctx, goal: int, idle: np.ndarray) -> list[int]:
        g = ctx.patrol_map.graph
        i_max = float(idle.max())
        c_min, c_max = g.min_edge_length, g.max_edge_length
        span = c_max - c_min

        def weight(u, w):
            a = (i_max - idle[w]) / i_max if i_max > 0 else 0.0
            b = (g.edge_length(u, w) - c_min) / span if span > 0 else 0.0
            return max(a, 0.0) + max(b, 0.0)

        return dijkstra_path(self.adj, weight, ctx.current_vertex, goal)

    def decide(self, ctx):
        if not hasattr(self, "plan"):
            self.start(ctx)
        idle = self._arrived(ctx)
        here = ctx.current_vertex
        if self.plan and self.plan[0] == here:
            self.plan.pop(0)
        if self.plan and self.plan[0] not in self.adj[here]:
            self.plan = []  # off the planned path (goal failure, etc.): replan
        if not self.plan:
            cands, score = self.goal_scores(ctx, idle)
            if not cands:
                wait_nowhere_to_go(ctx)
                return None
            goal = pick_max(cands, score, ctx.rng)
            self.plan = self.path_to(ctx, goal, idle)[1:]
        return self.plan[0]
