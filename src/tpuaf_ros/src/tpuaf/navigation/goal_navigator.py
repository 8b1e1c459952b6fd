"""Route + an external planner (move_base): `GoalNavigator` sends each waypoint as a goal."""

from __future__ import annotations

import math

import numpy as np

from tpuaf.navigation.controller import GOAL_TOLERANCE_M, STOP_FAILED, Command, Status
from tpuaf.navigation.navigator import Event
from tpuaf.navigation.route import GraphRoute


class GoalClient:
    """What `GoalNavigator` needs from a planner's action client (the rospy adapter is
    tpuaf.ros.move_base.MoveBaseClient). `state()` is one of 'idle', 'active', 'succeeded',
    'failed'."""

    def send(self, x: float, y: float, yaw: float) -> None:  # pragma: no cover - interface
        raise NotImplementedError

    def cancel(self) -> None:  # pragma: no cover - interface
        raise NotImplementedError

    def state(self) -> str:  # pragma: no cover - interface
        raise NotImplementedError


class GoalNavigator:
    """Follows a `GraphRoute` by sending each waypoint as a goal to an external planner
    (move_base drives the robot; the agent publishes no cmd_vel). Events as `Navigator`:
    a waypoint is passed within `waypoint_tolerance`, the goal reached within
    `goal_tolerance` [m] of the pose (the agents: the map's visit radius, whatever the planner's
    own tolerance), and the goal fails when the planner aborts or the robot makes no progress of
    `progress_m` for `stuck_timeout_s` [s]; within `near_goal_m` [m] (the goal tolerance) of the
    goal it ends short instead (ARRIVED; the visit rule makes it a dwell)."""

    def __init__(self, client: GoalClient, goal_tolerance: float = GOAL_TOLERANCE_M,
                 waypoint_tolerance: float = 0.6, stuck_timeout_s: float = 60.0,
                 progress_m: float = 0.15, near_goal_m: float | None = None):
        self.client = client
        self.near_goal_m = near_goal_m  # [m]
        self.short_arrivals = 0
        self.goal_tolerance = float(goal_tolerance)
        self.waypoint_tolerance = float(waypoint_tolerance)
        self.stuck_timeout_s = float(stuck_timeout_s)
        self.progress_m = float(progress_m)
        self.route: GraphRoute | None = None
        self._target: tuple[float, float] | None = None
        self._best = math.inf
        self._best_t = 0.0
        self.goals_sent = 0

    def set_route(self, route: GraphRoute, t: float) -> None:
        self.route = route
        self._aim(t)

    def cancel(self) -> None:
        if self.route is not None:
            self.client.cancel()
        self.route = None
        self._target = None

    def pause(self) -> None:
        """Stale inputs: stop the planner (the route is kept; `resume` sends the goal again)."""
        if self.route is not None:
            self.client.cancel()

    def resume(self, t: float) -> None:
        if self.route is not None and self._target is not None:
            self._aim(t)

    def _aim(self, t: float) -> None:
        route = self.route
        x, y = route.next_position()
        k = route._k
        prev = route.positions[route.waypoints[k - 1] if k > 0 else route.start]
        yaw = math.atan2(y - prev[1], x - prev[0]) if (x, y) != tuple(prev) else 0.0
        self._target = (x, y)
        self._best, self._best_t = math.inf, float(t)
        self.client.send(x, y, yaw)
        self.goals_sent += 1

    def step(self, t: float, pose: tuple[float, float, float],
             points: np.ndarray | None = None) -> tuple[Command, Event, int]:
        route = self.route
        if route is None:
            return Command(0.0, 0.0, Status.REACHED), Event.NONE, -1
        idle = Command(0.0, 0.0, Status.DRIVING)
        last = route.is_last
        d = math.hypot(self._target[0] - pose[0], self._target[1] - pose[1])
        state = self.client.state()
        tol = self.goal_tolerance if last else self.waypoint_tolerance
        if d <= tol or (state == "succeeded" and not last and d <= 2 * tol):
            vertex = route.advance()
            if last:
                self.cancel()  # the visit counts here; move_base may still be fine-tuning
                return Command(0.0, 0.0, Status.REACHED), Event.ARRIVED, vertex
            self._aim(t)
            return idle, Event.WAYPOINT, vertex
        if d < self._best - self.progress_m or self._best == math.inf:
            self._best, self._best_t = d, float(t)
        stuck = t - self._best_t > self.stuck_timeout_s
        if state == "failed" or stuck or (state == "succeeded" and last):
            goal = route.goal
            if last and self.near_goal_m is not None and d <= self.near_goal_m:
                self.short_arrivals += 1
                route.advance()
                self.cancel()
                return Command(0.0, 0.0, Status.REACHED), Event.ARRIVED, goal
            self.cancel()
            return STOP_FAILED, Event.FAILED, goal
        return idle, Event.NONE, -1
