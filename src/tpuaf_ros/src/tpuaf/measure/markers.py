"""What RViz shows of a patrol (ROS-free): the patrol graph, vertices coloured by idleness or
uncertainty, each robot's footprint, goal and announced intention, as plain marker
descriptions (`Marker`) that tpuaf.ros.markers_node turns into visualization_msgs/MarkerArray.

`PatrolView` is fed what the team publishes and the robots' poses:
- `on_visit(robot, vertex, t)`: a Visit report (idleness of that vertex restarts at t [s]);
- `on_goal(robot, vertex)`: the robot's goal (AgentEvent GOAL);
- `on_intention(robot, from_vertex, vertex, expected_arrival)`: its announced next target;
- `on_pose(robot, t, x, y, yaw)`: its position [m, rad];
- `on_health(robot, stuck)`: the monitor reports it making no progress (/fleet/metrics);
then `markers(now)` describes every marker at run time now [s].

Colours: vertices go green (0) -> yellow -> red (>= the scale: `idleness_scale_s`, or for
uncertainty the X of a target left unvisited that long); robot i has ROBOT_COLOURS[i % 8] for
its footprint, goal line and intention arrow. Uncertainty is the map's model (SPEC Eq. 1-3),
advanced with the robots' sensing at their latest poses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

RGBA = tuple[float, float, float, float]
ROBOT_COLOURS: list[RGBA] = [  # distinct, none green/yellow/red (the vertex scale)
    (0.12, 0.47, 0.71, 1.0),  # blue
    (0.58, 0.40, 0.74, 1.0),  # purple
    (1.00, 0.50, 0.05, 1.0),  # orange
    (0.09, 0.75, 0.81, 1.0),  # cyan
    (0.89, 0.47, 0.76, 1.0),  # pink
    (0.55, 0.34, 0.29, 1.0),  # brown
    (0.50, 0.50, 0.50, 1.0),  # grey
    (0.10, 0.10, 0.10, 1.0),  # black
]
EDGE_COLOUR: RGBA = (0.35, 0.35, 0.35, 0.8)
STUCK_COLOUR: RGBA = (0.9, 0.0, 0.0, 1.0)  # the text under a robot that makes no progress
MODES = ("idleness", "uncertainty")
Z_GRAPH, Z_ROBOT = 0.02, 0.1  # [m] drawing heights


@dataclass
class Marker:
    """One marker: kind is line_list, sphere_list, cylinder, arrow, line_strip or text;
    points [(x, y, z)] in the map frame; pose (x, y, z, yaw) for cylinder and text."""

    ns: str
    id: int
    kind: str
    points: list[tuple[float, float, float]] = field(default_factory=list)
    colors: list[RGBA] = field(default_factory=list)  # per point (sphere_list)
    color: RGBA = (1.0, 1.0, 1.0, 1.0)
    scale: tuple[float, float, float] = (0.1, 0.1, 0.1)  # [m]
    pose: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    text: str = ""


def scale_colour(value: float, vmax: float) -> RGBA:
    """Green (0) -> yellow (vmax / 2) -> red (>= vmax); NaN = grey."""
    if not math.isfinite(value) or not vmax > 0:
        return (0.6, 0.6, 0.6, 1.0)
    u = min(max(value / vmax, 0.0), 1.0)
    return (min(1.0, 2.0 * u), min(1.0, 2.0 * (1.0 - u)), 0.0, 1.0)


class PatrolView:
    def __init__(self, patrol_map: Any, n_robots: int, *, mode: str = "idleness",
                 idleness_scale_s: float = 0.0, start_time: float = 0.0):
        if mode not in MODES:
            raise ValueError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
        self.map = patrol_map
        self.n = int(n_robots)
        self.mode = mode
        self.positions = np.asarray(patrol_map.positions, dtype=float)
        self.edges = sorted({(min(int(a), int(b)), max(int(a), int(b)))
                             for a, b, *_ in patrol_map.edges})  # undirected, by index
        s = patrol_map.settings
        self.robot_radius = float(s.robot_radius)
        # Drawing sizes [m] follow the graph's scale (lab: 3 m across, grid: 26 m).
        lengths = [float(np.hypot(*(self.positions[a] - self.positions[b])))
                   for a, b in self.edges]
        step = float(np.median(lengths)) if lengths else 1.0
        self.size = min(max(0.2 * step, 0.06), 0.5)  # vertex sphere diameter
        # Default scale: twice the time to walk the graph's edges once at the nominal speed,
        # shared by the team (a rough I_max of a good team).
        if idleness_scale_s > 0:
            self.scale_s = float(idleness_scale_s)
        else:
            length = sum(float(np.hypot(*(self.positions[a] - self.positions[b])))
                         for a, b in self.edges)
            self.scale_s = max(10.0, 2.0 * length / max(float(s.nominal_speed), 1e-3)
                               / max(self.n, 1))
        self.last_visit = np.full(len(self.positions), float(start_time))
        self.robot_pose: list[tuple[float, float, float] | None] = [None] * self.n
        self.goal = [-1] * self.n
        self.intention: list[tuple[int, int] | None] = [None] * self.n  # (from, to)
        self.stuck = [False] * self.n  # no progress (the monitor's LiveMetrics.no_progress)
        self.field = None
        self._field_t: float | None = None
        if mode == "uncertainty":
            import tpuaf_core

            self.field = tpuaf_core.UncertaintyField(
                self.positions, np.asarray(patrol_map.importance, dtype=float),
                np.asarray(patrol_map.initial_uncertainty, dtype=float),
                patrol_map.uncertainty_model())
            self._peak, self._radius = float(s.sensing_peak), float(s.sensing_radius)
            # the X reached by a target left unvisited for the idleness scale
            probe = tpuaf_core.UncertaintyField(
                self.positions[:1], np.ones(1), np.zeros(1), patrol_map.uncertainty_model())
            probe.advance_uncovered(self.scale_s)
            self.x_scale = max(float(probe.values[0]), 1e-6)

    # -- inputs (vertex = graph index) ---------------------------------------------------------

    def on_visit(self, robot: int, vertex: int, t: float) -> None:
        if 0 <= vertex < len(self.last_visit):
            self.last_visit[vertex] = max(self.last_visit[vertex], float(t))
        if 0 <= robot < self.n and self.goal[robot] == vertex:
            self.goal[robot] = -1

    def on_goal(self, robot: int, vertex: int) -> None:
        if 0 <= robot < self.n and -1 <= vertex < len(self.positions):
            self.goal[robot] = int(vertex)

    def on_intention(self, robot: int, from_vertex: int, vertex: int) -> None:
        nv = len(self.positions)
        if 0 <= robot < self.n and 0 <= vertex < nv and -1 <= from_vertex < nv:
            self.intention[robot] = (int(from_vertex), int(vertex))

    def on_pose(self, robot: int, t: float, x: float, y: float, yaw: float = 0.0) -> None:
        if 0 <= robot < self.n and math.isfinite(x) and math.isfinite(y):
            self.robot_pose[robot] = (float(x), float(y), float(yaw))

    def on_health(self, robot: int, stuck: bool) -> None:
        if 0 <= robot < self.n:
            self.stuck[robot] = bool(stuck)

    # -- output ---------------------------------------------------------------------------------

    def vertex_values(self, now: float) -> np.ndarray:
        """Idleness [s] (now - last visit) or uncertainty X of every vertex."""
        if self.field is None:
            return np.maximum(0.0, float(now) - self.last_visit)
        if self._field_t is not None and now > self._field_t:
            seen = [p for p in self.robot_pose if p is not None]
            dt = float(now) - self._field_t
            if seen:
                pts = np.array([(p[0], p[1]) for p in seen])
                self.field.advance(dt, pts, np.full(len(pts), self._peak),
                                   np.full(len(pts), self._radius))
            else:
                self.field.advance_uncovered(dt)
        self._field_t = float(now) if self._field_t is None else max(self._field_t, float(now))
        return np.asarray(self.field.values, dtype=float)

    def markers(self, now: float) -> list[Marker]:
        out: list[Marker] = []
        p = self.positions
        w = self.size
        out.append(Marker("graph_edges", 0, "line_list", color=EDGE_COLOUR,
                          scale=(0.15 * w, 0.0, 0.0),
                          points=[pt for a, b in self.edges for pt in
                                  ((p[a, 0], p[a, 1], Z_GRAPH), (p[b, 0], p[b, 1], Z_GRAPH))]))
        values = self.vertex_values(now)
        vmax = self.scale_s if self.field is None else self.x_scale
        out.append(Marker(f"vertices_{self.mode}", 0, "sphere_list", scale=(w, w, w),
                          points=[(x, y, Z_GRAPH) for x, y in p],
                          colors=[scale_colour(v, vmax) for v in values]))
        for i, pose in enumerate(self.robot_pose):
            colour = ROBOT_COLOURS[i % len(ROBOT_COLOURS)]
            if pose is None:
                continue
            x, y, yaw = pose
            d = 2.0 * max(self.robot_radius, 0.1)
            out.append(Marker("footprints", i, "cylinder", color=colour, scale=(d, d, 0.2),
                              pose=(x, y, Z_ROBOT, yaw)))
            out.append(Marker("headings", i, "arrow", color=colour,
                              scale=(0.2 * w, 0.4 * w, 0.4 * w),
                              points=[(x, y, 0.25), (x + d * math.cos(yaw),
                                                     y + d * math.sin(yaw), 0.25)]))
            out.append(Marker("names", i, "text", color=colour, scale=(0.0, 0.0, 1.2 * w),
                              pose=(x, y + d, 0.7, 0.0), text=str(i)))
            # always sent (transparent when moving): RViz keeps a marker until replaced
            out.append(Marker("stuck", i, "text", color=STUCK_COLOUR if self.stuck[i] else
                              (*STUCK_COLOUR[:3], 0.0), scale=(0.0, 0.0, 1.2 * w),
                              pose=(x, y - d, 0.7, 0.0), text="STUCK" if self.stuck[i] else " "))
            g = self.goal[i]
            if g >= 0:
                out.append(Marker("goals", i, "line_strip", color=colour,
                                  scale=(0.25 * w, 0.0, 0.0),
                                  points=[(x, y, Z_ROBOT), (p[g, 0], p[g, 1], Z_ROBOT)]))
            intent = self.intention[i]
            if intent is not None:
                a, b = intent
                start = (p[a, 0], p[a, 1]) if a >= 0 else (x, y)
                faded = (*colour[:3], 0.6)
                out.append(Marker("intentions", i, "arrow", color=faded,
                                  scale=(0.3 * w, 0.7 * w, 0.7 * w),
                                  points=[(start[0], start[1], 0.35), (p[b, 0], p[b, 1], 0.35)]))
        return out

