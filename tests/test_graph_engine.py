"""The graph runtime's C++ event loop: numpy's streams and sums bit for bit, heartbeats as the
physics runtime's, the strategies of the core reached from every runtime, clear errors.

Its results against committed outputs: tests/test_runtime_equivalence.py.
"""

from __future__ import annotations

import numpy as np
import pytest
import tpuaf_core
from tpuaf.maps import load_map
from tpuaf.policies import REGISTRY
from tpuaf.policies.core import CoreStrategyPolicy
from tpuaf.runtimes.config import RunConfig
from tpuaf.runtimes.graph import GraphRun


@pytest.mark.parametrize("key", [[3, 1], [0, 2, 5], [7, 2, 11]])
def test_numpy_pcg64_stream_is_numpy_s(key):
    g = np.random.default_rng(key)
    c = tpuaf_core.NumpyPcg64(g.bit_generator.state)
    assert np.array_equal(g.random(500), [c.random() for _ in range(500)])
    for n in (1, 2, 3, 7, 1000, 2**31 + 5, 2**32):
        assert [int(g.integers(0, n)) for _ in range(50)] == [c.integers(n) for _ in range(50)]
    assert [int(g.choice(np.array([4, 5, 9]))) for _ in range(50)] == [
        [4, 5, 9][c.integers(3)] for _ in range(50)]
    assert c.state == g.bit_generator.state


def test_numpy_mean_is_bit_identical():
    rng = np.random.default_rng(5)
    for n in [1, 5, 8, 9, 127, 128, 129, 1000, 8191, 8192, 8193, 20011, 100003]:
        a = rng.random(n) * 1e3
        assert tpuaf_core.numpy_mean(a) == float(np.mean(a))


@pytest.mark.parametrize(("loss", "delay_s", "period_s"), [(0.0, 0.0, 1.0), (0.4, 5.0, 1.0),
                                                          (0.7, 0.3, 0.7)])
def test_heartbeat_links_in_cpp_equal_python_s(loss, delay_s, period_s):
    """Every query of the C++ HeartbeatLinks answers as tpuaf.team.liveness.HeartbeatLinks,
    before and after deaths (at a heartbeat's instant and between two)."""
    import math

    import tpuaf_core
    from tpuaf.team.liveness import HeartbeatLinks

    n, duration, timeout, seed = 5, 120.0, 3.0, 11
    python = HeartbeatLinks(n, duration, timeout, delay_s, loss, seed, period_s)
    rngs = [tpuaf_core.NumpyPcg64(np.random.default_rng([seed, 4, j]).bit_generator.state)
            for j in range(n)]
    native = tpuaf_core.HeartbeatLinks(n, duration, timeout, delay_s, loss, period_s, rngs)
    rng = np.random.default_rng(0)
    checked, dead = 0, False
    for now in np.sort(rng.uniform(0.0, duration + 10.0, 150)).tolist() + [7 * period_s]:
        if now > 40.0 and not dead:
            dead = True
            for links in (python, native):
                links.died(1, 40.0)
                links.died(3, 21 * period_s)  # exactly at a heartbeat
        for i in range(n):
            for j in range(n):
                assert native.last_arrival_s(i, j, now) == python.last_arrival_s(i, j, now)
                last_heard = python.last_arrival_s(i, j, now)
                for heard in (last_heard, -math.inf, now - 0.5 * timeout):
                    for lost in (False, True):
                        assert native.next_check_s(i, j, heard, lost, now) == \
                            python.next_check_s(i, j, heard, lost, now)
                        checked += 1
    assert dead and checked > 10000



def test_a_plan_without_a_walk_for_a_robot_is_refused():
    """A planner callback that leaves a robot without a walk is a clear error, not a crash."""
    from tpuaf.policies.tpuaf import new_knowledge

    patrol_map = load_map("grid")
    run = GraphRun(RunConfig(map="grid", strategy="cgg", robots=2, duration_s=10), patrol_map)
    walk = list(range(patrol_map.num_vertices))
    route = (walk, [float(i) for i in walk], float(len(walk)), [0])
    strategy = tpuaf_core.TpuafPlusStrategy(
        new_knowledge(patrol_map, 30.0, 60.0), tpuaf_core.TpuafPlusParams(),
        lambda team: ([route], [0, -1], [(-1, 0.0), (-1, 0.0)]))
    run._engine.set_strategy(strategy)
    with pytest.raises(ValueError, match="no walk for robot 1"):
        run._engine.run()


def test_tpuaf_and_tpuaf_plus_are_written_once_in_the_core():
    """The strategies of the core have no Python decision path: their policies only build the
    core's strategy, and the graph runtime runs that same object for the whole team."""
    for name in ("tpuaf", "tpuaf_plus"):
        cls = REGISTRY.get(name)
        assert issubclass(cls, CoreStrategyPolicy)
        assert "decide" not in vars(cls) and "on_message" not in vars(cls)
        run = GraphRun(RunConfig(map="grid", strategy=name, robots=3, duration_s=120))
        assert run.core_strategy and not run.robots
        assert isinstance(run._strategy, tpuaf_core.TeamStrategy)
        assert run.run()["visits"] > 5


def test_a_core_policy_on_a_live_clock_sends_what_the_core_decides():
    """One robot's policy (physics runtime, ROS agent) over a PolicyHost: its decision is a
    neighbour, it announces a visit and an intention, and what it hears changes its knowledge."""
    from tpuaf.team.messages import Intention, Visit

    grid = load_map("grid")

    class Context:
        robot, n_robots, patrol_map = 1, 3, grid
        rng = np.random.default_rng([4, 2, 1])
        now, current_vertex, average_speed = 0.0, 12, 1.0

        def __init__(self):
            self.sent, self.wakes = [], []

        def send(self, message):
            self.sent.append(message)

        def wake_at(self, t):
            self.wakes.append(t)

    ctx = Context()
    policy = REGISTRY.create("tpuaf")
    policy.start(ctx)
    policy.on_message(Visit(0, 13, 0.0, 14), ctx)
    assert policy.knowledge.last_visit[13] == 0.0
    goal = policy.decide(ctx)
    assert goal in grid.graph.neighbours(12) and goal != 13  # 13 was just seen
    assert [type(m) for m in ctx.sent] == [Visit, Intention]
    assert ctx.sent[0] == Visit(1, 12, 0.0, goal) and ctx.sent[1].vertex == goal
    plus = REGISTRY.create("tpuaf_plus")
    ctx = Context()
    plus.start(ctx)
    assert set(plus.team) == {0, 1, 2} and len(plus.walk) >= 1
