"""Edge travel times a robot really has: a model of the physics runtime's motion (ROS-free).

An edge's duration [s] is that of its planned path (`PathPlanner`, the navigator's corners)
driven by the reactive controller (controller.py) on a body with speed, turn-rate and
acceleration limits (`RobotKinematics`). Terms, each read off the controller's logic:

- driving: the path, each corner cut by the navigator's corner tolerance and the goal reached
  within the map's goal tolerance, at the cruise speed, except in the slow zones: where the
  free length ahead f (the controller's swept-disc measure, robot radius + safety margin, here
  against the map's wall cells) is below `slow_m`, the speed is v f / slow_m, never below
  APPROACH_MPS (the time is the integral of ds / speed);
- turns: at every heading change e (the path's corners, and at the start the turn from the
  arrival heading to the first leg): in place at the angular limit while e > turn_in_place,
  then driving at v cos(e) while e decays at heading_gain (angular speed and acceleration
  limits, the control period); the time lost against driving straight on at v;
- acceleration: from standstill (after a turn in place) to v at the linear acceleration limit;
- arrival: checked once per control period, on average half a period after the robot entered
  the goal tolerance (the next edge starts from there).

The robot's arrival heading at the edge's first vertex is not known per edge: a directed edge's
figure is the mean over the ways of arriving there (the last leg of every other edge of that
vertex; back along the edge itself at a dead end), as on a walk that does not turn back.
Edges are undirected: `edge_durations` gives the mean of both directions. A timed map also
carries, per way of arriving (w, u, v), what it adds to that mean (`turn_times`: a robot that
turns back at u loses a half turn in place and its speed); the graph runtime's robots and
tpuaf_plus's walks add it, so a walk back and forth is timed as the robots drive it.

Left out: other robots (waits, give-ways, detours), recoveries, the controller's headings off
the straight line (it may steer round a wall's corner), laser noise and the laser's offset from
the base.
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from tpuaf.navigation.controller import (
    APPROACH_MPS,
    CONTROL_PERIOD_S,
    PHYSICS_STEP_S,
    ControllerConfig,
    LocalController,
)


def _corner_tolerance() -> float:
    """[m] the navigator's corner tolerance (Navigator's default)."""
    import inspect

    from tpuaf.navigation.navigator import Navigator

    return float(inspect.signature(Navigator.__init__).parameters["corner_tolerance"].default)


@dataclass(frozen=True)
class RobotKinematics:
    """A robot's motion limits and the controller that drives it (units in the comments)."""

    max_linear_speed: float  # [m/s] cruise: the controller's top speed
    max_angular_speed: float  # [rad/s] the body's limit
    linear_accel: float = math.inf  # [m/s^2]
    angular_accel: float = math.inf  # [rad/s^2]
    radius_m: float = 0.105  # [m] footprint disc
    control_period_s: float = CONTROL_PERIOD_S  # [s] agents' tick
    physics_step_s: float = PHYSICS_STEP_S  # [s] world step
    corner_tolerance_m: float = field(default_factory=_corner_tolerance)  # [m]
    # None: the controller as the physics runtime configures it (speeds and radius above)
    controller: ControllerConfig | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        for name in ("max_linear_speed", "max_angular_speed", "linear_accel", "angular_accel",
                     "radius_m", "control_period_s", "physics_step_s"):
            value = getattr(self, name)
            if not value > 0 or math.isnan(value):
                raise ValueError(f"robot kinematics: {name} must be > 0, got {value!r}")
        if self.controller is None:
            object.__setattr__(self, "controller", ControllerConfig(
                max_linear_speed=self.max_linear_speed,
                max_angular_speed=self.max_angular_speed, robot_radius=self.radius_m))

    @property
    def turn_rate(self) -> float:
        """[rad/s] the angular speed limit in effect: the controller's and the body's."""
        return min(self.max_angular_speed, self.controller.max_angular_speed)

    @property
    def slow_m(self) -> float:
        """[m] free length below which the controller slows down (LocalController.slow_m)."""
        return LocalController(self.controller).slow_m

    @classmethod
    def from_preset(cls, preset: str, speed_mps: float | None = None, **kw) -> RobotKinematics:
        """A simulator preset (tpuaf_stage.presets) at cruise `speed_mps` (default its limit)."""
        from tpuaf_stage.presets import ROBOT_PRESETS

        p = ROBOT_PRESETS[preset]
        speed = float(p["max_linear_speed"] if speed_mps is None else speed_mps)
        return cls(max_linear_speed=min(speed, float(p["max_linear_speed"])),
                   max_angular_speed=float(p["max_angular_speed"]),
                   linear_accel=float(p["max_linear_accel"]),
                   angular_accel=float(p["max_angular_accel"]), radius_m=float(p["radius"]),
                   **kw)

    @classmethod
    def of(cls, robot: Any) -> RobotKinematics:
        """`robot` itself, or the kinematics of a robot model (tpuaf.robot.model.RobotModel:
        speed_mps, max_angular_speed, linear_accel, angular_accel, radius_m)."""
        if isinstance(robot, RobotKinematics):
            return robot
        return cls(max_linear_speed=float(robot.speed_mps),
                   max_angular_speed=float(robot.max_angular_speed),
                   linear_accel=float(robot.linear_accel),
                   angular_accel=float(robot.angular_accel), radius_m=float(robot.radius_m))


