"""Turns at vertices in the plan's time (navigation/travel_time.py `turn_times`): a timed map
says what each way of arriving at an edge's first vertex adds to the edge's mean time; the
graph runtime's robots and the learned durations use it (tpuaf_plus's walk arcs do not:
docs/STRATEGIES.md, "Turns in the plan")."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from tpuaf.maps import PatrolMap
from tpuaf.navigation.planner import PathPlanner
from tpuaf.navigation.travel_time import (
    RobotKinematics,
    arrival_durations,
    edge_durations,
    timed_map,
)
from tpuaf.robot.learning import LearnedTravel
from tpuaf.runtimes.config import RunConfig
from tpuaf.runtimes.graph import GraphRun
from tpuaf.team.messages import Intention, Visit

from tests.test_travel_time import line_map


def tee() -> PatrolMap:
    """0 - 1 - 2 on a line (2 m edges) and 1 - 3 off to the side: test_travel_time's map."""
    return line_map()


def burger_timed():
    pm = tee()
    kin = RobotKinematics.from_preset("burger")
    planner = PathPlanner(pm, kin.radius_m)
    return pm, kin, planner, timed_map(pm, kin, planner)


def test_turning_back_costs_a_half_turn_and_straight_on_is_quicker_than_the_mean():
    pm, kin, planner, timed = burger_timed()
    turns = timed.turns
    durations = edge_durations(pm, kin, planner)
    arrivals = arrival_durations(pm, kin, planner)
    # each entry: that way of arriving's time, less the edge's mean
    for (w, u, v), s in turns.items():
        mean = durations[(min(u, v), max(u, v))]
        assert s == pytest.approx(arrivals[(w, u, v)] - mean)
    back, straight, side = turns[(0, 1, 0)], turns[(2, 1, 0)], turns[(3, 1, 0)]
    assert straight < side < back and straight < 0 < back
    # turning back at 1 costs a half turn in place (about 1.1 s at 2.84 rad/s), less the
    # last 0.1 m (the visit radius) it need not drive twice
    assert back - straight > 0.3
    # a dead end has one way of arriving (back along its edge), in the edge's mean already
    assert turns[(1, 0, 1)] > 0 and (1, 3, 1) in turns


def test_the_graph_runtime_times_a_walk_with_its_turns():
    """A robot patrols the tee alone on a map whose turns say that arriving at 1 from 2 (or
    3) and leaving for the other side arm takes 5 s longer: every lap of tpuaf_plus's closed
    walk (0-1-2-1-3-1, which passes 1 from one side arm to the other once) takes the edges'
    times plus those 5 s."""
    pm = replace(tee(), turns={(2, 1, 3): 5.0, (3, 1, 2): 5.0})
    run = GraphRun(RunConfig(map="tee", strategy="tpuaf_plus", robots=1, duration_s=200),
                   patrol_map=pm)
    graph, speed = run.patrol_map.graph, run.speed
    assert run.patrol_map.turns == pm.turns  # declared travel: the map as given
    run.run()
    walk = [int(v) for v in run._strategy.walk(0)]
    n = len(walk)
    edges_s = sum(graph.edge_length(walk[i], walk[(i + 1) % n]) for i in range(n)) / speed
    times = [t for t, _, v in run.recorder.visits if v == 0]
    gaps = np.diff(times[1:])
    assert len(gaps) >= 3
    assert gaps == pytest.approx(np.full(len(gaps), edges_s + 5.0), abs=1e-6)


def test_learned_traversals_leave_the_turn_out():
    """A robot that turns back at each end of edge 0-1 measures the edge plus a half turn;
    the samples take the plan map's turn off, so the learned time is the edge's own."""
    _, _, _, timed = burger_timed()
    learned = LearnedTravel(timed)
    edge_s = learned.durations.duration(0, 1)
    back = timed.turns[(1, 0, 1)] if (1, 0, 1) in timed.turns else 0.0
    back_at_1 = timed.turns[(0, 1, 0)]
    t, here = 0.0, 0
    for _ in range(8):  # 0 -> 1 -> 0 -> ...: each leg after the first starts with a turn back
        there = 1 - here
        turn = 0.0 if t == 0.0 else (back_at_1 if here == 1 else back)
        seconds = 1.1 * edge_s + turn  # the truth: 10 % slower than the model, plus the turn
        learned.observe(Intention(0, here, there, t + seconds, seconds, t))
        learned.observe(Visit(0, there, t + seconds))
        t, here = t + seconds, there
    assert learned.durations.duration(0, 1) == pytest.approx(1.1 * edge_s, rel=1e-6)


def test_no_robot_parks_on_ctcv_at_twelve_in_physics(shared_maps):
    """ctcv, 12 robots at 1 m/s, tpuaf_plus, physics, 300 s. The plan once parked robots on parts
    of one vertex (never visited again under the visit rule); such a part is now driven out and
    back, so every robot drives and every vertex keeps being visited. (The plan then no longer
    has the 7-9-8 corridor shared by two robots whose uneven gaps kept them apart at 9; the
    shared walks it has now cross head-on: docs/STRATEGIES.md, "No robot parks for good".)"""
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    run = PhysicsRun(PhysicsConfig(map=str(shared_maps / "ctcv"), strategy="tpuaf_plus",
                                   robots=12, duration_s=300.0, seed=1))
    summary = run.run()
    per_robot = np.bincount([r for _, r, _ in run.recorder.visits], minlength=12)
    assert per_robot.min() >= 5, per_robot.tolist()
    assert all(len(times) >= 3 for times in run.recorder.vertex_times)
    assert summary["worst_idleness_s"] < 100.0, summary["worst_idleness_s"]
