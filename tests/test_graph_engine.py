"""The graph runtime's C++ event loop: numpy's streams and sums bit for bit, the strategies of
the core reached from every runtime, clear errors.

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


def test_a_plan_without_a_walk_for_a_robot_is_refused():
    """A planner callback that leaves a robot without a walk is a clear error, not a crash."""
    from tpuaf.policies.tpuaf import new_knowledge

    patrol_map = load_map("grid")
    run = GraphRun(RunConfig(map="grid", strategy="cgg", robots=2, duration_s=10), patrol_map)
    walk = list(range(patrol_map.num_vertices))
    route = (walk, [float(i) for i in walk], float(len(walk)), [0])
    strategy = tpuaf_core.TpuafPlusStrategy(
        new_knowledge(patrol_map, 30.0), tpuaf_core.TpuafPlusParams(),
        lambda team, timing: ([route], [0, -1], [(-1, 0.0), (-1, 0.0)]))
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