# ---------------------------------------------------------------------------------------------
# Turns and acceleration


def turn_loss_s(kin: RobotKinematics, angle: float, v0: float | None = None) -> float:
    """[s] lost against driving straight on at the cruise speed when the heading error jumps
    to `angle` [rad] while driving at `v0` [m/s] (default the cruise speed; 0: from
    standstill, the acceleration term): the controller's commands (turn in place above
    turn_in_place, else v cos(e), w = heading_gain e within the angular limit) held for a
    control period, the body's speed and acceleration limits per world step. Progress counts
    along the new direction."""
    c = kin.controller
    vmax = kin.max_linear_speed
    v = vmax if v0 is None else float(v0)
    e = abs(float(angle))
    w = 0.0
    dt = kin.physics_step_s
    sub = max(1, round(kin.control_period_s / dt))
    wmax = kin.turn_rate
    dv, dw = kin.linear_accel * dt, kin.angular_accel * dt
    t = progress = 0.0
    for _ in range(100_000):
        if e < 1e-3 and abs(v - vmax) < 1e-6 * vmax:
            break
        wc = min(wmax, c.heading_gain * e)
        vc = 0.0 if e > c.turn_in_place else vmax * math.cos(e)
        for _ in range(sub):
            v += max(-dv, min(dv, vc - v))
            w += max(-dw, min(dw, wc - w))
            progress += v * math.cos(e) * dt
            e = max(0.0, e - w * dt)  # converging; an overshoot ends the turn
            t += dt
    return t - progress / vmax


class _TurnTable:
    """turn_loss_s on a grid of angles, from cruise and from standstill (linear in between)."""

    N = 181

    def __init__(self, kin: RobotKinematics):
        self.angles = np.linspace(0.0, math.pi, self.N)
        self.moving = np.array([turn_loss_s(kin, a) for a in self.angles])
        self.still = np.array([turn_loss_s(kin, a, 0.0) for a in self.angles])
        self.vmax = kin.max_linear_speed

    def __call__(self, angle: float, v0: float) -> float:
        a = min(abs(angle), math.pi)
        f = min(1.0, max(0.0, v0 / self.vmax))
        return float(f * np.interp(a, self.angles, self.moving)
                     + (1.0 - f) * np.interp(a, self.angles, self.still))


# ---------------------------------------------------------------------------------------------
# Free length ahead (the slow zones)


