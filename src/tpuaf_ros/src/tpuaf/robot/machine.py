"""The robot state machine every runtime drives (graph, physics, agent; docs/RUNTIMES.md).

`RobotMachine` is one robot's patrol protocol and the `RobotContext` its policy sees:

    start --decide--> DRIVING(goal) --vertex passed--> DRIVING (same route, or a redirect)
                 |        |--goal vertex reached--> REACHED (a visit) or DWELL: decide again
                 |        |--navigator gave up----> FAILED: on_goal_failed, decide again
                 |--goal == here, robot on it--> DWELLING(STAY_S) --end--> DWELL: decide again
                 |--None--> WAITING --wake time--> decide
    any state --death--> DEAD (no motion, no decisions, no messages in or out)

A runtime ("driver") owns the clock, the transport and the motion. It calls `start`, `decide`,
`on_vertex` (a vertex of the route was reached), `observe` (every position of the robot),
`on_goal_failed`, `on_wake`, `on_message`, `die` and `stall`, and feeds the robot's liveness (`TeammateLiveness`, team/liveness.py):
`hear(robot, t)` for every team message and heartbeat delivered, `check_liveness(now)` when a
check is due (the ROS agent node: 4 Hz; graph and physics: when a silence can end, from
`heartbeat_links`), which calls the policy's `on_teammate_lost` for a teammate silent for the
timeout; the machine calls back the driver (`RobotDriver`) to move, dwell, halt,
send and schedule wake-ups, and reports what happened through `emit(kind, vertex, from_vertex,
t)` with the AgentEvent kinds of tpuaf.topics: START, GOAL, REACHED (a visit by the one rule of
every runtime, `tpuaf_core.VisitRule`: an arrival at the goal vertex within the visit radius
after the robot was farther than twice the radius from it), DWELL (a goal ended without a visit:
the robot stood on the vertex, or stopped short of it), FAILED.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, Protocol

from tpuaf.params import LIVENESS_DEFAULTS
from tpuaf.policies import Policy, RobotContextBase
from tpuaf.robot.learning import LearnedTravel
from tpuaf.team.liveness import TeammateLiveness
from tpuaf.team.messages import IdlenessEstimate, Intention, LaneClaim, Visit
from tpuaf.topics import DWELL, FAILED, GOAL, REACHED, START

STAY_S = 1.0  # [s] a robot whose goal is its own vertex dwells this long (a DWELL, no visit)
DEFAULT_RETRY_S = 1.0  # [s] a policy that waits without asking for a wake-up is asked again after


class RobotDriver(Protocol):
    """What a runtime provides to its robots' machines (robot = the machine's index)."""

    @property
    def now(self) -> float: ...  # [s] run time

    def position_of(self, robot: int) -> tuple[float, float]: ...  # [m] map frame

    def transmit(self, robot: int, message: Any) -> None: ...  # broadcast to the team

    def schedule_wake(self, robot: int, time: float) -> None: ...  # call on_wake at time [s]

    def drive(self, robot: int, from_vertex: int, goal: int) -> None:
        """Follow the shortest path; call on_vertex at every vertex of it, or on_goal_failed."""

    def dwell(self, robot: int, vertex: int, duration_s: float) -> None:
        """Stand still duration_s [s], then call on_vertex(vertex, at_goal=True)."""

    def halt(self, robot: int) -> None: ...  # no goal: stand still


def announced_vertex(message: Any) -> int:
    """The vertex a team message announces as its sender's next destination (-1: none)."""
    if isinstance(message, Intention):
        return int(message.vertex)
    if isinstance(message, (Visit, IdlenessEstimate)):
        return int(message.next_vertex)
    return -1


