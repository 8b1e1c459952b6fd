"""The robot state machine every runtime drives (graph, physics, agent; docs/RUNTIMES.md).

The state machine is the C++ core's `tpuaf_core.RobotProtocol` (robot_protocol.cpp), the one the
graph runtime's loop drives in C++. `RobotMachine` is its Python adapter for the physics runtime
and the ROS agents: it forwards the driver's events to the protocol, answers the protocol's
callbacks (the driver's motion and clock, the policy's hooks, the events), and is the
`RobotContext` its policy sees:

    start --decide--> DRIVING(goal) --vertex passed--> DRIVING (same route, or a redirect)
                 |        |--goal vertex reached--> REACHED (a visit) or DWELL: decide again
                 |        |--navigator gave up----> FAILED: on_goal_failed, decide again
                 |--goal == here, robot on it--> DWELLING(STAY_S) --end--> DWELL: decide again
                 |--None--> WAITING --wake time--> decide
    any state --death--> DEAD (no motion, no decisions, no messages in or out)

A runtime ("driver") owns the clock, the transport and the motion. It calls `start`, `decide`,
`on_vertex` (a vertex of the route was reached), `observe` (every position of the robot),
`on_goal_failed`, `on_wake`, `on_message`, `die` and `stall`, and feeds the robot's liveness
(the protocol's `TeammateLiveness`): `hear(robot, t)` for every team message and heartbeat delivered, `check_liveness(now)` when a
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

import numpy as np

from tpuaf.params import LIVENESS_DEFAULTS
from tpuaf.policies import Policy, RobotContextBase
from tpuaf.robot.learning import LearnedTravel
from tpuaf.team.messages import IdlenessEstimate, Intention, LaneClaim, Visit
from tpuaf.topics import DWELL, REACHED

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
    """One robot's protocol (tpuaf_core.RobotProtocol) and the RobotContext of its policy (see
    the module docstring)."""

    def __init__(self, driver: RobotDriver, robot: int, n_robots: int, patrol_map: Any,
                 policy: Policy, rng, emit: Callable[[int, int, int, float], None] | None = None,
                 start_vertex: int | None = None,
                 teammate_timeout_s: float = LIVENESS_DEFAULTS.teammate_timeout_s):
        import tpuaf_core

        self.driver = driver
        self.robot = int(robot)
        self.n_robots = int(n_robots)
        self.patrol_map = patrol_map
        self.policy = policy
        self.rng = rng
        self.emit = emit or (lambda kind, vertex, from_vertex, t: None)
        # Called with (vertex, t) for every destination announced in a team message sent.
        self.on_announce: Callable[[int, float], None] | None = None
        if not teammate_timeout_s > 0:
            raise ValueError(f"teammate timeout must be > 0 s, got {teammate_timeout_s}")
        # The state machine; it holds the visit rule (the one definition of a visit) and the
        # teammate liveness ([s] a teammate silent teammate_timeout_s is lost).
        self.protocol = tpuaf_core.RobotProtocol(
            self, np.asarray(patrol_map.positions, dtype=float), self.robot, self.n_robots,
            STAY_S, DEFAULT_RETRY_S, float(teammate_timeout_s), float(patrol_map.visit_radius_m),
            float(patrol_map.settings.goal_tolerance))
        self._start_position = (math.nan, math.nan)
        if start_vertex is not None:
            self.place(start_vertex)
        # Vel(i) of Eq. 6 in the plan's units: plan metres of the legs driven to a visit over
        # their driving time [s] (the graph runtime's measure), so that the plan's lengths over
        # it give travel times whatever the lengths model (declared, planned or timed).
        self.travelled_m = 0.0
        self.travel_time_s = 0.0
        # The team's measured edge durations; the plan is re-timed on them (robot/learning.py).
        self.learned = LearnedTravel(patrol_map)
        self.lane_locks = None  # team.lane_locks.LaneLocks on maps with lanes (robot/lanes.py)
        # Called with a lost teammate's index before the policy hears of it (the lane layer:
        # a body blocking a lane changes the plan the policy then re-plans on).
        self.on_teammate_lost_first: Callable[[int], None] | None = None
        # Called with a lost teammate's index when it is heard again (the lane layer reopens
        # the vertices its body was thought to stand on).
        self.on_teammate_back: Callable[[int], None] | None = None
        # teammate -> its latest Intention heard: where a teammate lost on its way was heading
        # and when it left (the lane layer: where its body lies)
        self.teammate_intentions: dict[int, Intention] = {}
        # teammate -> its latest Visit heard: an arrival newer than its latest Intention says
        # that the Intention of its next leg was lost
        self.teammate_visits: dict[int, Visit] = {}

    # --- the protocol's state ---
    @property
    def goal(self) -> int | None:
        g = self.protocol.goal
        return None if g < 0 else g

    @property
    def redirect(self) -> int | None:  # a new goal asked for while driving
        g = self.protocol.redirect
        return None if g < 0 else g

    @property
    def _current(self) -> int:
        return self.protocol.current_vertex

    @property
    def _start_vertex(self) -> int:
        return self.protocol.start_vertex

    alive = property(lambda self: self.protocol.alive)
    started = property(lambda self: self.protocol.started)
    stalled = property(lambda self: self.protocol.stalled)
    dwelling = property(lambda self: self.protocol.dwelling)
    wake_pending = property(lambda self: self.protocol.wake_pending)
    visits = property(lambda self: self.protocol.visits)
    dwells = property(lambda self: self.protocol.dwells)  # goals ended without a visit (DWELL)
    dwell_time_s = property(lambda self: self.protocol.dwell_time_s)  # [s] standing in dwells
    failures = property(lambda self: self.protocol.failures)
    decisions = property(lambda self: self.protocol.decisions)
    visit_rule = property(lambda self: self.protocol.visit_rule)  # tpuaf_core.VisitRule
    liveness = property(lambda self: self.protocol.liveness)  # tpuaf_core.TeammateLiveness

    def at_vertex(self, vertex: int) -> bool:
        """Is the robot within the map's goal tolerance [m] of `vertex` (it dwells there rather
        than drive)? The protocol's rule (vertex_geometry.hpp, the graph loop's too)."""
        return self.protocol.within_goal_tolerance(int(vertex))

    def nearest_vertex(self, x: float, y: float) -> int:
        """The vertex nearest (x, y) [m] (the first on ties; the graph loop's rule)."""
        return self.protocol.nearest_vertex(float(x), float(y))

    def within(self, vertex: int) -> bool:
        """Is the robot within the visit radius [m] of `vertex` (VisitRule)?"""
        return self.visit_rule.within(int(vertex), *self.position)

    def observe(self, x: float, y: float) -> None:
        """A position [m] of the robot (the driver's every pose): re-arms the visit rule."""
        self.protocol.observe(float(x), float(y))

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
        self.protocol.wake_at(float(time))

    def change_goal(self, vertex: int) -> None:
        """Redirect while driving: at the next vertex passed, head to `vertex` instead (only
        that goal counts as a visit)."""
        self.protocol.change_goal(self.checked_vertex(vertex))

    # --- inputs from the driver, forwarded to the protocol ----------------------------------
    def place(self, vertex: int) -> None:
        """The robot stands at its start vertex (before `start`)."""
        v = self.checked_vertex(vertex)
        self.protocol.place(v)
        p = self.patrol_map.positions[v]
        self._start_position = (float(p[0]), float(p[1]))

    def start(self) -> None:
        """START (the start vertex's first visit), then the policy's start hook; the driver
        calls `decide` next (after every robot of a team has started, where it can)."""
        self.protocol.start()

    def decide(self) -> None:
        """Ask the policy for the next goal and head there (None: wait for a wake-up)."""
        self.protocol.decide()

    def on_wake(self) -> None:
        """A wake-up time requested with `wake_at` is due (ignored while the robot has a goal)."""
        self.protocol.on_wake()

    def on_vertex(self, vertex: int, at_goal: bool) -> bool:
        """The robot reached `vertex` of its route (`at_goal`: the route's last one, or the
        end of a dwell). Returns True when the driver should go on along the same route."""
        return self.protocol.on_vertex(int(vertex), bool(at_goal))

    def on_goal_failed(self, vertex: int, nearest_vertex: int) -> None:
        """The motion gave up on the goal `vertex`; the robot is nearest to `nearest_vertex`."""
        self.protocol.on_goal_failed(int(vertex), int(nearest_vertex))

    def on_message(self, message: Any) -> None:
        """A team message from another robot (never its own); lane claims go to the lane
        locks, not to the policy."""
        if isinstance(message, LaneClaim):
            if self.alive and self.lane_locks is not None:
                self.lane_locks.on_claim(message)
            return
        if isinstance(message, Intention):
            latest = self.teammate_intentions.get(message.robot)
            if latest is None or message.time >= latest.time:
                self.teammate_intentions[message.robot] = message
        elif isinstance(message, Visit):
            arrived = self.teammate_visits.get(message.robot)
            if arrived is None or message.time >= arrived.time:
                self.teammate_visits[message.robot] = message
        if self.protocol.listening:
            self.learned.observe(message)
            self.policy.on_message(message, self)

    def hear(self, robot: int, t: float) -> bool:
        """Teammate `robot` was heard (a team message or a heartbeat delivered) at run time t
        [s]. True when it had been reported lost (it is back; the policy is not told: it
        hears the teammate's next message)."""
        back = self.protocol.hear(int(robot), float(t))
        if back and self.on_teammate_back is not None:
            self.on_teammate_back(int(robot))
        return back

    def check_liveness(self, now: float) -> list[int]:
        """Teammates silent for the timeout by run time `now` [s], each reported once: the
        policy's `on_teammate_lost` is called for each (after the start)."""
        return self.protocol.check_liveness(float(now))

    def on_teammate_lost(self, robot: int) -> None:
        """Teammate `robot` went silent for the liveness timeout (it may be dead)."""
        self.protocol.on_teammate_lost(int(robot))

    def die(self) -> None:
        """Death: no motion, no decisions, no messages from now on (teammates are not told)."""
        self.protocol.die()

    def stall(self) -> None:
        """The robot stops moving for good but keeps deciding and talking (the driver stops
        its motion; its navigator then gives up on goals it cannot reach)."""
        self.protocol.stall()

    # --- the protocol's callbacks (the driver's motion and clock are called directly) -------
    def _policy_start(self) -> None:
        self.policy.start(self)

    def _policy_decide(self) -> int | None:
        retimed = self.learned.retimed_map(self.driver.now)
        if retimed is not None:  # learned travel times: the policy plans on them from now on
            self.patrol_map = retimed
            self.policy.retime(self)
        return self.call_decide(self.policy)

    def _policy_goal_failed(self, vertex: int) -> None:
        self.policy.on_goal_failed(vertex, self)

    def replan(self, plan_map: Any) -> None:
        """The plan's map lost edges (a lane blocked): the policy re-plans on it from now on,
        and learned travel times re-time it from the next decision."""
        self.patrol_map = plan_map
        self.learned.rebase(plan_map)
        self.policy.replan(self)

    def _policy_teammate_lost(self, robot: int) -> None:
        if self.on_teammate_lost_first is not None:
            self.on_teammate_lost_first(int(robot))
        hook = getattr(self.policy, "on_teammate_lost", None)
        if hook is not None:
            hook(int(robot), self)

    def _emit_event(self, kind: int, vertex: int, from_vertex: int, t: float) -> None:
        if kind == REACHED or kind == DWELL:  # a goal's end: its leg's plan metres and time
            leg_from = self.protocol.leg_from
            if leg_from >= 0 and leg_from != vertex:
                self.travelled_m += self.patrol_map.graph.distance(leg_from, vertex)
                self.travel_time_s += t - self.protocol.leg_start_s
        self.emit(kind, vertex, from_vertex, t)
