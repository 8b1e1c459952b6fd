"""Global planning on the map's occupancy grid, move_base style (ROS-free).

A `PathPlanner` wraps the C++ core's `Costmap` (exact distance transform; cells closer to a wall
than the robot's radius + `safety_margin_m` are lethal; a cost falling off exponentially out to
`inflation_m` beyond that, as move_base's inflation layer) and `GridPlanner` (8-connected A*,
cost-aware line-of-sight smoothing). Paths are polylines in the map frame [m]. The path of
every graph edge is computed once per map and robot footprint and cached; a plan from any pose
takes milliseconds (benchmarks/results/planner.md), so a robot replans when it is blocked.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class PlannerConfig:
    """Costmap and planner settings (units in the comments)."""

    safety_margin_m: float = 0.05  # [m] added to the robot radius: the lethal (inscribed) radius
    inflation_m: float = 0.5  # [m] beyond the inscribed radius where the cost reaches 0
    cost_scaling_per_m: float = 5.0  # [1/m] exponential fall-off of the cost near walls
    cost_weight: float = 1.0  # extra metres per metre driven at cost 1 (keeps paths central)
    # [m] planning grid (a whole number of map cells); 0 = auto: the coarsest whole number of
    # map cells not above half the inscribed radius (the conservative coarsening then narrows
    # a passage by less than that)
    planning_resolution_m: float = 0.0
    snap_radius_m: float = 0.6  # [m] a start or goal in a lethal cell moves this far at most

    def __post_init__(self) -> None:
        for name in ("inflation_m", "cost_scaling_per_m", "snap_radius_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"planner parameter {name} must be > 0, got {value!r}")
        for name in ("safety_margin_m", "cost_weight", "planning_resolution_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"planner parameter {name} must be >= 0, got {value!r}")


@dataclass(frozen=True)
class EdgeCheck:
    """A graph edge against the robot's footprint: its declared length and the planned one."""

    u: int  # vertex indices
    v: int
    declared_m: float
    planned_m: float  # +inf: no collision-free path

    @property
    def ratio(self) -> float:
        return self.planned_m / self.declared_m if self.declared_m > 0 else math.inf


class PathPlanner:
    def __init__(self, patrol_map: Any, robot_radius_m: float,
                 config: PlannerConfig | None = None):
        import tpuaf_core

        if not (math.isfinite(robot_radius_m) and robot_radius_m > 0):
            raise ValueError(f"robot radius must be > 0 m, got {robot_radius_m!r}")
        self.config = c = config or PlannerConfig()
        self.patrol_map = patrol_map
        self.robot_radius_m = float(robot_radius_m)
        grid = patrol_map.occupancy_grid()
        inscribed = self.robot_radius_m + c.safety_margin_m
        spec = tpuaf_core.CostmapSpec(inscribed, inscribed + c.inflation_m, c.cost_scaling_per_m,
                                      c.cost_weight)
        res = float(grid.resolution)
        if c.planning_resolution_m > 0:
            resolution = max(res, c.planning_resolution_m)
        else:
            resolution = res * max(1, math.floor(0.5 * inscribed / res + 1e-9))
        self.costmap = tpuaf_core.Costmap(np.ascontiguousarray(grid.occupied, dtype=bool),
                                          float(grid.resolution),
                                          (float(grid.origin[0]), float(grid.origin[1])), spec,
                                          resolution)
        options = tpuaf_core.PlannerOptions()
        options.snap_radius_m = c.snap_radius_m
        self._planner = tpuaf_core.GridPlanner(self.costmap, options)
        self._positions = np.asarray(patrol_map.positions, dtype=float)
        # Map-grid distances to the nearest obstacle [m] (row 0 the bottom row), for vectorised
        # lookups of many points (the laser's) without a call per point.
        self._distances = np.asarray(self.costmap.map_distances(), dtype=float)
        self._edges: dict[tuple[int, int], np.ndarray | None] = {}
        self.plans = 0  # plans made (edges and on the fly)

    def distances_to_obstacle(self, points: np.ndarray) -> np.ndarray:
        """[m] from each map-frame point (k, 2) to the nearest mapped obstacle (0 outside the
        map): the costmap's distance transform, looked up for all points at once."""
        ox, oy = self.costmap.origin
        res = self.costmap.map_resolution
        cols = np.floor((points[:, 0] - ox) / res).astype(int)
        rows = np.floor((points[:, 1] - oy) / res).astype(int)
        h, w = self._distances.shape
        inside = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
        out = np.zeros(len(points))
        out[inside] = self._distances[rows[inside], cols[inside]]
        return out

    def segment_clear(self, a, b, clearance_m: float) -> bool:
        """Whether every point of the segment a -> b (map frame [m]) lies at least
        `clearance_m` [m] from the nearest mapped obstacle (sampled every half map cell)."""
        ax, ay, bx, by = float(a[0]), float(a[1]), float(b[0]), float(b[1])
        if not all(map(math.isfinite, (ax, ay, bx, by))):
            return False
        step = 0.5 * self.costmap.map_resolution
        k = max(2, int(math.ceil(math.hypot(bx - ax, by - ay) / step)) + 1)
        f = np.linspace(0.0, 1.0, k)
        points = np.column_stack((ax + f * (bx - ax), ay + f * (by - ay)))
        return bool((self.distances_to_obstacle(points) >= clearance_m).all())

    @property
    def inscribed_radius_m(self) -> float:
        return self.robot_radius_m + self.config.safety_margin_m

    def plan(self, start_xy, goal_xy, obstacles: np.ndarray | None = None) -> np.ndarray | None:
        """Polyline (k, 2) [m] from start to goal (start first), or None without a path.
        obstacles: (m, 3) rows (x, y, radius_m) lethal for this plan only."""
        self.plans += 1
        plan = self._planner.plan(np.asarray(start_xy, dtype=float)[:2],
                                  np.asarray(goal_xy, dtype=float)[:2], obstacles)
        return np.asarray(plan.points, dtype=float) if plan.ok else None

    def edge_path(self, u: int, v: int) -> np.ndarray | None:
        """The cached path of the graph edge (or any vertex pair) u -> v, or None."""
        key = (int(u), int(v))
        if key not in self._edges:
            self._edges[key] = self.plan(self._positions[key[0]], self._positions[key[1]])
        return self._edges[key]

    def check_edges(self) -> list[EdgeCheck]:
        """Every graph edge: declared length and planned length (one search per vertex)."""
        graph = self.patrol_map.graph
        edges = sorted({(min(int(i), int(j)), max(int(i), int(j)))
                        for i, j, _ in self.patrol_map.edges})
        if not edges:
            return []
        plans = self._planner.plan_edges(self._positions, np.asarray(edges, dtype=np.int32))
        self.plans += len(edges)
        out = []
        for (u, v), plan in zip(edges, plans, strict=True):
            points = np.asarray(plan.points, dtype=float) if plan.ok else None
            self._edges.setdefault((u, v), points)
            out.append(EdgeCheck(u, v, float(graph.edge_length(u, v)),
                                 float(plan.length_m) if plan.ok else math.inf))
        return out


