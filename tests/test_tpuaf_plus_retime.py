"""tpuaf_plus on learned travel times (issue 32): with `retime` on, a re-timed plan map (robot/
learning.py) re-times its walks: arc positions, lap length and spacing targets follow the learned
edge durations, the walks stay; off (the default) it keeps the model's times."""

from __future__ import annotations

import collections
import math

import numpy as np
import pytest
import tpuaf_core
from tpuaf.maps import MapSettings, PatrolMap
from tpuaf.navigation.travel_time import MIN_SAMPLES
from tpuaf.policies.tpuaf_plus import TpuafPlus
from tpuaf.robot.learning import LearnedTravel
from tpuaf.runtimes.config import PhysicsConfig
from tpuaf.runtimes.physics import PhysicsRun
from tpuaf.team.messages import Intention, Visit

SPEED = 0.5  # [m/s] plan speed of the square


def square() -> PatrolMap:
    """Four vertices on a 2 m square, 2 m edges (4 s each at 0.5 m/s), robots start at 0 and 2."""
    pos = np.array([(1.0, 1.0), (3.0, 1.0), (3.0, 3.0), (1.0, 3.0)])
    return PatrolMap(name="square", vertex_ids=[0, 1, 2, 3], positions=pos,
                     edges=[(0, 1, 2.0), (1, 2, 2.0), (2, 3, 2.0), (3, 0, 2.0)],
                     importance=np.full(4, 0.01), initial_uncertainty=np.ones(4),
                     settings=MapSettings(nominal_speed=SPEED, goal_tolerance=0.1,
                                          initial_vertices={2: [0, 2]}),
                     corridor_width=1.0)


def started(pm: PatrolMap, retime: bool):
    """The team's core strategy and robot 0's host, started at t = 0."""
    params = TpuafPlus({"retime": retime}).params
    strategy = TpuafPlus.core_strategy(params, pm, 2, [])
    host = tpuaf_core.PolicyHost(pm.graph, 2, 0)
    host.set_state(0.0, 0, SPEED)
    strategy.start(host)
    return strategy, host


def slow_edge_map(pm: PatrolMap) -> PatrolMap:
    """The plan map re-timed on the team's traversals: edge 0-1 driven in 8 s (twice the model's
    4 s), the others as modelled."""
    learned = LearnedTravel(pm)
    for k in range(MIN_SAMPLES):
        learned.observe(Intention(1, 0, 1, 10.0 * k + 4.0, 4.0, 10.0 * k))
        learned.observe(Visit(1, 1, 10.0 * k + 8.0))
    retimed = learned.retimed_map(60.0)
    assert retimed is not None
    return retimed


def step_lengths(strategy, pm: PatrolMap) -> tuple[list[float], list[float], float]:
    """(the walk's step lengths on pm [m], its arc steps as the strategy holds them [m], L)."""
    walk = list(strategy.walk(0))
    arc, length, _ = strategy.timing(0)
    steps = [pm.graph.edge_length(walk[i], walk[(i + 1) % len(walk)]) for i in range(len(walk))]
    held = [b - a for a, b in zip(arc, [*arc[1:], length], strict=True)]
    return steps, held, length


@pytest.mark.parametrize("retime", [True, False])
def test_the_walk_timing_follows_the_learned_durations_only_when_retiming(retime):
    pm = square()
    strategy, host = started(pm, retime)
    walk = list(strategy.walk(0))
    steps, held, length = step_lengths(strategy, pm)
    assert held == pytest.approx(steps) and length == pytest.approx(8.0)  # the model: 4 x 2 m
    retimed = slow_edge_map(pm)
    host.set_graph(retimed.graph)
    host.set_state(60.0, 0, SPEED)
    strategy.retime(host)
    assert list(strategy.walk(0)) == walk  # the tour stays
    new_steps, held, length = step_lengths(strategy, retimed)
    if retime:  # 0-1 is 4 m of plan travel now: the lap is 10 m, the even gap 5 m (10 s)
        assert held == pytest.approx(new_steps) and length == pytest.approx(10.0)
    else:  # the model's times
        assert held == pytest.approx(steps) and length == pytest.approx(8.0)
        assert held != pytest.approx(new_steps)