class _Walls:
    """The map's wall cells (occupied cells with a free neighbour, and the grid's border) as
    points [m]: what the laser sees, for the controller's free-length measure."""

    def __init__(self, patrol_map: Any):
        grid = patrol_map.occupancy_grid()
        occ = np.pad(np.asarray(grid.occupied, dtype=bool), 1, constant_values=True)
        free = ~occ
        near_free = np.zeros_like(occ)
        near_free[1:, :] |= free[:-1, :]
        near_free[:-1, :] |= free[1:, :]
        near_free[:, 1:] |= free[:, :-1]
        near_free[:, :-1] |= free[:, 1:]
        rows, cols = np.nonzero(occ & near_free)
        res = float(grid.resolution)
        # padded index - 1 = grid index; row 0 the bottom row
        self.xy = np.column_stack((grid.origin[0] + (cols - 0.5) * res,
                                   grid.origin[1] + (rows - 0.5) * res))

    def free_lengths(self, a: np.ndarray, u: np.ndarray, s: np.ndarray, rm: float,
                     cap: float) -> np.ndarray:
        """[m] free length at a + s u (s [m] along the unit vector u) along u of a disc of
        radius rm: the controller's `_free` with the wall points, capped at `cap`."""
        rel = self.xy - a
        along = rel @ u
        lat = rel[:, 0] * u[1] - rel[:, 1] * u[0]
        keep = (np.abs(lat) < rm) & (along > s[0]) & (along < s[-1] + cap + rm)
        if not keep.any():
            return np.full(len(s), cap)
        along, lat = along[keep], lat[keep]
        touch = along - np.sqrt(rm * rm - lat * lat)  # [m] where the disc reaches the point
        order = np.argsort(along)
        along, touch = along[order], touch[order]
        suffix = np.minimum.accumulate(touch[::-1])[::-1]  # least touch of points farther on
        k = np.searchsorted(along, s, side="right")  # first point ahead of s
        out = np.full(len(s), math.inf)
        inside = k < len(along)
        out[inside] = suffix[k[inside]] - s[inside]
        return np.clip(out, 0.0, cap)


# ---------------------------------------------------------------------------------------------
# One traversal


@dataclass
class _Model:
    kin: RobotKinematics
    goal_tolerance_m: float
    walls: _Walls | None
    turns: _TurnTable
    step_m: float = 0.01  # [m] integration step along a leg

    def leg(self, a: np.ndarray, u: np.ndarray, length: float) -> tuple[float, float]:
        """([s] to drive `length` [m] from a along u with the slow zones, [m/s] end speed)."""
        kin = self.kin
        vmax = kin.max_linear_speed
        if length <= 0:
            return 0.0, vmax
        n = max(1, int(math.ceil(length / self.step_m)))
        ds = length / n
        s = (np.arange(n) + 0.5) * ds
        if self.walls is None:
            return length / vmax, vmax
        c = kin.controller
        ctl = LocalController(c)
        f = self.walls.free_lengths(a, u, s, c.robot_radius + c.safety_margin, ctl.cap)
        floor = min(1.0, APPROACH_MPS / vmax)
        speed = vmax * np.clip(f / ctl.slow_m, floor, 1.0)
        return float(np.sum(ds / speed)), float(speed[-1])

    def traversal(self, path: np.ndarray, start: np.ndarray | None = None,
                  heading: np.ndarray | None = None) -> tuple[float, np.ndarray, np.ndarray]:
        """([s] along `path` (k, 2) [m] from `start` (default its first point) arriving with
        unit `heading` (None: at rest, facing the first leg), the end point [m], the last leg's
        unit direction)."""
        kin = self.kin
        pos = np.asarray(path[0] if start is None else start, dtype=float)
        targets = np.asarray(path[1:], dtype=float)
        prev = None if heading is None else np.asarray(heading, dtype=float)
        v = 0.0 if heading is None else kin.max_linear_speed
        total = 0.0
        last_u = prev
        for k, target in enumerate(targets):
            final = k == len(targets) - 1
            tol = self.goal_tolerance_m if final else kin.corner_tolerance_m
            d = target - pos
            dist = float(math.hypot(d[0], d[1]))
            if dist <= tol:  # within tolerance already: the navigator passes it
                continue
            u = d / dist
            if prev is None:
                total += self.turns(0.0, v)  # from standstill, facing the leg
            else:
                angle = math.atan2(prev[0] * u[1] - prev[1] * u[0], prev @ u)
                total += self.turns(angle, v)
            driven = dist - tol
            t, v = self.leg(pos, u, driven)
            if final:
                # The arrival is checked once per control period: on average half a period
                # after the robot crossed into the tolerance, as far on (at the end speed).
                over = min(0.5 * kin.control_period_s * v, tol)
                driven += over
                t += over / v
            total += t
            pos = pos + u * driven
            prev = last_u = u
        if last_u is None:
            d = targets[-1] - pos if len(targets) else np.zeros(2)
            last_u = d / (np.hypot(*d) or 1.0)
        return total, pos, last_u


