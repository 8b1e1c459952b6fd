"""Graph runtime: an event-driven simulation of the team without ROS (the reference runtime).

Robots drive shortest paths along graph edges at nominal speed (straight segments between
vertex positions, each taking edge length / speed). Each robot is a `RobotMachine`
(robot/machine.py, shared with the physics and agent runtimes); this module is its driver:
event queue clock and segment motion; `TeamRun` (runtimes/base.py) holds the `TeamBus`
(delay, loss), the recorder and the faults. Ground truth (uncertainty, idleness, interference)
is measured by `tpuaf.measure.metrics.RunRecorder` from the true, piecewise-linear positions;
visits are the machines' REACHED events. Faults (death, stall) are injected at configured times
(runtimes/faults.py); the survivors notice a death from what they stop hearing (heartbeats and
messages: `TeamRun` liveness, one queued check per robot). Runs are deterministic for a seed.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable

import numpy as np

from tpuaf.maps import start_vertices
from tpuaf.navigation import GraphRoute, navigator_give_up_s
from tpuaf.policies import REGISTRY
from tpuaf.robot.machine import DEFAULT_RETRY_S, STAY_S, RobotMachine
from tpuaf.runtimes.base import TeamRun
from tpuaf.runtimes.config import RunConfig, run_description

__all__ = ["DEFAULT_RETRY_S", "STAY_S", "BatchRun"]

_ARRIVE, _WAKE, _DELIVER, _FAULT, _GIVE_UP, _LIVENESS = 0, 1, 2, 3, 4, 5


class BatchRun(TeamRun):
    """One graph-runtime run. `run()` returns the summary; the recorder holds visits and time
    series. It is the `RobotDriver` of every robot's machine (`self.robots`)."""

    runtime = "graph"

    def __init__(self, config: RunConfig, patrol_map=None):
        super().__init__(config, patrol_map)
        graph = self.patrol_map.graph  # validates the graph (MapError on a bad one)
        self.graph = graph
        self.speed = float(self.patrol_map.settings.nominal_speed)
        self._events: list = []
        self._seq = 0
        n = config.robots
        cls = REGISTRY.get(config.strategy)
        starts = start_vertices(self.patrol_map, n)
        self._record()
        self.robots = [
            RobotMachine(self, i, n, self.patrol_map, cls(config.strategy_params),
                         np.random.default_rng([self.seed, 2, i]), self.visit_listener(i),
                         starts[i], teammate_timeout_s=float(config.teammate_timeout_s))
            for i in range(n)
        ]
        self._team(self.robots)
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

    # --- event queue ---
    def push(self, time: float, kind: int, payload) -> int:
        self._seq += 1
        heapq.heappush(self._events, (time, kind, self._seq, payload))
        return self._seq

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

    # --- RobotDriver ---
    def transmit(self, robot: int, message) -> None:
        self.bus.send(robot, message, self.now)

    def schedule_wake(self, robot: int, time: float) -> None:
        self.push(time, _WAKE, robot)

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

    # --- faults (TeamRun hooks) ---
    def _stop_motion(self, i: int) -> None:
        self._freeze(i)

    def _after_stall(self, i: int) -> None:
        if not self.robots[i].dwelling:  # a dwell needs no motion: it ends as planned
            self._freeze(i)
            if self.robots[i].goal is not None:
                self._give_up_later(i)

    def _liveness_at(self, time_s: float, i: int, token: int) -> None:
        self.push(time_s, _LIVENESS, (i, token))

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
        self.deliver_ready()
        for robot in self.robots:
            robot.decide()
            self.deliver_ready()
        self.start_liveness()
        next_progress = 0.0
        events = self._events
        robots = self.robots
        pending = self._pending
        bus = self.bus
        while True:
            # The next event: the queue's, or a message in flight on the bus, which comes
            # after arrivals and wake-ups of the same time and before faults (kind order).
            due = bus.next_due_s()
            from_bus = not events or (due, _DELIVER) < events[0][:2]
            time = due if from_bus else events[0][0]
            if time > end:
                break
            if from_bus:
                bus.release_next()
                kind = _DELIVER
            else:
                time, kind, seq, payload = heapq.heappop(events)
            if time > self.now:
                self._record_positions(time)
                self.now = time
            if kind == _ARRIVE:
                if pending[payload] == seq:
                    self._arrive(payload)
            elif kind == _WAKE:
                robots[payload].on_wake()
            elif kind == _FAULT:
                self.inject(payload)
            elif kind == _LIVENESS:
                self.liveness_due(*payload)
            elif kind == _GIVE_UP:
                if pending[payload] == seq:
                    self._give_up(payload)
            self.deliver_ready()
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