# One planner per map object and footprint, shared by the robots of a run (edge cache included).
_SHARED: dict[int, tuple[weakref.ref, dict]] = {}


def shared_planner(patrol_map: Any, robot_radius_m: float,
                   config: PlannerConfig | None = None) -> PathPlanner:
    key = id(patrol_map)
    entry = _SHARED.get(key)
    if entry is None or entry[0]() is not patrol_map:
        for k in [k for k, (ref, _) in _SHARED.items() if ref() is None]:
            del _SHARED[k]
        entry = (weakref.ref(patrol_map), {})
        _SHARED[key] = entry
    planners = entry[1]
    wanted = (round(float(robot_radius_m), 6), config or PlannerConfig())
    if wanted not in planners:
        planners[wanted] = PathPlanner(patrol_map, robot_radius_m, wanted[1])
    return planners[wanted]


def with_planned_lengths(patrol_map: Any, robot_radius_m: float,
                         config: PlannerConfig | None = None) -> Any:
    """A copy of `patrol_map` whose edge lengths are the planned path lengths [m] of a robot
    of radius `robot_radius_m`: travel times a robot can achieve. MapError when an edge has no
    collision-free path."""
    from dataclasses import replace

    from tpuaf.errors import MapError

    checks = shared_planner(patrol_map, robot_radius_m, config).check_edges()
    ids = patrol_map.vertex_ids
    blocked = [f"{ids[c.u]}-{ids[c.v]}" for c in checks if not math.isfinite(c.planned_m)]
    if blocked:
        raise MapError(f"map '{patrol_map.name}': no collision-free path for a robot of radius "
                       f"{robot_radius_m:g} m along edge(s) {', '.join(blocked[:10])}"
                       + (f" and {len(blocked) - 10} more" if len(blocked) > 10 else ""))
    planned = {(c.u, c.v): c.planned_m for c in checks}
    edges = []
    for i, j, _ in patrol_map.edges:
        key = (min(i, j), max(i, j))
        edges.append((i, j, planned[key]))
    return replace(patrol_map, edges=edges,
                   notes=[*patrol_map.notes, f"edge lengths: planned paths of a robot of radius "
                                             f"{robot_radius_m:g} m"])