def test_retiming_is_gated_by_how_far_the_spacing_targets_move():
    """Two robots on the square, 0-1 twice as slow: robots L / 2 apart on the model's walk are
    6 m and 4 m of plan travel apart on the re-timed one, 0.2 of the even gap 5 m off (the
    default tolerance 0.1 re-times); a uniformly slower walk moves no target."""
    walk, robots = [0, 1, 2, 3], [0, 1]
    model = (walk, [0.0, 2.0, 4.0, 6.0], 8.0, robots, [])
    slow = (walk, [0.0, 4.0, 6.0, 8.0], 10.0, robots, [])
    assert tpuaf_core.retime_gap_change(model, slow) == pytest.approx(0.2)
    assert tpuaf_core.TpuafPlusParams().retime_tolerance < 0.2
    uniform = (walk, [0.0, 3.0, 6.0, 9.0], 12.0, robots, [])
    assert tpuaf_core.retime_gap_change(model, uniform) == pytest.approx(0.0, abs=1e-12)
    assert tpuaf_core.retime_gap_change((walk, [0.0, 2.0, 4.0, 6.0], 8.0, [0], []), slow) == 0


def polygon(sides: list[float]) -> np.ndarray:
    """Vertices of a convex polygon with these side lengths [m], inscribed in a circle."""
    lo, hi = max(sides) / 2 * (1 + 1e-12), 1e3
    for _ in range(200):  # the radius whose central angles sum to 2 pi
        r = (lo + hi) / 2
        lo, hi = (r, hi) if sum(2 * math.asin(s / (2 * r)) for s in sides) > 2 * math.pi \
            else (lo, r)
    angles = np.cumsum([0.0] + [2 * math.asin(s / (2 * r)) for s in sides[:-1]])
    return np.c_[np.cos(angles), np.sin(angles)] * r + r + 2


def steady_gaps(run: PhysicsRun, from_s: float) -> list[float]:
    times = collections.defaultdict(list)
    for t, _, vertex in run.recorder.visits:
        times[vertex].append(t)
    return [b - a for ts in times.values() for a, b in zip(ts, ts[1:], strict=False)
            if a >= from_s]


def test_physics_spacing_evens_in_time_on_a_hand_drawn_ring(monkeypatch):
    """A hand-drawn ring: 8 edges all declared 4 m, one of them 16 m long, the others 2 m.
    Three robots spaced on the declared lengths pass a vertex unevenly in time; re-timed on
    what they learn, every vertex waits close to the mean gap (measured: 27.5 s -> 15.1 s
    worst, mean 14.3 s). Legs on the planned paths' centre lines (not kept right), as when the
    figures were measured. (With a 12 m edge and 3 m ones, the ring this test had, the
    closed-loop spacing alone keeps it even since the controller's door rule (test_doors.py):
    13.1 against 13.0 s re-timed; it was 21.6 s.)"""
    from tpuaf.navigation import navigator

    monkeypatch.setattr(navigator, "KEEP_RIGHT_SHARE", 0.0)
    sides = [16.0] + [2.0] * 7
    n = len(sides)
    pm = PatrolMap("ring", list(range(n)), polygon(sides),
                   [(i, (i + 1) % n, 4.0) for i in range(n)], np.ones(n), np.ones(n),
                   MapSettings(initial_vertices={3: [0, 2, 4]}))
    worst = {}
    for retime in (False, True):
        run = PhysicsRun(PhysicsConfig(map="ring", strategy="tpuaf_plus", robots=3, seed=1,
                                       duration_s=450.0, travel="declared",
                                       strategy_params={"retime": retime}), patrol_map=pm)
        run.run()
        gaps = steady_gaps(run, 150.0)
        worst[retime] = max(gaps)
        if retime:
            assert max(gaps) <= 1.2 * float(np.mean(gaps)), (max(gaps), np.mean(gaps))
            assert all(a.machine.learned.retimes >= 1 for a in run.agents)
    assert worst[True] <= 0.75 * worst[False], worst
