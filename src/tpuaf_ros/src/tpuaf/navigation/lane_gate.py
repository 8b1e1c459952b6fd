"""The navigator's side of the lane layer (docs/LANES.md): `LaneGate`, a part of `Navigator`.

A leg into a lane starts only at the lane's waiting spot (the route's vertex before the lane,
reached within GATE_TOLERANCE_M rather than the pass-through tolerance) and only once the
robot holds the lane (`lanes.may_start`, robot/lanes.py). Meanwhile the robot stands at the
spot, making room for a robot that comes up to it (`park_step`); second in a queue of waiting
robots, it waits at a refuge off the way out of the lane (give_way.find_refuge), so that the
robot before it can drive in and the holder out.
"""

from __future__ import annotations

import numpy as np

from tpuaf.navigation.controller import Command, Status
from tpuaf.navigation.give_way import find_refuge
from tpuaf.navigation.route import GraphRoute

GATE_TOLERANCE_M = 0.15  # [m] a lane's waiting spot is reached within this (at least goal tol.)
LANE_MOUTH_M = 0.5  # [m] along the lane from its waiting spot: where a robot comes out of it
GATE_REFUGE_TOLERANCE_M = 0.08  # [m] the waiting point off the way is reached within this
FOLLOW_MAX_S = 30.0  # [s] longest wait behind a robot ahead in a one-way lane, in a row
LANE_CHECK_STEP_M = 0.05  # [m] between the checked points of a path off the route


def along(path: np.ndarray, step: float) -> np.ndarray:
    """The points of a polyline (k, 2) [m] after its first, at most `step` [m] apart."""
    out = []
    for a, b in zip(path[:-1], path[1:], strict=True):
        n = max(1, int(np.ceil(np.hypot(*(b - a)) / step)))
        out.append(a + (b - a) * (np.arange(1, n + 1) / n)[:, None])
    return np.vstack(out) if out else path[1:]


def around(route: GraphRoute) -> tuple[int | None, int, int | None]:
    """(previous, next, following) vertex of a route's next waypoint (None: none)."""
    k = route._k
    prev = route.waypoints[k - 1] if k > 0 else route.start
    nxt = route.waypoints[k + 1] if k + 1 < len(route.waypoints) else None
    return (None if prev == route.waypoints[k] else prev), route.waypoints[k], nxt


class LaneGate:
    """Navigator methods of the lane layer (state: `lanes`, `_gate`, `_gate_corners`,
    `_follow_since`)."""

    _follow_since: float | None = None  # [s] since when waiting behind a robot in a lane

    def _gate_tolerance(self, route: GraphRoute, tol: float) -> float:
        """[m] the tolerance of the next waypoint: tight when the route enters a lane there."""
        if self.lanes is not None and not route.is_last and self.lanes.enters(*around(route)):
            return min(tol, max(self.goal_tolerance, GATE_TOLERANCE_M))
        return tol

    def _driven_lane(self) -> int:
        """The one-way lane the robot's current leg drives along its arc (held by the driver:
        it may wait, give way or go round inside it), -1 when none."""
        if self.lanes is None or self.route is None or self.route.done:
            return -1
        prev, nxt, _ = around(self.route)
        return self.lanes.driven(prev, nxt)

    @property
    def _lane_free(self):
        """Where the robot may stand or drive off its route: outside the lanes it does not
        hold (a mask function of points (k, 2) [m]); None without lanes."""
        if self.lanes is None:
            return None
        driven = self._driven_lane()
        return lambda points: self.lanes.allowed(points, driven)

    def _lane_free_path(self, path: np.ndarray) -> bool:
        """Whether a path off the route (a way round another robot, a refuge) keeps out of
        the lanes the robot does not hold: every point along it, LANE_CHECK_STEP_M apart
        (a straight path's two ends can lie outside the lane it runs through)."""
        if self.lanes is None:
            return True
        points = along(np.asarray(path, dtype=float), LANE_CHECK_STEP_M)
        return bool(self.lanes.allowed(points, self._driven_lane()).all())

    def _gate_wait(self, t: float, pose: tuple[float, float, float], points, u: int, nxt: int,
                   obstacles) -> Command:
        """The command while waiting for the lane of u -> nxt at its waiting spot u (see the
        module docstring); `obstacles`: discs (x, y, r) [m] of what the map does not explain."""
        if self._gate_corners is None and self.lanes.queued_behind_waiter(u, nxt):
            self._gate_corners = self._waiting_point(pose, u, nxt, obstacles)
        if self._gate_corners:  # to the waiting point, off the way out of the lane
            ctl = self.controller
            ctl.set_target(self._gate_corners[0], GATE_REFUGE_TOLERANCE_M, t, new_goal=False)
            cmd = ctl.step(t, pose, points)
            if cmd.status == Status.REACHED:
                self._gate_corners.pop(0)
            elif cmd.status in (Status.RECOVERING, Status.FAILED):
                self._gate_corners = []  # wait where we are
                ctl.resume_driving(t)
            else:
                return cmd
        v, w = self.park_step(t, pose, points)
        if self._give_way is not None:  # making room: back to the spot afterwards
            advance = self._gate[1]
            self._gate = self._gate_corners = None
            if not advance:  # the spot becomes a waypoint again, reached before the lane
                self.route.waypoints.insert(self.route._k, u)
        return Command(v, w, Status.DRIVING)

    def _following(self, t: float, pose: tuple[float, float, float], ahead: np.ndarray) -> bool:
        """Is what holds us ahead (map-frame points [m]) a robot in the one-way lane we drive
        along its arc (docs/LANES.md, section 2b)? Then the robot waits behind it, at most
        FOLLOW_MAX_S in a row (then the give-way and recovery rules act as without lanes).
        Not when the robot aims against the arc (it stands past the leg's far end)."""
        if self.lanes is None or self.route is None or self.route.done:
            return False
        prev, nxt, _ = around(self.route)
        if prev is None or not self.lanes.follows(prev, nxt, ahead):
            self._follow_since = None
            return False
        arc = self.route.positions[nxt] - self.route.positions[prev]
        aim = np.asarray(self.controller.target or self.route.next_position()) - pose[:2]
        if float(arc @ aim) <= 0.0:  # aiming against the lane's flow: no right to wait
            return False
        if self._follow_since is None:
            self._follow_since = t
        return t - self._follow_since <= FOLLOW_MAX_S

    def _waiting_point(self, pose: tuple[float, float, float], u: int, nxt: int,
                       obstacles) -> list[tuple[float, float]]:
        """The corners to a refuge near u off the way of a robot that comes out of the lane
        u -> nxt; [] to wait where we stand."""
        path = self.planner.edge_path(u, nxt) if self.planner is not None else None
        if path is None or len(path) < 2:
            return []
        k = int(np.searchsorted(np.cumsum(np.hypot(*np.diff(path, axis=0).T)), LANE_MOUTH_M))
        mouth = tuple(float(c) for c in path[min(k + 1, len(path) - 1)])
        refuge = find_refuge(self.planner, (float(pose[0]), float(pose[1])), mouth, [],
                             self._pass_clearance_m(), obstacles, allowed=self._lane_free)
        return [] if refuge is None else [(float(x), float(y)) for x, y in refuge[1:]]
