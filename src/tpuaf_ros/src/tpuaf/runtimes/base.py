"""What the graph and physics runtimes share: the team around the robots' machines.

`TeamRun` holds the run's configuration, map, `TeamBus` and `RunRecorder`, and does for every
robot what does not depend on how robots move: visits and announcements to the recorder,
delivery of ready team messages to the live machines, the fault injection (death, stall) and
the run summary. A runtime subclasses it and supplies motion through three hooks:
`_stop_motion(i)` (a death: stop where it is), `_after_stall(i)` and `_liveness_at(t, i, token)`
(call `liveness_due(i, token)` at run time t [s]).

Liveness (runs with faults): every robot's machine is fed the team messages delivered to it and
the heartbeats it hears (`heartbeat_links`: one a second from every live robot, with the bus's
loss and delay), and checks its teammates' silence when one can reach the timeout
(`config.teammate_timeout_s`, the agent node's ~teammate_timeout): a death is detected from what
the survivors hear, later under loss; a stalled robot keeps its heartbeats. One pending check per
robot (the earliest time a silence can end; messages only postpone it, so it is never late).
Runs without faults carry no heartbeats (nothing can go silent but through loss), so they stay
identical to the C++ loop's.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict
from typing import Any

from tpuaf.maps import load_map
from tpuaf.measure.metrics import RunRecorder
from tpuaf.robot.machine import RobotMachine
from tpuaf.runtimes.config import RunConfig, run_robot, travel_map
from tpuaf.runtimes.faults import DEATH, Fault
from tpuaf.team.bus import TeamBus, bus_stream
from tpuaf.team.liveness import HEARTBEAT_PERIOD_S, heartbeat_links
from tpuaf.topics import DWELL, GOAL, REACHED, START


class TeamRun:
    runtime = "team"

    def __init__(self, config: RunConfig, patrol_map=None):
        config.validate()
        self.config = config
        # The map as loaded (geometry: the world, the planner) and the plan's map (the robot's
        # speed and travel times: strategies, routes, metrics).
        self.source_map = patrol_map if patrol_map is not None else load_map(
            config.map, params=config.map_params, params_origin="map_params")
        self.robot = run_robot(config, self.source_map)
        self.patrol_map = travel_map(config, self.source_map, self.robot)
        self.seed = int(config.seed)
        self.now = 0.0
        self.bus = TeamBus(config.robots, config.delay_s, config.loss, bus_stream(self.seed))
        self.faults = config.faults()
        self.recorder: RunRecorder | None = None
        self.machines: list[RobotMachine] = []
        self.links = None  # tpuaf_core.HeartbeatLinks: heartbeats, in runs with faults
        self._liveness_token: list[int] = []  # per robot: the id of its one pending check
        self.losses: list[tuple[float, int, int]] = []  # (t [s], observer, lost teammate)
        self._died_at: dict[int, float] = {}

    def _record(self) -> RunRecorder:
        """The run's recorder, on the plan's map (the robots' speed and travel times)."""
        self.recorder = RunRecorder(self.patrol_map, self.config.robots,
                                    sample_period_s=self.config.sample_period_s,
                                    teammate_timeout_s=float(self.config.teammate_timeout_s))
        return self.recorder

    def _team(self, machines: list[RobotMachine]) -> None:
        """The robots' machines, in index order; their announcements are recorded (recovery
        metrics) when the run has faults."""
        self.machines = machines
        if self.faults:
            for machine in machines:
                machine.on_announce = self.announcer(machine.robot)
            cfg = self.config
            self.links = heartbeat_links(cfg.robots, float(cfg.duration_s),
                                         float(cfg.teammate_timeout_s), self.bus.delay_s,
                                         self.bus.loss, self.seed, self.heartbeat_period_s)
            self._liveness_token = [0] * len(machines)

    heartbeat_period_s = HEARTBEAT_PERIOD_S  # [s] (the physics runtime: its agents')

    # --- recording ---
    def visit_listener(self, robot: int) -> Callable[[int, int, int, float], None]:
        """The `emit` of robot `robot`'s machine: its visits (START: the start vertex's first
        visit, REACHED), goals and dwells (DWELL: a goal ended without a visit) go to the
        recorder."""
        recorder = self.recorder
        record_visit = recorder.record_visit

        def emit(kind: int, vertex: int, from_vertex: int, t: float) -> None:
            if kind == REACHED or kind == START:
                record_visit(robot, vertex, t)
            elif kind == GOAL:
                recorder.record_goal(robot, vertex, from_vertex, t)
            elif kind == DWELL:
                recorder.record_dwell(robot, vertex, t)

        return emit

    def announcer(self, robot: int) -> Callable[[int, float], None]:
        record = self.recorder.record_announcement
        return lambda vertex, t: record(robot, vertex, t)

    # --- team messages ---
    def deliver_ready(self) -> None:
        """Hand every ready message to its live recipients."""
        ready = self.bus.ready
        machines = self.machines
        if self.links is not None:
            self._deliver_heard()
            return
        delivered = 0
        while ready:
            message, recipients = ready.popleft()
            for r in recipients:
                machine = machines[r]
                if machine.alive:
                    machine.on_message(message)
                    delivered += 1
        self.bus.count_delivered(delivered)

    def _deliver_heard(self) -> None:
        """deliver_ready, each message also heard by its recipient's liveness."""
        ready = self.bus.ready
        machines = self.machines
        delivered = 0
        while ready:
            message, recipients = ready.popleft()
            sender = getattr(message, "robot", -1)
            for r in recipients:
                machine = machines[r]
                if machine.alive:
                    if machine.hear(sender, self.now):
                        self._plan_liveness(r)  # back: its next silence may come sooner
                    machine.on_message(message)
                    delivered += 1
        self.bus.count_delivered(delivered)

    # --- liveness (runs with faults) ---
    def start_liveness(self) -> None:
        """Plan every robot's first liveness check (after the start, at run time now)."""
        if self.links is not None:
            for machine in self.machines:
                self._plan_liveness(machine.robot)

    def _feed_heartbeats(self, robot: int) -> None:
        """Robot `robot` hears the last heartbeat of every teammate that reached it by now."""
        self.links.feed(self.machines[robot].liveness, self.now)

    def _plan_liveness(self, robot: int) -> None:
        """Schedule robot `robot`'s next liveness check (the earliest time any teammate's
        silence can reach the timeout, or one can be heard again: HeartbeatLinks, as the
        graph loop plans it)."""
        machine = self.machines[robot]
        if not machine.alive:
            return
        self._feed_heartbeats(robot)
        due = self.links.next_check_of(machine.liveness, self.now)
        self._liveness_token[robot] += 1
        if math.isfinite(due):
            self._liveness_at(max(due, self.now), robot, self._liveness_token[robot])

    def liveness_due(self, robot: int, token: int) -> None:
        """A planned liveness check of robot `robot` (stale when `token` is not its latest)."""
        if token != self._liveness_token[robot] or not self.machines[robot].alive:
            return
        self._feed_heartbeats(robot)
        for lost in self.machines[robot].check_liveness(self.now):
            self.losses.append((self.now, robot, lost))
        self._plan_liveness(robot)

    def _liveness_at(self, time_s: float, robot: int, token: int) -> None:  # pragma: no cover
        raise NotImplementedError

    # --- faults ---
    def inject(self, fault: Fault) -> None:
        i = fault.robot
        machine = self.machines[i]
        if not machine.alive:
            return
        if fault.kind == DEATH:
            self._stop_motion(i)
            machine.die()
            self.bus.set_dead(i)
            self.recorder.record_robot_death(i, self.now)
            self._died_at[i] = self.now
            self.links.died(i, self.now)  # its heartbeats stop: every survivor's checks move
            for machine in self.machines:
                self._plan_liveness(machine.robot)
            return
        machine.stall()
        self.recorder.record_robot_stall(i, self.now)
        self._after_stall(i)

    def _stop_motion(self, robot: int) -> None:
        """A death: the robot stops where it is now."""

    def _after_stall(self, robot: int) -> None:
        """A stall: the robot no longer moves (its machine keeps deciding)."""

    # --- results ---
    def summary(self) -> dict[str, Any]:
        summary = self.recorder.summary(self.now)
        summary["messages"] = asdict(self.bus.stats)
        summary["faults"] = [f.to_dict() for f in self.faults if f.time_s <= self.now]
        if self.links is not None:
            summary["liveness"] = self.liveness_summary()
        return summary

    def liveness_summary(self) -> dict[str, Any]:
        """How the survivors noticed each death (see `liveness_summary`)."""
        return liveness_summary(float(self.config.teammate_timeout_s), self.links.period_s,
                                self._died_at, self.losses)

def liveness_summary(teammate_timeout_s: float, heartbeat_period_s: float,
                     died_at: dict[int, float], losses: list[tuple[float, int, int]]
                     ) -> dict[str, Any]:
    """How the survivors noticed each death (detection delays [s] after the death, over the
    robots alive when they noticed) and how often a live teammate was taken for lost (a
    silence of the timeout under loss). died_at: robot -> death time [s]; losses: (t [s],
    observer, lost teammate)."""
    deaths = []
    for robot, died in sorted(died_at.items(), key=lambda kv: (kv[1], kv[0])):
        delays = [t - died for t, _, lost in losses if lost == robot and t >= died]
        deaths.append({
            "robot": robot, "time_s": died, "noticed_by": len(delays),
            "first_delay_s": min(delays) if delays else None,
            "last_delay_s": max(delays) if delays else None,
        })
    false = sum(1 for t, _, lost in losses if t < died_at.get(lost, math.inf))
    return {"teammate_timeout_s": float(teammate_timeout_s),
            "heartbeat_period_s": heartbeat_period_s, "deaths": deaths, "false_losses": false}