def path_duration(path, robot: Any, goal_tolerance_m: float = 0.0, patrol_map: Any = None,
                  heading: float | None = None) -> float:
    """[s] to drive the polyline `path` (k, 2) [m] from its first point (at rest facing the
    first leg, or moving at the cruise speed with `heading` [rad]) to within
    `goal_tolerance_m` [m] of its last, under `robot` (RobotKinematics or a robot model); the
    slow zones against the walls of `patrol_map` (None: no walls)."""
    kin = RobotKinematics.of(robot)
    model = _Model(kin, float(goal_tolerance_m),
                   None if patrol_map is None else _Walls(patrol_map), _TurnTable(kin))
    h = None if heading is None else np.array([math.cos(heading), math.sin(heading)])
    return model.traversal(np.asarray(path, dtype=float), None, h)[0]


def _paths(patrol_map: Any, planner: Any) -> dict[tuple[int, int], np.ndarray]:
    """The planned path of every graph edge, both directions (the reverse of the u < v path),
    from the planner's edge cache. MapError for an edge without a collision-free path."""
    from tpuaf.errors import MapError

    checks = planner.check_edges()
    ids = patrol_map.vertex_ids
    blocked = [f"{ids[c.u]}-{ids[c.v]}" for c in checks if not math.isfinite(c.planned_m)]
    if blocked:
        raise MapError(f"map '{patrol_map.name}': no collision-free path for a robot of radius "
                       f"{planner.robot_radius_m:g} m along edge(s) {', '.join(blocked[:10])}")
    out = {}
    for c in checks:
        path = np.asarray(planner.edge_path(c.u, c.v), dtype=float)
        out[(c.u, c.v)] = path
        out[(c.v, c.u)] = path[::-1].copy()
    return out


def arrival_durations(patrol_map: Any, robot: Any, planner: Any,
                      goal_tolerance_m: float | None = None
                      ) -> dict[tuple[int, int, int], float]:
    """[s] per directed edge (u, v) and way of arriving at u, from w (the last leg of edge
    (w, u); w = v: the robot turns back): the modelled traversal time of u -> v (vertex
    indices). At a start (no arrival) the robot faces the first leg."""
    kin = RobotKinematics.of(robot)
    # A leg ends when the robot is within the visit radius (the navigator's goal tolerance).
    tol = float(patrol_map.visit_radius_m if goal_tolerance_m is None else goal_tolerance_m)
    model = _Model(kin, tol, _Walls(patrol_map), _TurnTable(kin))
    paths = _paths(patrol_map, planner)
    into: dict[int, list[int]] = {}
    for (a, b) in paths:
        into.setdefault(b, []).append(a)
    # How each edge ends: the end point and heading of its traversal (from rest, no history).
    ends = {e: model.traversal(p)[1:] for e, p in paths.items()}
    out = {}
    for (u, v), path in paths.items():
        for w in into[u]:
            end, heading = ends[(w, u)]
            out[(w, u, v)] = model.traversal(path, end, heading)[0]
    return out


def directed_durations(patrol_map: Any, robot: Any, planner: Any,
                       goal_tolerance_m: float | None = None,
                       arrivals: dict[tuple[int, int, int], float] | None = None
                       ) -> dict[tuple[int, int], float]:
    """[s] per directed edge (u, v) (vertex indices, both directions): the mean over the ways
    of arriving at u (see the module docstring; `arrival_durations`, given or computed) of the
    modelled traversal time to v."""
    if arrivals is None:
        arrivals = arrival_durations(patrol_map, robot, planner, goal_tolerance_m)
    ways: dict[tuple[int, int], dict[int, float]] = {}
    for (w, u, v), seconds in arrivals.items():
        ways.setdefault((u, v), {})[w] = seconds
    # not turning back, unless u is a dead end
    return {e: float(statistics.fmean([s for w, s in by.items() if w != e[1]] or [by[e[1]]]))
            for e, by in ways.items()}


def edge_durations(patrol_map: Any, robot: Any, planner: Any,
                   arrivals: dict[tuple[int, int, int], float] | None = None
                   ) -> dict[tuple[int, int], float]:
    """[s] per graph edge (u, v) as in `patrol_map.edges` (vertex indices): the modelled
    travel time of `robot` (RobotKinematics, or a robot model) along the planner's path, the
    mean of both directions."""
    directed = directed_durations(patrol_map, robot, planner, arrivals=arrivals)
    return {(int(i), int(j)): 0.5 * (directed[(int(i), int(j))] + directed[(int(j), int(i))])
            for i, j, _ in patrol_map.edges}


