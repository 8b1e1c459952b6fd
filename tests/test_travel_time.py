"""Edge travel times (tpuaf.navigation.travel_time): the model's terms, the timed map, learned
durations, and one check against the physics world."""

from __future__ import annotations

import math
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from tpuaf.maps import MapSettings, PatrolMap, load_map
from tpuaf.navigation.controller import ControllerConfig
from tpuaf.navigation.planner import PathPlanner, shared_planner
from tpuaf.navigation.travel_time import (
    MIN_SAMPLES,
    EdgeDurations,
    RobotKinematics,
    directed_durations,
    edge_durations,
    path_duration,
    timed_map,
    turn_loss_s,
)

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def kinematics(**kw) -> RobotKinematics:
    base = dict(max_linear_speed=0.5, max_angular_speed=2.0, linear_accel=1.0,
                angular_accel=math.inf, corner_tolerance_m=1e-9)
    return RobotKinematics(**{**base, **kw})


def line_map() -> PatrolMap:
    """Three vertices on a line, 2 m apart, and a branch: 0 - 1 - 2, 1 - 3 (generated
    corridors)."""
    pos = np.array([(1.0, 1.0), (3.0, 1.0), (5.0, 1.0), (3.0, 3.0)])
    return PatrolMap(name="line", vertex_ids=[0, 1, 2, 3], positions=pos,
                     edges=[(0, 1, math.nan), (1, 2, math.nan), (1, 3, math.nan)],
                     importance=np.full(4, 0.01), initial_uncertainty=np.ones(4),
                     settings=MapSettings(nominal_speed=0.5, goal_tolerance=0.1),
                     corridor_width=1.0)


def test_straight_edge_is_length_over_speed_plus_acceleration():
    kin = kinematics()
    seconds = path_duration([(0.0, 0.0), (4.0, 0.0)], kin)
    accel = turn_loss_s(kin, 0.0, v0=0.0)  # from standstill
    assert seconds == pytest.approx(4.0 / 0.5 + accel, abs=1e-9)
    # v / (2 a) = 0.25 s, within the world step's Euler integration (0.05 s steps)
    assert accel == pytest.approx(0.5 / (2 * 1.0), abs=0.05)
    # unlimited acceleration: length / speed
    free = kinematics(linear_accel=math.inf)
    assert path_duration([(0.0, 0.0), (4.0, 0.0)], free) == pytest.approx(8.0, abs=1e-9)


def test_a_right_angle_costs_the_turn_time():
    kin = kinematics()
    straight = path_duration([(0.0, 0.0), (8.0, 0.0)], kin)
    corner = path_duration([(0.0, 0.0), (4.0, 0.0), (4.0, 4.0)], kin)
    turn = turn_loss_s(kin, 0.5 * math.pi)
    assert corner - straight == pytest.approx(turn, abs=1e-6)
    # at least the turn in place down to the controller's threshold, at the angular limit
    c = ControllerConfig()
    assert turn >= (0.5 * math.pi - c.turn_in_place) / kin.turn_rate
    # and the arrival heading counts the same way: a straight edge entered at 90 degrees
    assert path_duration([(0.0, 0.0), (4.0, 0.0)], kin, heading=0.5 * math.pi) == \
        pytest.approx(8.0 + turn, abs=1e-6)


def test_turn_loss_grows_with_the_angle_and_reads_the_controller():
    kin = kinematics()
    losses = [turn_loss_s(kin, a) for a in np.linspace(0, math.pi, 7)]
    assert losses[0] == pytest.approx(0.0, abs=1e-9)
    assert all(b > a for a, b in zip(losses, losses[1:], strict=False))
    # a wider turn-in-place threshold (the controller's) drives on through 90 degrees
    # (unlimited acceleration: otherwise both are still braking from the cruise speed)
    eager = kinematics(linear_accel=math.inf, controller=ControllerConfig(
        max_linear_speed=0.5, max_angular_speed=2.0, turn_in_place=2.0))
    strict = kinematics(linear_accel=math.inf)
    assert turn_loss_s(eager, 1.4) < turn_loss_s(strict, 1.4)


