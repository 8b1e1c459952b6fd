"""What the graph and physics runtimes share: the team around the robots' machines.

`TeamRun` holds the run's configuration, map, `TeamBus` and `RunRecorder`, and does for every
robot what does not depend on how robots move: visits and announcements to the recorder,
delivery of ready team messages to the live machines, the fault injection (death, stall) and
the run summary. A runtime subclasses it and supplies motion through three hooks:
`_stop_motion(i)` (a death: stop where it is), `_after_stall(i)` and `_notify_lost_at(t, i)`
(tell the survivors at time t [s] that robot i went silent, as heartbeats would).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict
from typing import Any

import numpy as np

from tpuaf.maps import load_map
from tpuaf.measure.metrics import RunRecorder
from tpuaf.robot.machine import RobotMachine
from tpuaf.runtimes.config import RunConfig, travel_map
from tpuaf.runtimes.faults import DEATH, Fault
from tpuaf.team.bus import TeamBus
from tpuaf.topics import REACHED, START


class TeamRun:
    runtime = "team"

    def __init__(self, config: RunConfig, patrol_map=None):
        config.validate()
        self.config = config
        self.patrol_map = travel_map(config, patrol_map if patrol_map is not None
                                     else load_map(config.map))
        self.seed = int(config.seed)
        self.now = 0.0
        self.bus = TeamBus(config.robots, config.delay_s, config.loss,
                           np.random.default_rng([self.seed, 1]))
        self.faults = config.faults()
        self.recorder: RunRecorder | None = None
        self.machines: list[RobotMachine] = []

    def _record(self, speed_mps: float | None = None) -> RunRecorder:
        """The run's recorder (speed [m/s] of the robots when it differs from the map's)."""
        extra = {} if speed_mps is None else {"speed_mps": speed_mps}
        self.recorder = RunRecorder(self.patrol_map, self.config.robots,
                                    sample_period_s=self.config.sample_period_s, **extra)
        return self.recorder

    def _team(self, machines: list[RobotMachine]) -> None:
        """The robots' machines, in index order; their announcements are recorded (recovery
        metrics) when the run has faults."""
        self.machines = machines
        if self.faults:
            for machine in machines:
                machine.on_announce = self.announcer(machine.robot)

    # --- recording ---
    def visit_listener(self, robot: int) -> Callable[[int, int, int, float], None]:
        """The `emit` of robot `robot`'s machine: its visits (START: the start vertex's first
        visit, REACHED) go to the recorder."""
        record_visit = self.recorder.record_visit

        def emit(kind: int, vertex: int, _from_vertex: int, t: float) -> None:
            if kind == REACHED or kind == START:
                record_visit(robot, vertex, t)

        return emit

    def announcer(self, robot: int) -> Callable[[int, float], None]:
        record = self.recorder.record_announcement
        return lambda vertex, t: record(robot, vertex, t)

    # --- team messages ---
    def deliver_ready(self) -> None:
        """Hand every ready message to its live recipients."""
        ready = self.bus.ready
        machines = self.machines
        stats = self.bus.stats
        while ready:
            message, recipients = ready.popleft()
            for r in recipients:
                machine = machines[r]
                if machine.alive:
                    machine.on_message(message)
                    stats.delivered += 1

    def teammate_lost(self, robot: int) -> None:
        for machine in self.machines:
            machine.on_teammate_lost(robot)

    # --- faults ---
    def inject(self, fault: Fault) -> None:
        i = fault.robot
        machine = self.machines[i]
        if not machine.alive:
            return
        if fault.kind == DEATH:
            self._stop_motion(i)
            machine.die()
            self.bus.alive[i] = False
            self.recorder.record_robot_death(i, self.now)
            self._notify_lost_at(self.now + self.config.teammate_timeout_s, i)
            return
        machine.stall()
        self.recorder.record_robot_stall(i, self.now)
        self._after_stall(i)

    def _stop_motion(self, robot: int) -> None:
        """A death: the robot stops where it is now."""

    def _after_stall(self, robot: int) -> None:
        """A stall: the robot no longer moves (its machine keeps deciding)."""

    def _notify_lost_at(self, time_s: float, robot: int) -> None:  # pragma: no cover
        raise NotImplementedError

    # --- results ---
    def summary(self) -> dict[str, Any]:
        summary = self.recorder.summary(self.now)
        summary["messages"] = asdict(self.bus.stats)
        summary["faults"] = [f.to_dict() for f in self.faults if f.time_s <= self.now]
        return summary
