"""One definition of a visit (issue 32, part 3; docs/RUNTIMES.md "Visits").

`tpuaf_core.VisitRule`: an arrival within the map's visit radius of a vertex after the robot was
farther than twice the radius from it. The graph engine, the RobotMachine of the physics runtime
and the ROS agents, the monitor and bag analysis all hold one per robot; a robot that stands
still on a vertex makes no visit (its dwells are counted apart)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import tpuaf_core
from tpuaf.maps import MapSettings, load_map
from tpuaf.measure.monitor import FleetMonitor
from tpuaf.policies import REGISTRY, Policy
from tpuaf.robot.machine import STAY_S
from tpuaf.runtimes.agent import AgentRuntime
from tpuaf.runtimes.config import PhysicsConfig, RunConfig
from tpuaf.runtimes.graph import GraphRun
from tpuaf.runtimes.physics import PhysicsRun
from tpuaf.topics import DWELL, GOAL, REACHED, START

REPO = Path(__file__).resolve().parents[1]
R = tpuaf_core.DEFAULT_VISIT_RADIUS_M


def pair_rule(radius: float = R) -> tpuaf_core.VisitRule:
    return tpuaf_core.VisitRule(np.array([[0.0, 0.0], [2.0, 0.0]]), radius)


# ---------------------------------------------------------------------------------------------
# The rule


def test_standing_on_the_start_vertex_never_visits_it_again():
    rule = pair_rule()
    rule.start(0, 0.02, 0.0)  # the start: the first visit
    assert rule.visits == 1 and not rule.armed(0) and rule.armed(1)
    assert not any(rule.arrive(0, 0.01 * (k % 3), 0.0) for k in range(900))
    assert rule.visits == 1


def test_an_arrival_after_driving_is_one_visit():
    rule = pair_rule()
    rule.start(0, 0.0, 0.0)
    assert not rule.arrive(1, 2.0 - 2 * R, 0.0)  # short of the radius: no visit
    assert rule.arrive(1, 2.0 - 0.9 * R, 0.0)
    assert not rule.arrive(1, 2.0, 0.0)  # a dwell on it
    assert rule.visits == 2


def test_wobble_within_the_hysteresis_does_not_rearm():
    rule = pair_rule()
    rule.start(0, 0.0, 0.0)
    rule.observe(1.9 * R, 0.0)  # inside 2 x the radius: still disarmed
    assert not rule.armed(0) and not rule.arrive(0, 0.0, 0.0)
    rule.observe(2.1 * R, 0.0)
    assert rule.armed(0) and rule.arrive(0, 0.5 * R, 0.0)


def test_bad_radius_and_vertex_are_refused():
    with pytest.raises(ValueError, match="visit_radius"):
        pair_rule(0.0)
    with pytest.raises(IndexError):
        pair_rule().arrive(5, 0.0, 0.0)


def test_the_default_is_declared_once_and_maps_may_override_it(tmp_path):
    assert R == 0.15 and MapSettings().visit_radius == R
    # declared in the C++ header only; Python reads tpuaf_core.DEFAULT_VISIT_RADIUS_M
    sources = [p for p in (REPO / "src").rglob("*") if p.suffix in (".py", ".hpp", ".cpp")]
    hits = [p for p in sources
            if re.search(r"(?i)visit_radius\w*\s*[:=]?\s*(float\s*)?=\s*0\.15",
                         p.read_text(errors="replace"))
            or "kDefaultVisitRadiusM = 0.15" in p.read_text(errors="replace")]
    assert [p.name for p in hits] == ["visit_rule.hpp"]
    assert load_map("grid").visit_radius_m == R
    assert load_map("lab").visit_radius_m == 0.05  # stops 0.6 m apart, goal tolerance 0.05 m
    folder = tmp_path / "m"
    folder.mkdir()
    (folder / "graph.yaml").write_text("vertices:\n  - {id: 0, x: 1.0, y: 1.0}\n"
                                       "  - {id: 1, x: 3.0, y: 1.0}\nedges:\n  - [0, 1]\n")
    (folder / "map.yaml").write_text("name: m\nsettings:\n  visit_radius: 0.1\n")
    assert load_map(folder).visit_radius_m == 0.1
    (folder / "map.yaml").write_text("name: m\nsettings:\n  goal_tolerance: 0.2\n"
                                     "  visit_radius: 0.3\n")
    with pytest.raises(Exception, match="visit_radius 0.3 m exceeds goal_tolerance"):
        load_map(folder)


# ---------------------------------------------------------------------------------------------
# The same rule in every runtime


class Stand(Policy):
    """Always picks the vertex it stands on (tpuaf_plus waiting at a vertex, at its worst)."""

    name = "stand_test"

    def decide(self, ctx):
        return ctx.current_vertex


@pytest.fixture()
def stand(monkeypatch):
    monkeypatch.setitem(REGISTRY._classes, Stand.name, Stand)
    return Stand


def test_every_runtime_holds_the_same_rule(stand):
    grid = load_map("grid")
    graph = GraphRun(RunConfig(map="grid", strategy=stand.name, robots=2, duration_s=5))
    agent = AgentRuntime(grid, stand(), 0, 1, 0, lambda m: None, lambda *e: None)
    monitor = FleetMonitor(grid, 2, 10.0)
    rules = [graph._engine.visit_rule(0), agent.machine.visit_rule, monitor._rules[0]]
    assert all(type(r) is tpuaf_core.VisitRule and r.radius == R for r in rules)


def test_a_robot_standing_on_its_vertex_makes_no_visit_in_the_graph_runtime(stand):
    run = GraphRun(RunConfig(map="grid", strategy=stand.name, robots=3, duration_s=100))
    summary = run.run()
    assert summary["visits"] == 3  # the starts only
    # one dwell per STAY_S and robot, counted apart; patrolling_sim would count them all
    assert summary["dwells"] == pytest.approx(3 * 100 / STAY_S, abs=3)
    assert summary["dwell_time_s"] == pytest.approx(summary["dwells"] * STAY_S)
    assert summary["visits_patrolling_sim"] == summary["visits"] + summary["dwells"]


def test_an_agent_that_stands_or_wobbles_on_its_goal_makes_no_visit(stand):
    """The physics runtime's and the ROS node's agent, placed on its goal for 900 s (the issue's
    DIAG_labs robots moved 0.3 m in 900 s and logged 897 visits each)."""
    grid = load_map("grid")
    events = []
    agent = AgentRuntime(grid, stand(), 0, 1, 0, lambda m: None,
                         lambda k, v, f, t: events.append((k, v)))
    x, y = grid.positions[7]
    rng = np.random.default_rng(1)
    for k in range(9000):
        jitter = rng.uniform(-0.1, 0.1, 2)  # within the re-arm distance 2 x 0.15 m
        agent.on_pose(0.1 * k, x + jitter[0], y + jitter[1], 0.0)
        agent.tick(0.1 * k, None)
    kinds = [k for k, _ in events]
    assert kinds.count(START) == 1 and kinds.count(REACHED) == 0
    assert agent.machine.visits == 0 and kinds.count(DWELL) == agent.machine.dwells >= 800
    assert agent.machine.dwell_time_s == pytest.approx(agent.machine.dwells * STAY_S, rel=0.1)


class LoggedPhysics(PhysicsRun):
    """A physics run that keeps every agent event and ground-truth pose it records."""

    def __init__(self, config):
        self.events: list[tuple] = []
        self.poses: list[tuple[float, np.ndarray]] = []
        super().__init__(config)
        record = self.recorder.record_positions

        def record_positions(t, positions):
            self.poses.append((float(t), np.array(positions, dtype=float)))
            record(t, positions)

        self.recorder.record_positions = record_positions

    def visit_listener(self, robot):
        emit = super().visit_listener(robot)

        def logged(kind, vertex, from_vertex, t):
            self.events.append((float(t), robot, kind, vertex, from_vertex))
            emit(kind, vertex, from_vertex, t)

        return logged


def test_the_monitor_finds_the_agents_visits_on_their_trajectory():
    """Physics runtime (agents' RobotMachine) and FleetMonitor (ground truth, the live monitor
    and `tpuaf analyze`): the same rule on the same trajectory gives the same visits, to the
    tick."""
    duration = 150.0
    run = LoggedPhysics(PhysicsConfig(map="grid", strategy="tpuaf_plus", robots=3,
                                      duration_s=duration))
    summary = run.run()
    monitor = FleetMonitor(run.patrol_map, 3, duration, lag_s=0.5)
    events = sorted(run.events, key=lambda e: e[0])
    k = 0
    for t, poses in run.poses:
        while k < len(events) and events[k][0] <= t:
            stamp, robot, kind, vertex, from_vertex = events[k]
            monitor.on_event(robot, kind, vertex, stamp, from_vertex)
            k += 1
        for r in range(3):
            monitor.on_pose(r, t, *poses[r])
    for r in range(3):  # flush the last groups
        monitor.on_pose(r, duration + 1.0, *run.poses[-1][1][r])
    got = monitor.summary()
    agents = [(round(t, 6), r, v) for t, r, v in run.recorder.visits]
    assert [(round(t, 6), r, v) for t, r, v in monitor.recorder.visits] == agents
    assert got["visits"] == summary["visits"] > 3
    assert got["dwells"] == summary["dwells"] == sum(a.machine.dwells for a in run.agents)
    assert sum(1 for e in run.events if e[2] == GOAL) > 0