def test_effective_lengths_give_back_the_durations():
    pm = line_map()
    kin = RobotKinematics.from_preset("burger", 0.2)
    planner = PathPlanner(pm, kin.radius_m)
    durations = edge_durations(pm, kin, planner)
    assert set(durations) == {(0, 1), (1, 2), (1, 3)}
    timed = timed_map(pm, kin, planner)
    assert timed.settings.nominal_speed == 0.2
    assert pm.settings.nominal_speed == 0.5  # the source map is unchanged
    for i, j, length in timed.edges:
        assert length / timed.settings.nominal_speed == pytest.approx(durations[(i, j)])
        assert timed.graph.edge_length(i, j) / 0.2 == pytest.approx(durations[(i, j)])
        # slower than the plain planned length / speed, the mean of both directions
        plain = planner.check_edges()
        assert durations[(i, j)] > next(c.planned_m for c in plain
                                        if (c.u, c.v) == (i, j)) / 0.2
    directed = directed_durations(pm, kin, planner)
    assert durations[(1, 3)] == pytest.approx(0.5 * (directed[(1, 3)] + directed[(3, 1)]))
    # a robot model (tpuaf.robot.model.RobotModel's fields) is accepted as well
    model = SimpleNamespace(speed_mps=0.2, max_angular_speed=2.84, linear_accel=2.5,
                            angular_accel=3.2, radius_m=0.105)
    assert edge_durations(pm, model, planner) == pytest.approx(durations)


def test_learned_durations_replace_the_model_after_k_samples():
    pm = line_map()
    kin = RobotKinematics.from_preset("burger", 0.2)
    model = edge_durations(pm, kin, PathPlanner(pm, kin.radius_m))
    learned = EdgeDurations(model)
    assert learned.duration(0, 1) == model[(0, 1)]
    true_s = model[(0, 1)] * 1.3
    rng = np.random.default_rng(0)
    samples = true_s + rng.normal(0.0, 0.5, 40)
    for s in samples[:MIN_SAMPLES - 1]:
        learned.add(1, 0, float(s))  # either direction counts for the edge
    assert learned.samples(0, 1) == MIN_SAMPLES - 1
    assert learned.duration(0, 1) == model[(0, 1)]  # fewer than k: still the model
    learned.add(0, 1, float(samples[MIN_SAMPLES - 1]))
    assert learned.duration(0, 1) == pytest.approx(np.median(samples[:MIN_SAMPLES]))
    for s in samples[MIN_SAMPLES:]:
        learned.add(0, 1, float(s))
    assert learned.duration(0, 1) == pytest.approx(true_s, abs=0.3)
    assert learned[(1, 2)] == model[(1, 2)]  # other edges keep the model
    learned.add(1, 2, math.nan)
    learned.add(1, 2, -1.0)
    assert learned.samples(1, 2) == 0
    assert learned.as_dict()[(0, 1)] == learned.duration(0, 1)


def test_model_within_15_percent_of_physics_on_a_straight_edge(monkeypatch):
    """The physics world (C++ world, navigator and controller at 10 Hz) along three straight
    edges of the built-in grid; the middle one's traversal against the model."""
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    from bench_travel_time import walk

    pm = load_map("grid")
    kin = RobotKinematics.from_preset("patrolling_sim", 1.0)
    # vertices 0, 1, 2, 3: column 0, straight down
    traversals = walk(pm, "patrolling_sim", 1.0, 40.0, route=[0, 1, 2, 3])
    measured = {(u, v): s for u, v, s in traversals}
    assert (1, 2) in measured
    model = directed_durations(pm, kin, shared_planner(pm, kin.radius_m))[(1, 2)]
    assert abs(model - measured[(1, 2)]) <= 0.15 * measured[(1, 2)]


def test_bad_kinematics():
    with pytest.raises(ValueError, match="max_linear_speed"):
        RobotKinematics(max_linear_speed=0.0, max_angular_speed=1.0)
    assert sys.modules["tpuaf.navigation.travel_time"].MIN_SAMPLES >= 1
