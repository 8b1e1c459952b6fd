"""The agent runtime: one robot's policy and navigator on a live clock (ROS-free).

The `patrol_agent` node (and the physics runtime, once per robot) feeds it poses (`on_pose`),
team messages of the other robots (`on_message`), what it hears of them for liveness (`hear`:
every team message and heartbeat; `check_liveness` when due, which tells the policy of a
teammate silent for `teammate_timeout_s`) and control ticks with laser points (`tick`, which
returns the velocity command). The robot protocol is the shared `RobotMachine`
(robot/machine.py, over the core's `RobotProtocol`): this class is its driver, with the run
clock of the ticks, `publish_team` as transport and the `Navigator` (route + local controller)
as motion. Times are seconds of run time (ROS time minus the run epoch).

Events for the monitor (`publish_event(kind, vertex, from_vertex, t)`, vertices as indices):
START at the start (the start vertex's first visit), GOAL on every new goal, REACHED (a visit:
tpuaf_core.VisitRule on the robot's poses), DWELL (a goal ended without a visit), FAILED,
HEARTBEAT every `heartbeat_period_s` while alive, STUCK (a navigator recovery), GIVE_WAY (a refuge
driven to, to let another robot pass). The navigator ends a route within the map's
visit radius of the goal; a robot held near its goal by another robot (within the goal
tolerance) ends it there, short: a DWELL, not a visit.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from tpuaf.navigation import (
    ControllerConfig,
    Event,
    GraphRoute,
    LocalController,
    Navigator,
    moved_points,
)
from tpuaf.params import LIVENESS_DEFAULTS
from tpuaf.policies import Policy
from tpuaf.robot.machine import DEFAULT_RETRY_S, STAY_S, RobotMachine
from tpuaf.team.liveness import HEARTBEAT_PERIOD_S
from tpuaf.team.messages import well_formed
from tpuaf.topics import GIVE_WAY, HEARTBEAT, STUCK

__all__ = ["DEFAULT_RETRY_S", "STAY_S", "AgentRuntime"]

MAX_EVENTS_PER_TICK = 4  # navigator events handled in one control tick


class AgentRuntime:
    """Driver of one robot's `RobotMachine` (see the module docstring). Attributes of the
    machine (the policy's RobotContext: now, position, current_vertex, goal, visits, ...) are
    readable here too."""

    def __init__(self, patrol_map: Any, policy: Policy, robot: int, n_robots: int, seed: int,
                 publish_team: Callable[[Any], None],
                 publish_event: Callable[[int, int, int, float], None],
                 controller: ControllerConfig | None = None,
                 heartbeat_period_s: float = HEARTBEAT_PERIOD_S, waypoint_tolerance_m: float = 0.6,
                 planner: Any = None,
                 teammate_timeout_s: float = LIVENESS_DEFAULTS.teammate_timeout_s):
        self._publish_team = publish_team
        self._publish_event = publish_event
        self.heartbeat_period_s = float(heartbeat_period_s)
        # [m] a leg ends within the visit radius of its goal; held by another robot, within the
        # goal tolerance (short: no visit)
        self.goal_tolerance = float(patrol_map.settings.goal_tolerance)
        self.visit_radius = patrol_map.visit_radius_m
        # planner: a navigation.PathPlanner (paths on the occupancy grid) or None (straight
        # edges, e.g. a map without walls in the tests).
        self.navigator = Navigator(LocalController(controller), self.visit_radius,
                                   waypoint_tolerance_m, planner, robot_index=robot,
                                   near_goal_m=self.goal_tolerance)
        self._graph = patrol_map.graph
        self._positions = np.asarray(patrol_map.positions, dtype=float)
        # [s] run time of the last tick; negative before the start when the team's epoch lies
        # ahead of our clock (a teammate whose clock is ahead announced it): heartbeats are then
        # stamped with the true time, not the epoch (which looked like clock skew)
        self._now = -math.inf
        self._pose: tuple[float, float, float] | None = None
        self._stay_until: float | None = None
        self._stay_vertex = -1  # the vertex visited when the stay ends
        self._unreachable: int | None = None  # a goal no route reaches: it fails next tick
        self._cut_off: frozenset[int] = frozenset()  # vertices a dead robot's body blocks
        self._wakes: list[float] = []  # requested wake-up times [s] (a heap)
        self._decide_pending = False
        self._next_heartbeat = -math.inf
        self.start_at: float | None = 0.0  # [s] run time to begin patrolling; None = not yet known
        # Called with (goal vertex, retry number, run time [s]) when the navigator starts a
        # recovery (stuck: back off, wait, replan): the node logs it, the physics runtime counts.
        self.on_stuck: Callable[[int, int, float], None] | None = None
        self.recoveries = 0
        self._retries_seen = 0
        self._give_ways_seen = 0
        rng = np.random.default_rng([int(seed), 2, int(robot)])  # as in the graph runtime
        self.machine = RobotMachine(self, robot, n_robots, patrol_map, policy, rng,
                                    emit=self._event, teammate_timeout_s=teammate_timeout_s)

    def __getattr__(self, name: str) -> Any:
        # Only for names not found on the runtime: the machine's (RobotContext) attributes.
        if name == "machine":
            raise AttributeError(name)
        return getattr(self.machine, name)

    # --- the policy context, for callers that hand this runtime to a policy ---
    @property
    def now(self) -> float:
        return max(self._now, 0.0)  # the policies' clock starts at 0

    @property
    def position(self) -> tuple[float, float]:
        return self.position_of(self.machine.robot)

    def send(self, message: Any) -> None:
        self.machine.send(message)

    def wake_at(self, time: float) -> None:
        self.machine.wake_at(time)

    def change_goal(self, vertex: int) -> None:
        """Redirect while driving: at the next vertex passed, head to `vertex` instead."""
        self.machine.change_goal(vertex)

    # --- RobotDriver ---
    def position_of(self, robot: int) -> tuple[float, float]:
        return (self._pose[0], self._pose[1]) if self._pose else self.machine.start_position

    def transmit(self, robot: int, message: Any) -> None:
        self._publish_team(message)

    def schedule_wake(self, robot: int, time: float) -> None:
        heapq.heappush(self._wakes, float(time))

    def drive(self, robot: int, from_vertex: int, goal: int) -> None:
        self._stay_until = None
        if goal != from_vertex and self.machine.within(goal):
            # Already within the visit radius of another vertex (two vertices closer than
            # it): stand there STAY_S, as on a goal equal to the current vertex; the VisitRule
            # then says whether it is a visit.
            self.navigator.cancel()
            self._stay_until = self._now + STAY_S
            self._stay_vertex = int(goal)
            return
        start = self._route_start(from_vertex, goal) if self._graph.one_way else from_vertex
        if int(goal) in self._cut_off or not math.isfinite(self._graph.distance(start, goal)):
            # cut off (a dead robot's body next to it, robot/lanes.py; a route to it would end
            # at the body) or, never on a connected plan, unreachable: the goal fails at the
            # next tick, without moving
            self.navigator.cancel()
            self._unreachable = int(goal)
            return
        route = GraphRoute(self._graph, self._positions, start, goal,
                           from_position=self.position, snap_m=self.navigator.waypoint_tolerance)
        self.navigator.set_route(route, self._now)

    def replan(self, plan_map: Any) -> None:
        """Route on `plan_map`'s graph from now on (a lane blocked: robot/lanes.py), and the
        policy re-plans on it; a route under way is re-planned from where the robot is. Goals
        at the map's `closed` vertices (a dead robot's body too near them) fail at once."""
        self._graph = plan_map.graph
        self._cut_off = frozenset(int(v) for v in plan_map.closed)
        self.machine.replan(plan_map)
        goal = self.machine.goal
        if self.navigator.route is not None and goal is not None and self._stay_until is None:
            self.drive(self.machine.robot, self.machine.current_vertex, goal)

    def _route_start(self, from_vertex: int, goal: int) -> int:
        """With one-way lanes: the vertex a route starts from when the robot stands away from
        `from_vertex` (a leg ended short or failed): of the vertices within twice the snap
        distance, the one of least straight distance to it plus directed path to `goal` [m],
        so that the robot does not drive back against the flow to where it came from."""
        x, y = self.position
        reach = 2.0 * self.navigator.waypoint_tolerance
        d = np.hypot(self._positions[:, 0] - x, self._positions[:, 1] - y)
        if d[from_vertex] <= self.navigator.waypoint_tolerance:
            return from_vertex
        near = [int(v) for v in np.flatnonzero(d <= reach)] or [from_vertex]
        return min(near, key=lambda v: d[v] + self._graph.distance(v, goal))

    def dwell(self, robot: int, vertex: int, duration_s: float) -> None:
        self.navigator.cancel()
        self._stay_until = self._now + duration_s
        self._stay_vertex = int(vertex)

    @property
    def pose(self) -> tuple[float, float, float] | None:
        """The last localisation (x [m], y [m], yaw [rad]), map frame; None before any."""
        return self._pose

    @property
    def staying(self) -> bool:
        """Standing at a vertex until a stay ends (a dwell, or a goal already within tolerance)."""
        return self._stay_until is not None

    def halt(self, robot: int) -> None:
        self.navigator.cancel()
        self._stay_until = None

    # --- inputs ---
    def on_pose(self, t: float, x: float, y: float, th: float) -> None:
        """Localisation (map frame) at run time t [s]."""
        self._pose = (float(x), float(y), float(th))
        self.machine.observe(x, y)

    def advance(self, t: float) -> None:
        """The clock moves on to run time t [s] (as the tick does): what is handled before the
        tick (team messages in lock-step, tpuaf.team.lockstep) happens at its time."""
        self._now = max(self._now, float(t))

    def on_message(self, message: Any) -> None:
        """A team message from another robot (the node filters out our own). A malformed one
        (unknown sender or vertex, NaN time: messages.well_formed) is dropped and counted."""
        m = self.machine
        lanes = getattr(self.navigator, "lanes", None)  # robot/lanes.py LaneAccess, if any
        n_lanes = len(lanes.lane_map.lanes) if lanes is not None else 0
        if not well_formed(message, m.n_robots, m.patrol_map.num_vertices, n_lanes):
            self.dropped_messages = getattr(self, "dropped_messages", 0) + 1
            return
        if message.robot != m.robot:
            m.on_message(message)

    def hear(self, robot: int, t: float) -> bool:
        """Teammate `robot` heard at run time t [s] (a message or a heartbeat); True: back."""
        return self.machine.hear(robot, t)

    def check_liveness(self, now: float) -> list[int]:
        """Teammates silent for the timeout by run time `now` [s] (their policy hook called)."""
        return self.machine.check_liveness(now)

    def on_teammate_lost(self, robot: int) -> None:
        """Teammate `robot` went silent (the liveness timeout)."""
        self.machine.on_teammate_lost(robot)

    def begin(self, t: float) -> bool:
        """Start patrolling now at run time t [s] if the pose is known: START and the policy's
        start hook; the first decision comes with the next tick. Returns True if started."""
        m = self.machine
        if m.started or self._pose is None:
            return m.started
        self._now = max(self._now, float(t))
        x, y, _ = self._pose
        m.place(m.nearest_vertex(x, y))
        lanes = getattr(self.navigator, "lanes", None)
        if lanes is not None and not lanes.started:  # a start inside a lane holds it
            lanes.start_at(m.current_vertex, self._now)
        m.start()
        self._decide_pending = True
        return True

    def die(self) -> None:
        """Fault injection: the robot is dead from now on (no motion, no messages)."""
        self.machine.die()

    def tick(self, t: float, points: np.ndarray | None,
             points_pose: tuple[float, float, float] | None = None) -> tuple[float, float]:
        """One control step at run time t [s] with laser points (k, 2) in the robot frame;
        returns (v [m/s], w [rad/s]). `points_pose`: the pose [m, m, rad] the points were
        measured at, when older than the current pose (they are motion-compensated)."""
        self._now = max(self._now, float(t))
        m = self.machine
        if self._pose is None or not m.alive:
            return 0.0, 0.0
        lanes = getattr(self.navigator, "lanes", None)
        if lanes is not None:  # the lane claim, re-announced when due
            lanes.tick(self._now, self.position)
        if self._now >= self._next_heartbeat:  # also before the start: "ready"
            self._event(HEARTBEAT, m.goal if m.goal is not None else -1, m.current_vertex)
            self._next_heartbeat = self._now + self.heartbeat_period_s
        if not m.started:
            if self.start_at is None or self._now < self.start_at:
                return 0.0, 0.0
            self.begin(self._now)
        if self._decide_pending:
            self._decide_pending = False
            m.decide()
        if self._wakes and self._wakes[0] <= self._now:
            due = 0
            while self._wakes and self._wakes[0] <= self._now:
                heapq.heappop(self._wakes)
                due += 1
            for _ in range(due):  # wake-ups asked for now wait for the next tick
                m.on_wake()
        if self._stay_until is not None:
            if self._now < self._stay_until:
                return 0.0, 0.0
            self._stay_until = None
            m.on_vertex(self._stay_vertex, True)
        if self._unreachable is not None:
            goal, self._unreachable = self._unreachable, None
            m.on_goal_failed(goal, m.nearest_vertex(*self.position))
            return 0.0, 0.0
        if points_pose is not None:
            points = moved_points(points, points_pose, self._pose)
        if lanes is not None and lanes.look is not None and points is not None:
            lanes.look(self._pose, points)  # closed vertices in view (robot/body_sight.py)
        if self.navigator.route is None:
            # Standing without a route (waiting for a decision): make room for another robot
            # that comes right up to us (Navigator.park_step; not with move_base).
            park = getattr(self.navigator, "park_step", None)
            return park(self._now, self._pose, points) if park is not None else (0.0, 0.0)
        # A goal reached at once on the way to the next (a vertex within tolerance of the one
        # just visited) is an event too: step again, a few times at most.
        for _ in range(MAX_EVENTS_PER_TICK):
            if self.navigator.route is None:
                return 0.0, 0.0
            cmd, event, vertex = self.navigator.step(self._now, self._pose, points)
            self._watch_recovery()
            if event == Event.WAYPOINT:
                m.on_vertex(vertex, False)
            elif event == Event.ARRIVED:
                m.on_vertex(vertex, True)
                continue
            elif event == Event.FAILED:
                m.on_goal_failed(vertex, m.nearest_vertex(*self.position))
                return 0.0, 0.0
            break
        else:
            return 0.0, 0.0
        return cmd.v, cmd.w

    # --- internals ---
    def _watch_recovery(self) -> None:
        controller = getattr(self.navigator, "controller", None)
        retries = getattr(controller, "retries", 0)
        goal = self.machine.goal
        if retries > self._retries_seen:
            self.recoveries += 1
            if goal is not None:
                self._event(STUCK, goal, self.machine.current_vertex)
            if self.on_stuck is not None and goal is not None:
                self.on_stuck(int(goal), int(retries), self._now)
        self._retries_seen = retries
        give_ways = getattr(self.navigator, "give_ways", 0)
        if give_ways > self._give_ways_seen and goal is not None:
            self._event(GIVE_WAY, goal, self.machine.current_vertex)
        self._give_ways_seen = give_ways

    def _event(self, kind: int, vertex: int, from_vertex: int, t: float | None = None) -> None:
        self._publish_event(kind, int(vertex), int(from_vertex), self._now if t is None else t)
