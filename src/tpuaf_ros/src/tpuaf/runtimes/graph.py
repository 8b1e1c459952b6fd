"""Graph runtime: an event-driven simulation of the team without ROS (the reference runtime).

Robots drive shortest paths along graph edges at nominal speed (straight segments between
vertex positions, each taking edge length / speed). Each robot is a `RobotMachine`
(runtimes/robot.py, shared with the physics and agent runtimes); this module is its driver:
event queue clock, `TeamBus` transport (delay, loss) and segment motion. Ground truth
(uncertainty, idleness, interference) is measured by `tpuaf.measure.metrics.RunRecorder` from the true,
piecewise-linear positions; visits are the machines' REACHED events. Faults (death, stall) are
injected at configured times (runtimes/faults.py). Runs are deterministic for a seed.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from dataclasses import asdict

import numpy as np

from tpuaf.maps import load_map, start_vertices
from tpuaf.measure.metrics import RunRecorder
from tpuaf.navigation import GraphRoute, navigator_give_up_s
from tpuaf.policies import REGISTRY
from tpuaf.robot.machine import DEFAULT_RETRY_S, STAY_S, RobotMachine
from tpuaf.runtimes.config import RunConfig, run_description
from tpuaf.runtimes.faults import DEATH, Fault
from tpuaf.team.bus import TeamBus
from tpuaf.topics import REACHED, START

__all__ = ["DEFAULT_RETRY_S", "STAY_S", "BatchRun"]

_ARRIVE, _WAKE, _DELIVER, _FAULT, _GIVE_UP, _LOST = 0, 1, 2, 3, 4, 5


class BatchRun:
    """One graph-runtime run. `run()` returns the summary; the recorder holds visits and time
    series. It is the `RobotDriver` of every robot's machine (`self.robots`)."""

    runtime = "graph"

    def __init__(self, config: RunConfig, patrol_map=None):
        config.validate()
        self.config = config
        self.patrol_map = patrol_map if patrol_map is not None else load_map(config.map)
        graph = self.patrol_map.graph  # validates the graph (MapError on a bad one)
        self.graph = graph
        self.speed = float(self.patrol_map.settings.nominal_speed)
        self.goal_tolerance = float(self.patrol_map.settings.goal_tolerance)
        self.now = 0.0
        self._events: list = []
        self._seq = 0
        seed = int(config.seed)
        n = config.robots
        self.bus = TeamBus(n, config.delay_s, config.loss, np.random.default_rng([seed, 1]))
        cls = REGISTRY.get(config.strategy)
        starts = start_vertices(self.patrol_map, n)
        self.recorder = RunRecorder(self.patrol_map, n, sample_period_s=config.sample_period_s)
        self.robots = [
            RobotMachine(self, i, n, self.patrol_map, cls(config.strategy_params),
                         np.random.default_rng([seed, 2, i]), self._listener(i), starts[i])
            for i in range(n)
        ]
        self.faults = config.faults()
        if self.faults:
            for robot in self.robots:
                robot.on_announce = self._announcer(robot.robot)
        self._last_positions_time = -1.0
        # Motion of every robot: its route, and one straight segment from p0 at t0 to t1 at
        # `velocity` (a vectorised table for positions). `_pending[i]` is the sequence number
        # of its one awaited ARRIVE or GIVE_UP event (others are stale).
        self._routes: list[GraphRoute | None] = [None] * n
        self._p0 = np.array([self.patrol_map.positions[s] for s in starts], dtype=float)
        self._velocity = np.zeros_like(self._p0)
        self._t0 = np.zeros(n)
        self._t1 = np.zeros(n)
        self._pending = [-1] * n
        self.stall_give_up_s = navigator_give_up_s()

    def _listener(self, robot: int):
        record_visit = self.recorder.record_visit

        def emit(kind: int, vertex: int, _from_vertex: int, t: float) -> None:
            if kind == REACHED or kind == START:  # START: the start vertex's first visit
                record_visit(robot, vertex, t)

        return emit

    def _announcer(self, robot: int):
        record = self.recorder.record_announcement
        return lambda vertex, t: record(robot, vertex, t)

    # --- event queue ---
    def push(self, time: float, kind: int, payload) -> int:
        self._seq += 1
        heapq.heappush(self._events, (time, kind, self._seq, payload))
        return self._seq

    def schedule_delivery(self, time: float, message, recipients: list[int]) -> None:
        self.push(time, _DELIVER, (message, recipients))

    def position_of(self, robot: int, t: float | None = None):
        """True position of one robot at time t [m] (default now), from the segment table."""
        if t is None:
            t = self.now
        elapsed = min(max(t - self._t0[robot], 0.0), self._t1[robot] - self._t0[robot])
        p = self._p0[robot] + self._velocity[robot] * elapsed
        return (float(p[0]), float(p[1]))

    def positions(self, t: float) -> np.ndarray:
        """True positions of all robots at time t [m], vectorised over robots."""
        elapsed = np.minimum(np.maximum(t - self._t0, 0.0), self._t1 - self._t0)
        return self._p0 + self._velocity * elapsed[:, None]

    def _deliver_ready(self) -> None:
        ready = self.bus.ready
        robots = self.robots
        while ready:
            message, recipients = ready.popleft()
            delivered = 0
            for r in recipients:
                robot = robots[r]
                if robot.alive:
                    robot.policy.on_message(message, robot)
                    delivered += 1
            self.bus.stats.delivered += delivered

    # --- RobotDriver ---
    def transmit(self, robot: int, message) -> None:
        self.bus.send(robot, message, self.now, self.schedule_delivery)

    def schedule_wake(self, robot: int, time: float) -> None:
        self.push(time, _WAKE, robot)

    def at_vertex(self, robot: int, vertex: int) -> bool:
        x, y = self.position_of(robot)
        p = self.patrol_map.positions[vertex]
        return math.hypot(x - p[0], y - p[1]) <= self.goal_tolerance

    def halt(self, robot: int) -> None:
        """No goal: the robot stands where its last segment ended (nothing to do), unless it
        is stopped mid-segment (death)."""

    def drive(self, robot: int, from_vertex: int, goal: int) -> None:
        route = GraphRoute(self.graph, self.patrol_map.positions, from_vertex, goal)
        self._routes[robot] = route
        if self.robots[robot].stalled:
            self._give_up_later(robot)
        else:
            self._start_segment(robot, from_vertex, route.next_waypoint)

    def dwell(self, robot: int, vertex: int, duration_s: float) -> None:
        self._routes[robot] = None
        self._segment(robot, vertex, vertex, duration_s)

    # --- motion ---
    def _segment(self, i: int, here: int, nxt: int, duration: float) -> None:
        positions = self.patrol_map.positions
        p0 = positions[here].astype(float)
        t1 = self.now + duration
        self._p0[i], self._t0[i], self._t1[i] = p0, self.now, t1
        self._velocity[i] = (positions[nxt] - p0) / duration  # [m/s] along the straight segment
        self._pending[i] = self.push(t1, _ARRIVE, i)

    def _start_segment(self, i: int, here: int, nxt: int) -> None:
        if nxt == here:
            self._segment(i, here, nxt, STAY_S)
            return
        length = self.graph.edge_length(here, nxt)
        duration = length / self.speed
        robot = self.robots[i]
        robot.travelled_m += length
        robot.travel_time_s += duration
        self._segment(i, here, nxt, duration)

    def _arrive(self, i: int) -> None:
        robot = self.robots[i]
        route = self._routes[i]
        if route is None:  # the end of a dwell
            robot.on_vertex(robot.current_vertex, True)
            return
        vertex = route.advance()
        if robot.on_vertex(vertex, route.done):
            self._start_segment(i, vertex, route.next_waypoint)  # pass-through vertex

    def _freeze(self, i: int) -> None:
        """Stop robot i where it is now; its awaited arrival becomes stale."""
        p = self.positions(self.now)[i]
        self._p0[i] = p
        self._velocity[i] = 0.0
        self._t0[i] = self._t1[i] = self.now
        self._pending[i] = -1

    def _give_up_later(self, i: int) -> None:
        self._pending[i] = self.push(self.now + self.stall_give_up_s, _GIVE_UP, i)

    def _fault(self, fault: Fault) -> None:
        i = fault.robot
        robot = self.robots[i]
        if not robot.alive:
            return
        if fault.kind == DEATH:
            self._freeze(i)
            robot.die()
            self.bus.alive[i] = False
            self.recorder.record_robot_death(i, self.now)
            self.push(self.now + self.config.teammate_timeout_s, _LOST, i)
            return
        robot.stall()
        self.recorder.record_robot_stall(i, self.now)
        if not robot.dwelling:  # a dwell needs no motion: it ends as planned
            self._freeze(i)
            if robot.goal is not None:
                self._give_up_later(i)

    def _give_up(self, i: int) -> None:
        robot = self.robots[i]
        goal = robot.goal
        self._routes[i] = None
        if goal is not None:
            robot.on_goal_failed(goal, self.patrol_map.nearest_vertex(*self.position_of(i)))

    def _record_positions(self, t: float) -> None:
        if t > self._last_positions_time:
            self.recorder.record_positions(t, self.positions(t))
            self._last_positions_time = t

    # --- main loop ---
    def run(self, progress: Callable[[float], None] | None = None) -> dict:
        """Simulate until duration_s. `progress(now)` is called now and then."""
        end = float(self.config.duration_s)
        self._record_positions(0.0)
        for fault in self.faults:
            self.push(fault.time_s, _FAULT, fault)
        for robot in self.robots:
            robot.start()
        self._deliver_ready()
        for robot in self.robots:
            robot.decide()
            self._deliver_ready()
        next_progress = 0.0
        events = self._events
        robots = self.robots
        pending = self._pending
        while events and events[0][0] <= end:
            time, kind, seq, payload = heapq.heappop(events)
            if time > self.now:
                self._record_positions(time)
                self.now = time
            if kind == _ARRIVE:
                if pending[payload] == seq:
                    self._arrive(payload)
            elif kind == _WAKE:
                robots[payload].on_wake()
            elif kind == _DELIVER:
                message, recipients = payload
                self.bus.ready.append((message, recipients))
            elif kind == _FAULT:
                self._fault(payload)
            elif kind == _LOST:
                for robot in robots:
                    robot.on_teammate_lost(payload)
            elif pending[payload] == seq:  # _GIVE_UP
                self._give_up(payload)
            self._deliver_ready()
            if progress is not None and self.now >= next_progress:
                progress(self.now)
                next_progress = self.now + end / 200.0
        self._record_positions(end)
        self.now = end
        if progress is not None:
            progress(end)
        return self.summary()

    def effective_config(self) -> dict:
        """Everything that determines this run, with defaults resolved (written to config.yaml)."""
        return run_description(
            self, [r.start_vertex for r in self.robots], self.robots[0].policy.params, self.faults,
            motion="straight segments between vertices, edge length / nominal speed each")

    def summary(self) -> dict:
        summary = self.recorder.summary(self.now)
        summary["messages"] = asdict(self.bus.stats)
        summary["faults"] = [f.to_dict() for f in self.faults if f.time_s <= self.now]
        return summary
