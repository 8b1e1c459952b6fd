"""What the graph and physics runtimes share: the team around the robots' machines.

`TeamRun` holds the run's configuration, map, `TeamBus` and `RunRecorder`, and does for every
robot what does not depend on how robots move: visits and announcements to the recorder,
delivery of ready team messages to the live machines, the fault injection (death, stall) and
the run summary. A runtime subclasses it and supplies motion through three hooks:
`_stop_motion(i)` (a death: stop where it is), `_after_stall(i)` and `_liveness_at(t, i, token)`
(call `liveness_due(i, token)` at run time t [s]).

Liveness and faults (runs with faults) are the core's `tpuaf_core.TeamLiveness`
(team_liveness.cpp), the one the graph loop holds too: every robot's machine is fed the team
messages delivered to it and the heartbeats it hears (`heartbeat_links`: one a second from every
live robot, with the bus's loss and delay), and checks its teammates' silence when one can reach
the timeout (`config.teammate_timeout_s`, the agent node's ~teammate_timeout): a death is
detected from what the survivors hear, later under loss; a stalled robot keeps its heartbeats.
One pending check per robot (the earliest time a silence can end; messages only postpone it, so
it is never late). The steps of a death, in their one order, are TeamLiveness.inject's. Runs
without faults carry no heartbeats (nothing can go silent but through loss), so they stay
identical to the C++ loop's.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import asdict
from typing import Any

import tpuaf_core

from tpuaf.maps import load_map
from tpuaf.measure.metrics import RunRecorder
from tpuaf.robot.machine import RobotMachine
from tpuaf.runtimes.config import RunConfig, run_robot, travel_map
from tpuaf.runtimes.faults import DEATH, Fault
from tpuaf.team.bus import TeamBus, bus_stream
from tpuaf.team.liveness import HEARTBEAT_PERIOD_S, heartbeat_links


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
        self.team: tpuaf_core.TeamLiveness | None = None  # liveness and faults (with faults)
        self.links = None  # tpuaf_core.HeartbeatLinks: the team's heartbeats
        self._check_tokens = itertools.count(1)  # the liveness checks' tokens (0: none)

    def _record(self) -> RunRecorder:
        """The run's recorder, on the plan's map (the robots' speed and travel times)."""
        self.recorder = RunRecorder(self.patrol_map, self.config.robots,
                                    sample_period_s=self.config.sample_period_s,
                                    teammate_timeout_s=float(self.config.teammate_timeout_s),
                                    body_radius_m=self.body_radius_m)
        return self.recorder

    body_radius_m: float | None = None  # [m] dead robots' bodies stay (physics: its robots')

    def _team(self, machines: list[RobotMachine]) -> None:
        """The robots' machines, in index order; their announcements are recorded (recovery
        metrics) when the run has faults."""
        self.machines = machines
        if self.faults:
            for machine in machines:
                machine.on_announce = self.announcer(machine.robot)
            cfg = self.config
            links = heartbeat_links(cfg.robots, float(cfg.duration_s),
                                    float(cfg.teammate_timeout_s), self.bus.delay_s,
                                    self.bus.loss, self.seed, self.heartbeat_period_s)
            self.team = tpuaf_core.TeamLiveness([m.protocol for m in machines], self.bus.core,
                                                self.recorder.core, links, self)
            self.links = self.team.links

    heartbeat_period_s = HEARTBEAT_PERIOD_S  # [s] (the physics runtime: its agents')

    # --- recording ---
    def visit_listener(self, robot: int) -> Callable[[int, int, int, float], None]:
        """The `emit` of robot `robot`'s machine: its visits (START: the start vertex's first
        visit, REACHED), goals and dwells (DWELL: a goal ended without a visit) go to the
        recorder."""
        record = self.recorder.record_event

        def emit(kind: int, vertex: int, from_vertex: int, t: float) -> None:
            record(robot, kind, vertex, from_vertex, t)

        return emit

    def announcer(self, robot: int) -> Callable[[int, float], None]:
        record = self.recorder.record_announcement
        return lambda vertex, t: record(robot, vertex, t)

    # --- team messages ---
    def deliver_ready(self) -> None:
        """Hand every ready message to its live recipients (with faults: the team's delivery,
        which feeds each recipient's liveness first)."""
        machines = self.machines
        if self.team is not None:
            self.bus.deliver_through(self.team, self.now,
                                     lambda r, message: machines[r].on_message(message))
            return
        delivered = 0
        while self.bus.ready:  # messages sent on the way join in
            message, recipients = self.bus.ready.popleft()
            for r in recipients:
                machine = machines[r]
                if machine.alive:
                    machine.on_message(message)
                    delivered += 1
        self.bus.count_delivered(delivered)

    # --- liveness (runs with faults) ---
    def start_liveness(self) -> None:
        """Plan every robot's first liveness check (after the start, at run time now)."""
        if self.team is not None:
            self.team.start(self.now)

    def liveness_due(self, robot: int, token: int) -> None:
        """A planned liveness check of robot `robot` (stale when `token` is not its latest)."""
        self.team.check_due(robot, token, self.now)

    def _schedule_check(self, robot: int, time_s: float) -> int:
        """TeamLiveness's hook: plan robot `robot`'s check at run time time_s [s]; its token."""
        token = next(self._check_tokens)
        self._liveness_at(time_s, robot, token)
        return token

    def _liveness_at(self, time_s: float, robot: int, token: int) -> None:  # pragma: no cover
        raise NotImplementedError

    @property
    def losses(self) -> list[tuple[float, int, int]]:
        """(t [s], observer, lost teammate) of every liveness loss."""
        return self.team.losses if self.team is not None else []

    # --- faults ---
    def inject(self, fault: Fault) -> None:
        """The fault's steps, in TeamLiveness.inject's order (the graph loop's)."""
        self.team.inject(fault.robot, fault.kind == DEATH, self.now)

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
        died_at = {int(robot): float(t) for t, robot in self.recorder.deaths}
        return liveness_summary(float(self.config.teammate_timeout_s), self.links.period_s,
                                died_at, self.losses)

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
