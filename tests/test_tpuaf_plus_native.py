"""TPUAF+'s C++ decision path (tpuaf_core.TpuafPlusStrategy) equals the Python policy.

Both run on the C++ event loop: the Python `TpuafPlus` called back from it
(`native_policy=False`) and the C++ strategy, whose plans come from the same Python planner.
Every case is checked to reach the branch it is there for (counted on the Python policy):
re-spacing on a shared cycle after a loss, a lone robot's urgent entry into an orphaned part,
several robots entering a new shared walk (transition entries), a stalled robot's goal
failures, and message loss with delay.
"""

from __future__ import annotations

import collections

import pytest
import tpuaf_core
from tpuaf.maps import load_map
from tpuaf.policies import tpuaf_plus
from tpuaf.runtimes.config import RunConfig
from tpuaf.runtimes.graph import BatchRun
from tpuaf.runtimes.native import NativeRun, make_run

from .conftest import PATROLLING_SIM_MAPS
from .test_engine_faults_golden import _assert_same as assert_same

CASES = [
    # (map, robots, duration [s], seed, faults and bus, strategy parameters, branches it reaches)
    ("grid", 4, 600, 11, dict(fail=[(1, 200.0)]), {}, {"_respace_target"}),
    ("grid", 6, 600, 13, dict(fail=[(0, 150.0), (2, 150.0), (3, 150.0)]), {},
     {"_respace_target"}),
    ("grid", 5, 600, 12, dict(fail=[(1, 200.0)], loss=0.3, delay_s=5.0), {},
     {"_respace_target"}),
    ("grid", 4, 600, 11, dict(stall=[(0, 90.0)], fail=[(3, 240.0)]), {},
     {"on_goal_failed", "_respace_target"}),
    ("grid", 7, 900, 3, dict(loss=0.2), {}, set()),
    ("1r5", 6, 1200, 3, dict(fail=[(1, 600.0)]), {"plan": "partition", "repair": "replan"},
     {"_urgent_entry", "_transition_entries"}),
    ("1r5", 6, 1200, 3, dict(fail=[(1, 600.0), (3, 700.0)]),
     {"plan": "partition", "repair": "merge"}, {"_repair_hop"}),
    ("cumberland", 12, 1500, 1, dict(fail=[(0, 600.0), (4, 600.0), (8, 600.0)]), {},
     {"_transition_entries"}),
]


def _map(name: str):
    if name == "grid":
        return load_map("grid")
    if not PATROLLING_SIM_MAPS.is_dir():
        pytest.skip(f"reference maps not found at {PATROLLING_SIM_MAPS}")
    return load_map(str(PATROLLING_SIM_MAPS / name))


def _count_branches(monkeypatch) -> collections.Counter:
    """Calls of the Python policy's branches that returned something (patched in place)."""
    count: collections.Counter = collections.Counter()

    def counted(owner, name):
        original = getattr(owner, name)

        def call(*args, **kwargs):
            result = original(*args, **kwargs)
            if result is not None and result != {}:
                count[name] += 1
            return result

        monkeypatch.setattr(owner, name, call)

    counted(tpuaf_plus, "_urgent_entry")
    for name in ("_transition_entries", "_respace_target", "_repair_hop"):
        counted(tpuaf_plus.TpuafPlus, name)
    original = tpuaf_plus.TpuafPlus.on_goal_failed

    def failed(self, vertex, ctx):
        count["on_goal_failed"] += 1
        return original(self, vertex, ctx)

    monkeypatch.setattr(tpuaf_plus.TpuafPlus, "on_goal_failed", failed)
    return count


@pytest.mark.parametrize(("name", "robots", "duration", "seed", "extra", "params", "branches"),
                         CASES, ids=[f"{c[0]}-{c[1]}-{i}" for i, c in enumerate(CASES)])
def test_cpp_decision_path_equals_python_policy(monkeypatch, name, robots, duration, seed, extra,
                                                params, branches):
    patrol_map = _map(name)
    config = dict(map=name, strategy="tpuaf_plus", robots=robots, duration_s=duration, seed=seed,
                  strategy_params=params, **extra)
    count = _count_branches(monkeypatch)
    python = NativeRun(RunConfig(**config), patrol_map, native_policy=False)
    summary_python = python.run()
    assert branches <= {k for k, v in count.items() if v > 0}, dict(count)
    native = NativeRun(RunConfig(**config), patrol_map)
    assert native.native_policy
    summary_native = native.run()
    # every summary value (recovery, liveness), visits, 1 Hz rows, X, losses, announcements
    assert_same(python, summary_python, native, summary_native)
    assert native.bus.stats == python.bus.stats


@pytest.fixture(scope="module")
def maps():
    return {"grid": load_map("grid")}


def test_cpp_decision_path_equals_the_python_loop(maps):
    """The whole chain: the Python event loop (BatchRun) with the Python policy."""
    config = dict(map="grid", strategy="tpuaf_plus", robots=5, duration_s=600, seed=4,
                  fail=[(2, 250.0)], loss=0.1)
    python = BatchRun(RunConfig(**config), maps["grid"])
    native = NativeRun(RunConfig(**config), maps["grid"])
    assert native.native_policy
    assert native.run() == python.run()
    assert native.recorder.visits == python.recorder.visits


def test_auto_engine_runs_tpuaf_plus_on_the_cpp_path(maps):
    run, why = make_run(RunConfig(map="grid", strategy="tpuaf_plus", robots=3), maps["grid"])
    assert isinstance(run, NativeRun) and run.native_policy
    assert "C++ decision path" in why
    assert not run._strategy.is_native  # plans are called back: the run keeps the GIL
    run.run()
    team = run._strategy.team(0)
    assert team == [0, 1, 2]
    assert set(run._strategy.walk(0)) == set(range(maps["grid"].num_vertices))  # one cycle


def test_a_plan_without_a_walk_for_a_robot_is_refused(maps):
    """A planner callback that leaves a robot without a walk is a clear error, not a crash."""
    from tpuaf.policies.tpuaf import new_knowledge

    patrol_map = maps["grid"]
    run = NativeRun(RunConfig(map="grid", strategy="tpuaf_plus", robots=2, duration_s=10),
                    patrol_map, native_policy=False)
    walk = list(range(patrol_map.num_vertices))
    route = (walk, [float(i) for i in walk], float(len(walk)), [0])
    strategy = tpuaf_core.TpuafPlusStrategy(
        new_knowledge(patrol_map, 30.0, 60.0), tpuaf_core.TpuafPlusParams(),
        lambda team: ([route], [0, -1], [(-1, 0.0), (-1, 0.0)]))
    run._engine.set_strategy(strategy)
    with pytest.raises(ValueError, match="no walk for robot 1"):
        run._engine.run()
