"""Learned travel times (tpuaf.robot.learning): the team's traversals, read from its Intention
and Visit messages, replace the model's durations and re-time the plan (issue 32, part 2)."""

from __future__ import annotations

import numpy as np
import pytest
import tpuaf_core
from tpuaf.maps import MapSettings, PatrolMap
from tpuaf.navigation.travel_time import MIN_SAMPLES
from tpuaf.robot.learning import RETIME_PERIOD_S, LearnedTravel
from tpuaf.runtimes.config import PhysicsConfig
from tpuaf.runtimes.physics import PhysicsRun
from tpuaf.team.messages import Intention, Visit


def ring_map(speed: float = 0.5, length: float = 2.0) -> PatrolMap:
    """Four vertices on a 2 m square, edges declared `length` [m] long (hand-built, generated
    corridors)."""
    pos = np.array([(1.0, 1.0), (3.0, 1.0), (3.0, 3.0), (1.0, 3.0)])
    return PatrolMap(name="ring", vertex_ids=[0, 1, 2, 3], positions=pos,
                     edges=[(0, 1, length), (1, 2, length), (2, 3, length), (3, 0, length)],
                     importance=np.full(4, 0.01), initial_uncertainty=np.ones(4),
                     settings=MapSettings(nominal_speed=speed, goal_tolerance=0.1),
                     corridor_width=1.0)


def drive(learned: LearnedTravel, robot: int, u: int, v: int, depart: float, seconds: float,
          planned: float = 4.0) -> None:
    """What a robot sends on one traversal: its Intention, then its Visit."""
    learned.observe(Intention(robot, u, v, depart + planned, planned, depart))
    learned.observe(Visit(robot, v, depart + seconds))


def test_traversals_of_the_team_converge_on_the_measured_median():
    pm = ring_map()  # 2 m at 0.5 m/s: the model says 4 s per edge
    learned = LearnedTravel(pm)
    assert learned.durations.duration(0, 1) == pytest.approx(4.0)
    rng = np.random.default_rng(1)
    t = 0.0
    for _lap in range(2 * MIN_SAMPLES):
        for u in range(4):  # two robots, one lap each per round; the truth is 6 s +- 0.5
            for robot in (0, 1):
                drive(learned, robot, u, (u + 1) % 4, t, 6.0 + float(rng.normal(0, 0.5)))
                t += 7.0
    for u in range(4):
        assert learned.durations.duration(u, (u + 1) % 4) == pytest.approx(6.0, abs=0.4)
    assert learned.traversals == 2 * MIN_SAMPLES * 4 * 2
    # Intentions for a multi-edge leg or a Visit of another vertex time nothing.
    learned.observe(Intention(0, 0, 2, 10.0, 8.0, 2.0))
    learned.observe(Visit(0, 2, 30.0))
    learned.observe(Intention(1, 0, 1, 10.0, 4.0, 6.0))
    learned.observe(Visit(1, 3, 30.0))
    assert learned.traversals == 2 * MIN_SAMPLES * 4 * 2


def test_the_plan_is_retimed_once_the_learned_times_differ():
    pm = ring_map()
    learned = LearnedTravel(pm)
    for k in range(MIN_SAMPLES - 1):
        drive(learned, 0, 0, 1, 10.0 * k, 6.0)
    assert learned.retimed_map(100.0) is None  # fewer than MIN_SAMPLES: still the model
    drive(learned, 0, 0, 1, 50.0, 6.0)
    retimed = learned.retimed_map(100.0)
    assert retimed is not None and learned.retimes == 1
    lengths = {(int(i), int(j)): length for i, j, length in retimed.edges}
    assert lengths[(0, 1)] == pytest.approx(0.5 * 6.0) and lengths[(1, 2)] == 2.0
    assert retimed.graph.distance(0, 1) == pytest.approx(3.0)  # the strategies' distances
    drive(learned, 0, 1, 2, 60.0, 8.0)
    for k in range(MIN_SAMPLES):
        drive(learned, 1, 2, 1, 70.0 + 10 * k, 8.0)
    assert learned.retimed_map(100.0 + RETIME_PERIOD_S / 2) is None  # not twice a minute
    assert learned.retimed_map(100.0 + RETIME_PERIOD_S).graph.distance(1, 2) == \
        pytest.approx(4.0)
    assert learned.summary()["learned_edges"] == 2


def test_a_core_strategy_host_takes_the_retimed_graph():
    pm = ring_map()
    host = tpuaf_core.PolicyHost(pm.graph, 2, 0)
    learned = LearnedTravel(pm)
    for k in range(MIN_SAMPLES):
        drive(learned, 1, 0, 1, 10.0 * k, 9.0)
    retimed = learned.retimed_map(60.0)
    host.set_graph(retimed.graph)
    del retimed  # the host keeps the graph alive
    other = PatrolMap(name="small", vertex_ids=[0, 1], positions=np.array([(0, 0), (1, 0.0)]),
                      edges=[(0, 1, 1.0)], importance=np.full(2, 0.01),
                      initial_uncertainty=np.ones(2), settings=MapSettings(), corridor_width=1.0)
    with pytest.raises(ValueError, match="2 vertices, the strategy's graph has 4"):
        host.set_graph(other.graph)


def test_physics_robots_learn_the_edges_they_drive():
    """On a hand-built square whose edges are declared 1.2 m (a hand-drawn graph; they are
    2 m), the plan on declared lengths is far too quick: the robots' learned durations match
    the traversals they drove, and the plan is re-timed on them."""
    pm = ring_map(speed=1.0, length=1.2)
    run = PhysicsRun(PhysicsConfig(map="ring", strategy="tpuaf", robots=2, duration_s=400,
                                   seed=1, robot="burger", travel="declared"), pm)
    run.run()
    driven: dict[tuple[int, int], list[float]] = {}
    last: dict[int, tuple[float, int]] = {}
    for t, robot, v in run.recorder.visits:
        if robot in last and last[robot][1] != v:
            u = last[robot][1]
            driven.setdefault((min(u, v), max(u, v)), []).append(t - last[robot][0])
        last[robot] = (t, v)
    for agent in run.agents:
        learned = agent.machine.learned
        summary = learned.summary()
        assert summary["learned_edges"] >= 1 and learned.retimes >= 1
        assert summary["median_learned_over_model"] > 1.5  # 2 m, not 1.2 m
        # Every robot learns from the team: both robots' traversals, not only its own.
        assert learned.traversals > agent.machine.visits - 1
        assert agent.machine.patrol_map is learned.plan_map
        for edge, times in driven.items():
            if len(times) >= 2 * MIN_SAMPLES:  # within 10 % of what the robots drove
                assert learned.durations.duration(*edge) == pytest.approx(np.median(times),
                                                                          rel=0.10)
        assert max(length for _, _, length in agent.machine.patrol_map.edges) > 1.5 * 1.2
