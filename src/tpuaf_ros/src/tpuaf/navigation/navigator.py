"""Navigators: follow a `GraphRoute` with the local controller, or with an external planner
(move_base) through a goal client. Same interface, ROS-free."""

from __future__ import annotations

import math
from enum import Enum

import numpy as np

from tpuaf.navigation.controller import STOP_FAILED, Command, LocalController, Status
from tpuaf.navigation.route import GraphRoute

# ---------------------------------------------------------------------------------------------
# Navigator: route + controller


class Event(Enum):
    NONE = 0
    WAYPOINT = 1  # passed a waypoint that is not the goal
    ARRIVED = 2  # within goal tolerance of the goal vertex
    FAILED = 3  # gave up on the goal


class Navigator:
    """Follows a `GraphRoute` with a `LocalController`.

    Pass-through waypoints count as reached within `waypoint_tolerance` [m], the goal within
    `goal_tolerance` [m] (SPEC: 0.4 m). `step` returns (Command, Event, vertex): the vertex is
    the waypoint or goal reached, or the goal that failed."""

    def __init__(self, controller: LocalController, goal_tolerance: float = 0.4,
                 waypoint_tolerance: float = 0.6):
        self.controller = controller
        self.goal_tolerance = float(goal_tolerance)
        self.waypoint_tolerance = float(waypoint_tolerance)
        self.route: GraphRoute | None = None

    def set_route(self, route: GraphRoute, t: float) -> None:
        self.route = route
        self._aim(t, new_goal=True)

    def cancel(self) -> None:
        self.route = None
        self.controller.target = None

    def pause(self) -> None:
        """The robot is stopped by its runtime (stale inputs); nothing to do here."""

    def resume(self, t: float) -> None:
        """After a pause (stale inputs, robot stopped): restart the progress watch at t [s], so
        the standstill does not count as being stuck."""
        self.controller.restart_progress(t)

    def _aim(self, t: float, new_goal: bool) -> None:
        route = self.route
        tol = self.goal_tolerance if route.is_last else self.waypoint_tolerance
        self.controller.set_target(route.next_position(), tol, t, new_goal=new_goal)

    def step(self, t: float, pose: tuple[float, float, float],
             points: np.ndarray | None) -> tuple[Command, Event, int]:
        route = self.route
        if route is None:
            return Command(0.0, 0.0, Status.REACHED), Event.NONE, -1
        cmd = self.controller.step(t, pose, points)
        if cmd.status == Status.FAILED:
            goal = route.goal
            self.cancel()
            return cmd, Event.FAILED, goal
        if cmd.status != Status.REACHED:
            return cmd, Event.NONE, -1
        last = route.is_last
        vertex = route.advance()
        if last:
            self.cancel()
            return cmd, Event.ARRIVED, vertex
        self._aim(t, new_goal=False)
        # Steer toward the next waypoint right away (no standstill tick at a pass-through).
        cmd = self.controller.step(t, pose, points)
        return cmd, Event.WAYPOINT, vertex


# ---------------------------------------------------------------------------------------------
# Navigation by an external planner (move_base): same interface as Navigator


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
    `goal_tolerance` [m] of the pose (the one definition of a visit, whatever the planner's own
    tolerance), and the goal fails when the planner aborts or the robot makes no progress of
    `progress_m` for `stuck_timeout_s` [s]."""

    def __init__(self, client: GoalClient, goal_tolerance: float = 0.4,
                 waypoint_tolerance: float = 0.6, stuck_timeout_s: float = 60.0,
                 progress_m: float = 0.15):
        self.client = client
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
            self.cancel()
            return STOP_FAILED, Event.FAILED, goal
        return idle, Event.NONE, -1
