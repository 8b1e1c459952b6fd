"""The team glue of runs with faults is written once, in the core (tpuaf_core.TeamLiveness:
liveness checks, delivery that feeds liveness, a fault's steps): both runtimes hold it, and a
death takes its steps in its one order (team_liveness.cpp; the C++ tests check the order
without Python)."""

from __future__ import annotations

import tpuaf_core
from tpuaf.runtimes.base import TeamRun
from tpuaf.runtimes.config import PhysicsConfig, RunConfig
from tpuaf.runtimes.graph import GraphRun
from tpuaf.runtimes.physics import PhysicsRun

TEAM = dict(map="grid", strategy="gbs", robots=3, duration_s=30, seed=1)


def test_both_runtimes_hold_the_cores_team_only_with_faults():
    assert isinstance(GraphRun(RunConfig(**TEAM, fail=["1@10"]))._engine.team,
                      tpuaf_core.TeamLiveness)
    assert isinstance(PhysicsRun(PhysicsConfig(**TEAM, fail=["1@10"])).team,
                      tpuaf_core.TeamLiveness)
    assert GraphRun(RunConfig(**TEAM))._engine.team is None
    assert PhysicsRun(PhysicsConfig(**TEAM)).team is None


def test_a_physics_death_takes_the_teams_steps_in_order():
    run = PhysicsRun(PhysicsConfig(**TEAM, fail=["1@10"]))
    steps = []

    def stop_motion(robot):  # the first step: still alive for its machine, bus and recorder
        steps.append(("stop", robot, run.machines[robot].alive, run.bus.core.alive(robot),
                      len(run.recorder.deaths)))

    def schedule_check(robot, time_s):
        steps.append(("check", robot))
        return TeamRun._schedule_check(run, robot, time_s)

    run._stop_motion = stop_motion
    run._schedule_check = schedule_check
    summary = run.run()
    first = steps.index(("stop", 1, True, True, 0))
    assert steps[first + 1:first + 3] == [("check", 0), ("check", 2)]  # every survivor's
    assert steps.count(("check", 1)) > 0 and ("check", 1) not in steps[first:]
    assert not run.machines[1].alive and not run.bus.core.alive(1)
    assert run.recorder.deaths == [(10.0, 1)]
    assert summary["liveness"]["deaths"][0]["robot"] == 1