class RobotMachine(RobotContextBase):
    """One robot's protocol state and the RobotContext of its policy (see module docstring)."""

    def __init__(self, driver: RobotDriver, robot: int, n_robots: int, patrol_map: Any,
                 policy: Policy, rng, emit: Callable[[int, int, int, float], None] | None = None,
                 start_vertex: int | None = None,
                 teammate_timeout_s: float = LIVENESS_DEFAULTS.teammate_timeout_s):
        self.driver = driver
        self.robot = int(robot)
        self.n_robots = int(n_robots)
        self.patrol_map = patrol_map
        self.policy = policy
        self.rng = rng
        self.emit = emit or (lambda kind, vertex, from_vertex, t: None)
        self.visit_rule = patrol_map.visit_rule()  # the one definition of a visit
        # Called with (vertex, t) for every destination announced in a team message sent.
        self.on_announce: Callable[[int, float], None] | None = None
        self._start_vertex = -1
        self._current = -1
        self._start_position = (math.nan, math.nan)
        if start_vertex is not None:
            self.place(start_vertex)
        self.goal: int | None = None
        self.redirect: int | None = None  # a new goal asked for while driving
        self.wake_pending = False
        self.dwelling = False
        self.started = False
        self.alive = True
        self.stalled = False
        # Vel(i) of Eq. 6 in the plan's units: plan metres of the legs driven to a visit over
        # their driving time [s] (the graph runtime's measure), so that the plan's lengths over
        # it give travel times whatever the lengths model (declared, planned or timed).
        self.travelled_m = 0.0
        self.travel_time_s = 0.0
        self._leg: tuple[int, float] | None = None  # (from vertex, departure [s]) of a drive
        self.visits = 0
        self.dwells = 0  # goals ended without a visit (DWELL)
        self.dwell_time_s = 0.0  # [s] standing in dwells
        self._dwell_since = 0.0  # [s] run time the current dwell began
        self.failures = 0
        self.decisions = 0
        # [s] a teammate silent this long is lost (the agent node's ~teammate_timeout)
        self.liveness = TeammateLiveness(self.n_robots, self.robot, teammate_timeout_s)
        # The team's measured edge durations; the plan is re-timed on them (robot/learning.py).
        self.learned = LearnedTravel(patrol_map)
        self.lane_locks = None  # team.lane_locks.LaneLocks on maps with lanes (robot/lanes.py)

    def at_vertex(self, vertex: int) -> bool:
        """Is the robot within the map's goal tolerance [m] of `vertex` (it dwells there rather
        than drive)?"""
        x, y = self.position
        p = self.patrol_map.positions[vertex]
        return math.hypot(x - p[0], y - p[1]) <= float(self.patrol_map.settings.goal_tolerance)

    def within(self, vertex: int) -> bool:
        """Is the robot within the visit radius [m] of `vertex` (VisitRule)?"""
        return self.visit_rule.within(int(vertex), *self.position)

    def observe(self, x: float, y: float) -> None:
        """A position [m] of the robot (the driver's every pose): re-arms the visit rule."""
        self.visit_rule.observe(float(x), float(y))

    # --- RobotContext -----------------------------------------------------------------------
    @property
    def now(self) -> float:
        return self.driver.now

    @property
    def position(self) -> tuple[float, float]:
        return self.driver.position_of(self.robot)

    def send(self, message: Any) -> None:
        if not self.alive:
            return
        if self.on_announce is not None:
            v = announced_vertex(message)
            if v >= 0:
                self.on_announce(v, self.driver.now)
        self.learned.observe(message)
        self.driver.transmit(self.robot, message)

    def wake_at(self, time: float) -> None:
        self.driver.schedule_wake(self.robot, max(float(time), self.driver.now))
        self.wake_pending = True

    def change_goal(self, vertex: int) -> None:
        """Redirect while driving: at the next vertex passed, head to `vertex` instead (only
        that goal counts as a visit)."""
        self.redirect = self.checked_vertex(vertex)

    # --- inputs from the driver --------------------------------------------------------------
    def place(self, vertex: int) -> None:
        """The robot stands at its start vertex (before `start`)."""
        v = self.checked_vertex(vertex)
        self._start_vertex = self._current = v
        p = self.patrol_map.positions[v]
        self._start_position = (float(p[0]), float(p[1]))

    def start(self) -> None:
        """START (the start vertex's first visit), then the policy's start hook; the driver
        calls `decide` next (after every robot of a team has started, where it can)."""
        self.started = True
        self.visit_rule.start(self._start_vertex, *self.position)
        self.emit(START, self._start_vertex, -1, self.driver.now)
        self.policy.start(self)

    def decide(self) -> None:
        """Ask the policy for the next goal and head there (None: wait for a wake-up)."""
        if not self.alive:
            return
        self.wake_pending = False
        self.decisions += 1
        retimed = self.learned.retimed_map(self.driver.now)
        if retimed is not None:  # learned travel times: the policy plans on them from now on
            self.patrol_map = retimed
            self.policy.retime(self)
        goal = self.call_decide(self.policy)
        self.redirect = None
        if goal is None:
            self.goal = None
            self.dwelling = False
            self.driver.halt(self.robot)
            if not self.wake_pending:
                self.wake_at(self.driver.now + DEFAULT_RETRY_S)
            return
        self._set_goal(goal)

    def _set_goal(self, goal: int) -> None:
        self.goal = goal
        here = self._current
        self.emit(GOAL, goal, here, self.driver.now)
        if goal == here and self.at_vertex(goal):
            self.dwelling = True
            self._dwell_since = self.driver.now
            self.driver.dwell(self.robot, goal, STAY_S)
        else:
            self.dwelling = False
            self._leg = (here, self.driver.now)
            self.driver.drive(self.robot, here, goal)

    def on_wake(self) -> None:
        """A wake-up time requested with `wake_at` is due (ignored while the robot has a goal)."""
        if self.alive and self.started and self.goal is None:
            self.decide()

    def on_vertex(self, vertex: int, at_goal: bool) -> bool:
        """The robot reached `vertex` of its route (`at_goal`: the route's last one, or the
        end of a dwell). Returns True when the driver should go on along the same route."""
        if not self.alive:
            return False
        self._current = vertex
        if self.redirect is not None and self.goal is not None:
            self.goal, self.redirect = self.redirect, None
            if vertex != self.goal:
                self.dwelling = False
                self.emit(GOAL, self.goal, vertex, self.driver.now)
                self.driver.drive(self.robot, vertex, self.goal)
                return False
        elif not at_goal:
            return True  # a pass-through vertex: not a visit
        self._reach(vertex)
        return False

    def _reach(self, vertex: int) -> None:
        """The goal ends at `vertex`: a visit (REACHED) if the VisitRule says so, else DWELL."""
        now = self.driver.now
        if self._leg is not None and self._leg[0] != vertex:
            self.travelled_m += self.patrol_map.graph.distance(self._leg[0], vertex)
            self.travel_time_s += now - self._leg[1]
        self._leg = None
        if self.visit_rule.arrive(vertex, *self.position):
            self.visits += 1
            self.emit(REACHED, vertex, vertex, now)
        else:
            self.dwells += 1
            if self.dwelling:
                self.dwell_time_s += now - self._dwell_since
            self.emit(DWELL, vertex, vertex, now)
        self.dwelling = False
        self.goal = None
        self.decide()

    def on_goal_failed(self, vertex: int, nearest_vertex: int) -> None:
        """The motion gave up on the goal `vertex`; the robot is nearest to `nearest_vertex`."""
        if not self.alive:
            return
        self.failures += 1
        self._leg = None
        self.emit(FAILED, vertex, self._current, self.driver.now)
        self.goal = None
        self.dwelling = False
        self._current = int(nearest_vertex)
        self.policy.on_goal_failed(vertex, self)
        self.decide()

    def on_message(self, message: Any) -> None:
        """A team message from another robot (never its own); lane claims go to the lane
        locks, not to the policy."""
        if isinstance(message, LaneClaim):
            if self.alive and self.lane_locks is not None:
                self.lane_locks.on_claim(message)
            return
        if self.alive and self.started:
            self.learned.observe(message)
            self.policy.on_message(message, self)

    def hear(self, robot: int, t: float) -> bool:
        """Teammate `robot` was heard (a team message or a heartbeat delivered) at run time t
        [s]. True when it had been reported lost (it is back; the policy is not told: it
        hears the teammate's next message)."""
        return self.alive and self.liveness.heard(robot, t)

    def check_liveness(self, now: float) -> list[int]:
        """Teammates silent for the timeout by run time `now` [s], each reported once: the
        policy's `on_teammate_lost` is called for each (after the start)."""
        if not self.alive:
            return []
        lost = self.liveness.check(now)
        for robot in lost:
            self.on_teammate_lost(robot)
        return lost

    def on_teammate_lost(self, robot: int) -> None:
        """Teammate `robot` went silent for the liveness timeout (it may be dead)."""
        if self.alive and self.started:
            hook = getattr(self.policy, "on_teammate_lost", None)
            if hook is not None:
                hook(int(robot), self)

    def die(self) -> None:
        """Death: no motion, no decisions, no messages from now on (teammates are not told)."""
        if not self.alive:
            return
        self.alive = False
        self.goal = None
        self.redirect = None
        self.dwelling = False
        self.driver.halt(self.robot)

    def stall(self) -> None:
        """The robot stops moving for good but keeps deciding and talking (the driver stops
        its motion; its navigator then gives up on goals it cannot reach)."""
        self.stalled = True