def turn_times(arrivals: dict[tuple[int, int, int], float],
               durations: dict[tuple[int, int], float]) -> dict[tuple[int, int, int], float]:
    """[s] per (w, u, v): what arriving at u from w adds to edge u-v's duration (`durations`,
    undirected): the turn at u, and the direction, against the edge's mean (negative: faster,
    e.g. straight on). Entries under 1 ms are left out."""
    out = {}
    for (w, u, v), seconds in arrivals.items():
        mean = durations[(u, v)] if (u, v) in durations else durations[(v, u)]
        if abs(seconds - mean) >= 1e-3:
            out[(w, u, v)] = float(seconds - mean)
    return out


def timed_map(patrol_map: Any, robot: Any, planner: Any,
              durations: dict[tuple[int, int], float] | None = None) -> Any:
    """A copy of `patrol_map` whose nominal speed is the robot's cruise speed v and whose edge
    lengths are v x the edge's duration (`durations`, default `edge_durations`): every consumer
    that computes length / speed gets the modelled travel time; its `turns` (`turn_times`) say
    how each way of arriving at an edge's first vertex changes that time (a turn back)."""
    kin = RobotKinematics.of(robot)
    speed = kin.max_linear_speed
    arrivals = arrival_durations(patrol_map, kin, planner)
    times = edge_durations(patrol_map, kin, planner, arrivals) if durations is None else durations
    edges = []
    for i, j, _ in patrol_map.edges:
        key = (int(i), int(j))
        seconds = times[key] if key in times else times[(key[1], key[0])]
        edges.append((i, j, speed * float(seconds)))
    return replace(patrol_map, edges=edges, turns=turn_times(arrivals, times),
                   settings=replace(patrol_map.settings, nominal_speed=speed),
                   notes=[*patrol_map.notes,
                          f"edge lengths: {speed:g} m/s x modelled travel times of a robot of "
                          f"radius {kin.radius_m:g} m (navigation/travel_time.py)"])


# ---------------------------------------------------------------------------------------------
# Learned durations

MIN_SAMPLES = 3  # traversals of an edge before its measured median replaces the model's figure


class EdgeDurations:
    """Per-edge durations [s] learned from the robot's own traversals: the median of the
    measured ones once an edge has been driven MIN_SAMPLES times (either direction), else the
    model's figure (`model`: {(u, v): s}, e.g. `edge_durations`)."""

    def __init__(self, model: dict[tuple[int, int], float], min_samples: int = MIN_SAMPLES,
                 max_samples: int = 50):
        self.model = {_key(*e): float(s) for e, s in model.items()}
        self.min_samples = int(min_samples)
        self.max_samples = int(max_samples)  # the latest ones kept per edge
        self._samples: dict[tuple[int, int], list[float]] = {}

    def add(self, u: int, v: int, seconds: float) -> None:
        """A measured traversal of edge u-v [s] (ignored unless finite and > 0)."""
        if not (math.isfinite(seconds) and seconds > 0):
            return
        samples = self._samples.setdefault(_key(u, v), [])
        samples.append(float(seconds))
        if len(samples) > self.max_samples:
            del samples[0]

    def samples(self, u: int, v: int) -> int:
        return len(self._samples.get(_key(u, v), ()))

    def measured(self) -> dict[tuple[int, int], list[float]]:
        """Every edge driven so far (u < v): its kept traversal times [s]."""
        return {e: list(s) for e, s in self._samples.items()}

    def duration(self, u: int, v: int) -> float:
        """[s] of edge u-v: the measured median, or the model's figure (KeyError: unknown)."""
        samples = self._samples.get(_key(u, v), ())
        if len(samples) >= self.min_samples:
            return float(statistics.median(samples))
        return self.model[_key(u, v)]

    def __getitem__(self, edge: tuple[int, int]) -> float:
        return self.duration(*edge)

    def as_dict(self) -> dict[tuple[int, int], float]:
        """Every edge of the model: its current duration [s]."""
        return {e: self.duration(*e) for e in self.model}


def _key(u: int, v: int) -> tuple[int, int]:
    return (int(u), int(v)) if u <= v else (int(v), int(u))
