"""The agent runtime: one robot's policy and navigator on a live clock (ROS-free).

The `patrol_agent` node feeds it poses (`on_pose`), team messages of the other robots
(`on_message`) and laser ticks (`tick`, which returns the velocity command). It implements
`RobotContext` for the policy exactly as the batch runtime does: `decide` on reaching the goal
vertex and at requested wake-up times, `on_goal_failed` when the navigator gives up. Times are
seconds of run time (ROS time minus the run epoch).

Events for the monitor (`publish_event(kind, vertex, from_vertex, t)`, vertices as indices):
START at the first pose, GOAL on every new goal, REACHED, FAILED, HEARTBEAT every
`heartbeat_period_s`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ..navigation import (
    ControllerConfig,
    Event,
    GraphRoute,
    LocalController,
    Navigator,
)
from ..policies import Policy, RobotContextBase
from ..topics import FAILED, GOAL, HEARTBEAT, REACHED, START
from .graph import DEFAULT_RETRY_S, STAY_S


class AgentRuntime(RobotContextBase):
    """RobotContext of one robot; see the module docstring."""

    def __init__(self, patrol_map: Any, policy: Policy, robot: int, n_robots: int, seed: int,
                 publish_team: Callable[[Any], None],
                 publish_event: Callable[[int, int, int, float], None],
                 controller: ControllerConfig | None = None, heartbeat_period_s: float = 1.0,
                 waypoint_tolerance_m: float = 0.6):
        self.robot = int(robot)
        self.n_robots = int(n_robots)
        self.patrol_map = patrol_map
        self.rng = np.random.default_rng([int(seed), 2, self.robot])  # as in batch
        self.policy = policy
        self._publish_team = publish_team
        self._publish_event = publish_event
        self.heartbeat_period_s = float(heartbeat_period_s)
        self.goal_tolerance = float(patrol_map.settings.goal_tolerance)
        self.navigator = Navigator(LocalController(controller), self.goal_tolerance,
                                   waypoint_tolerance_m)
        self._graph = patrol_map.graph
        self._positions = np.asarray(patrol_map.positions, dtype=float)
        self._now = 0.0
        self._pose: tuple[float, float, float] | None = None
        self._pose_t: float | None = None
        self._start_vertex = -1
        self._start_position = (math.nan, math.nan)
        self._current = -1
        self.goal: int | None = None
        self._stay_until: float | None = None
        self._wake: float | None = None
        self._redirect: int | None = None  # a new goal asked for while driving
        self._next_heartbeat = -math.inf
        self.started = False
        self.start_at: float | None = 0.0  # [s] run time to begin patrolling; None = not yet known
        self.travelled_m = 0.0
        self.travel_time_s = 0.0
        self.visits = 0
        self.failures = 0

    # --- RobotContext ---
    @property
    def now(self) -> float:
        return self._now

    @property
    def position(self) -> tuple[float, float]:
        return (self._pose[0], self._pose[1]) if self._pose else self._start_position

    def send(self, message: Any) -> None:
        self._publish_team(message)

    def wake_at(self, time: float) -> None:
        self._wake = max(float(time), self._now)

    def change_goal(self, vertex: int) -> None:
        """Redirect while driving: at the next vertex passed, head to `vertex` instead."""
        self._redirect = self.checked_vertex(vertex)

    # --- inputs ---
    def on_pose(self, t: float, x: float, y: float, th: float) -> None:
        """Localisation (map frame) at run time t [s]."""
        if self._pose is not None and self.goal is not None and self._stay_until is None:
            dt = t - self._pose_t
            if dt > 0:
                self.travelled_m += math.hypot(x - self._pose[0], y - self._pose[1])
                self.travel_time_s += dt
        self._pose = (float(x), float(y), float(th))
        self._pose_t = float(t)

    def on_message(self, message: Any) -> None:
        """A team message from another robot (the node filters out our own)."""
        if self.started and getattr(message, "robot", -1) != self.robot:
            self.policy.on_message(message, self)

    def tick(self, t: float, points: np.ndarray | None) -> tuple[float, float]:
        """One control step at run time t [s] with laser points (k, 2) in the robot frame;
        returns (v [m/s], w [rad/s])."""
        self._now = max(self._now, float(t))
        if self._pose is None:
            return 0.0, 0.0
        if self._now >= self._next_heartbeat:  # also before the start: "ready"
            self._event(HEARTBEAT, self.goal if self.goal is not None else -1, self._current)
            self._next_heartbeat = self._now + self.heartbeat_period_s
        if not self.started:
            if self.start_at is None or self._now < self.start_at:
                return 0.0, 0.0
            self._start()
        if self.goal is None:
            if self._wake is not None and self._now >= self._wake:
                self._wake = None
                self._decide()
            if self.goal is None:
                return 0.0, 0.0
        if self._stay_until is not None:
            if self._now < self._stay_until:
                return 0.0, 0.0
            self._stay_until = None
            self._arrive(self.goal)
            if self.goal is None or self._stay_until is not None:
                return 0.0, 0.0
        cmd, event, vertex = self.navigator.step(self._now, self._pose, points)
        if event == Event.WAYPOINT:
            self._current = vertex
            if self._redirect is not None:
                self._set_goal(self._redirect)
        elif event == Event.ARRIVED:
            self._arrive(vertex)
            if self.goal is None or self._stay_until is not None:
                return 0.0, 0.0
            cmd, _, _ = self.navigator.step(self._now, self._pose, points)
        elif event == Event.FAILED:
            self.failures += 1
            self._event(FAILED, vertex, self._current)
            self.goal = None
            self._current = self.patrol_map.nearest_vertex(*self.position)
            self.policy.on_goal_failed(vertex, self)
            self._decide()
            return 0.0, 0.0
        return cmd.v, cmd.w

    # --- internals ---
    def _event(self, kind: int, vertex: int, from_vertex: int, t: float | None = None) -> None:
        self._publish_event(kind, int(vertex), int(from_vertex), self._now if t is None else t)

    def _start(self) -> None:
        x, y, _ = self._pose
        self._start_vertex = self._current = self.patrol_map.nearest_vertex(x, y)
        p = self._positions[self._start_vertex]
        self._start_position = (float(p[0]), float(p[1]))
        self.started = True
        self._event(START, self._start_vertex, -1)
        self.policy.start(self)
        self._decide()

    def _arrive(self, vertex: int) -> None:
        self._current = vertex
        self.goal = None
        self.visits += 1
        self._event(REACHED, vertex, vertex)
        self._decide()

    def _decide(self) -> None:
        self._wake = None
        self._redirect = None
        goal = self.call_decide(self.policy)
        if goal is None:
            self.goal = None
            self.navigator.cancel()
            if self._wake is None:
                self._wake = self._now + DEFAULT_RETRY_S
            return
        self._set_goal(goal)

    def _set_goal(self, goal: int) -> None:
        """Drive to `goal` from the current vertex (announced to the monitor by a GOAL event)."""
        self._redirect = None
        self.goal = goal
        here = self._current
        x, y = self.position
        p = self._positions[goal]
        if goal == here and math.hypot(x - p[0], y - p[1]) <= self.goal_tolerance:
            # Dwell, then visit again (as batch). The GOAL event is stamped just before the
            # dwell ends, so the monitor counts the visit at the dwell's end.
            self._stay_until = self._now + STAY_S
            self.navigator.cancel()
            self._event(GOAL, goal, here, t=self._stay_until - 0.01)
            return
        route = GraphRoute(self._graph, self._positions, here, goal, from_position=(x, y),
                           snap_m=self.navigator.waypoint_tolerance)
        self.navigator.set_route(route, self._now)
        self._event(GOAL, goal, here)
