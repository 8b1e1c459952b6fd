"""Route-following baselines of BASELINES.md: CGG (one shared cycle) and MSP (one part each).

Routes come from `tpuaf.maps.tours` (deterministic, so every robot computes the same ones).
No messages.
"""

from __future__ import annotations

from tpuaf.maps import tours
from tpuaf.policies.base import Policy, register
from tpuaf.policies.common import neighbours, wait_nowhere_to_go


class _RouteFollower(Policy):
    """Follows a closed walk `self.route` (consecutive entries adjacent, last -> first too)."""

    route: list[int]

    def _route(self, ctx) -> list[int]:
        raise NotImplementedError

    def start(self, ctx):
        self.route = list(self._route(ctx))
        self.pos = self._entry(ctx.current_vertex, ctx)
        self.failed: int | None = None

    def _entry(self, vertex: int, ctx) -> int:
        """Index of `vertex` in the route, or -1 when it is not on it."""
        return self.route.index(vertex) if vertex in self.route else -1

    def on_goal_failed(self, vertex, ctx):
        self.failed = vertex

    def decide(self, ctx):
        if not hasattr(self, "route"):
            self.start(ctx)
        here, route = ctx.current_vertex, self.route
        m = len(route)
        if m == 1:  # a one-vertex part: shuttle to its nearest neighbour and back
            if here != route[0]:
                return route[0]
            nbrs = neighbours(ctx)
            if not nbrs:
                wait_nowhere_to_go(ctx)
                return None
            g = ctx.patrol_map.graph
            return min(nbrs, key=lambda w: (g.edge_length(here, w), w))
        if self.failed is not None and self.pos >= 0 and route[self.pos] == self.failed:
            # the navigator gave up on route[pos]: skip it
            self.failed = None
            self.pos = (self.pos + 1) % m
            if route[self.pos] == here:
                self.pos = (self.pos + 1) % m
            return route[self.pos]
        self.failed = None
        if self.pos < 0 or route[self.pos] != here:
            if here in route:  # resume at the next occurrence of `here` along the route
                first = max(self.pos, 0)
                self.pos = next((first + i) % m for i in range(m) if route[(first + i) % m] == here)
            else:  # not on the route (MSP start outside the part): go to its nearest vertex
                g = ctx.patrol_map.graph
                self.pos = min(range(m), key=lambda i: (g.distance(here, route[i]), i))
                return route[self.pos]
        self.pos = (self.pos + 1) % m
        return route[self.pos]


@register
class CyclicPolicy(_RouteFollower):
    """CGG: every robot follows the same shortest closed walk found, from its own start vertex."""

    name = "cgg"
    description = (
        "Cyclic (CGG): one shared closed walk through all vertices (TSP heuristic), followed "
        "from each robot's own start vertex (not evenly spaced)."
    )
    parameters = {}

    def _route(self, ctx):
        return tours.cyclic_tour(ctx.patrol_map).walk


def team_start_vertices(ctx) -> list[int]:
    """Every robot's start vertex as the runtimes choose them (tpuaf.maps.start_vertices).

    Every robot must use the same list so that the part assignment is consistent; a robot
    whose actual start differs simply drives to its assigned part first."""
    try:
        from tpuaf.maps import start_vertices

        starts = [int(v) for v in start_vertices(ctx.patrol_map, ctx.n_robots)]
    except Exception:  # a map without start settings: robot k gets part k
        starts = []
    if len(starts) != ctx.n_robots:
        return []
    return starts


@register
class MultilevelSubgraphPolicy(_RouteFollower):
    """MSP: the graph split into connected parts balanced by tour length; each robot tours its
    part's closed walk, entering it at the nearest part vertex."""

    name = "msp"
    description = (
        "Multilevel subgraph patrolling (MSP): balanced connected partition, one closed walk per "
        "part, parts assigned to robots by minimum total distance from the start vertices."
    )
    parameters = {}

    def _route(self, ctx):
        # one-way lanes: fewer parts when N strongly connected ones do not exist
        part = tours.tourable_partition(ctx.patrol_map, ctx.n_robots)
        dist = ctx.patrol_map.graph.distances
        starts = team_start_vertices(ctx)
        if starts:
            assignment = tours.assign_parts(part, starts, dist)
        else:
            assignment = [p for p, m in enumerate(part.robots_per_part) for _ in range(m)]
        self.part_index = assignment[ctx.robot]
        return part.tours[self.part_index].walk
