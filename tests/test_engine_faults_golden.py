"""Runs with faults: the native engine (C++ event loop) equals the Python graph runtime.

Deaths (`--fail`, `--fail-random`), stalls (`--stall`), the heartbeats and the teammate
liveness checks run in the C++ loop with the same event order and random draws as `BatchRun`:
the same summary (faults, liveness, recovery included), visits, 1 Hz rows, interference
episodes and liveness losses, for strategies with a C++ decision path (tpuaf, gbs, dtag,
tpuaf_plus; tpuaf_plus also in tests/test_tpuaf_plus_native.py) and for Python policies called
back from C++ (cgg).
"""

from __future__ import annotations

import numpy as np
import pytest
from tpuaf.maps import load_map
from tpuaf.runtimes.config import RunConfig
from tpuaf.runtimes.graph import BatchRun
from tpuaf.runtimes.native import NativeRun, make_run, unsupported_options

from .test_engine_golden import summary_json_of_both_engines

DEATH = dict(fail=[(1, 200.0)])
DEATHS_AT_ONCE = dict(fail=[(0, 150.0), (2, 150.0), (3, 150.0)])
DEATHS_APART = dict(fail=[(3, 100.0), (1, 260.5)])
RANDOM = dict(fail_random=2)
STALL = dict(stall=[(2, 130.0)])
STALL_AND_DEATH = dict(stall=[(0, 90.0)], fail=[(3, 240.0)])
LOSSY = dict(fail=[(1, 200.0)], loss=0.3, delay_s=5.0)

CASES = [
    # (strategy, robots, faults and bus)
    ("tpuaf", 4, DEATH),
    ("tpuaf", 6, DEATHS_AT_ONCE),
    ("tpuaf", 5, RANDOM),
    ("tpuaf", 4, STALL),
    ("tpuaf", 5, LOSSY),
    ("gbs", 5, DEATHS_APART),
    ("gbs", 6, RANDOM),
    ("gbs", 4, STALL_AND_DEATH),
    ("gbs", 5, LOSSY),
    ("dtag", 6, DEATHS_AT_ONCE),
    ("dtag", 4, STALL),
    ("dtag", 5, LOSSY),
    ("tpuaf_plus", 4, DEATH),
    ("tpuaf_plus", 6, DEATHS_AT_ONCE),
    ("tpuaf_plus", 4, STALL_AND_DEATH),
    ("tpuaf_plus", 5, LOSSY),
    ("cgg", 5, RANDOM),
    ("cgg", 4, STALL_AND_DEATH),
    ("cgg", 5, LOSSY),
]


@pytest.fixture(scope="module")
def grid():
    return load_map("grid")


def _pair(patrol_map, **kwargs):
    python = BatchRun(RunConfig(**kwargs), patrol_map)
    native = NativeRun(RunConfig(**kwargs), patrol_map)
    return python, python.run(), native, native.run()


def _assert_same(python, sp, native, sn):
    assert sn == sp  # every summary value, exactly (faults, liveness, recovery included)
    assert native.recorder.visits == python.recorder.visits
    assert native.recorder.timeseries == python.recorder.timeseries
    assert native.recorder.interferences == python.recorder.interferences
    assert np.array_equal(native.recorder.uncertainty(), python.recorder.uncertainty())
    assert native.losses == python.losses
    assert native.recorder.announcements == python.recorder.announcements
    assert native.effective_config()["faults"] == python.effective_config()["faults"]
    assert native.now == python.now


@pytest.mark.parametrize(("strategy", "robots", "extra"), CASES)
def test_native_engine_with_faults_equals_python_runtime(grid, strategy, robots, extra):
    python, sp, native, sn = _pair(grid, map="grid", strategy=strategy, robots=robots,
                                   duration_s=600, seed=robots + 7, **extra)
    assert native.native_policy == (strategy in ("tpuaf", "gbs", "dtag", "tpuaf_plus"))
    _assert_same(python, sp, native, sn)
    # The faults did happen, and the survivors noticed every death.
    deaths = [f for f in sp["faults"] if f["kind"] == "death"]
    assert sp["deaths"] == len(deaths) == len(extra.get("fail", [])) + extra.get("fail_random", 0)
    for death in sp["liveness"]["deaths"]:
        assert death["noticed_by"] > 0
    if deaths:
        assert len(sp["recovery"]) == len(deaths)
    if "stall" in extra:
        stalled = [r for r, _ in extra["stall"]]
        assert sp["stalled_robots"] == stalled
        # the stalled robot's navigator gave up on a goal at least once (the GIVE_UP path)
        assert sum(python.robots[r].failures for r in stalled) > 0
    if extra.get("loss") and sp["messages"]["sent"]:  # cgg sends nothing: heartbeats only
        assert sp["messages"]["lost"] > 0


@pytest.mark.parametrize("strategy", ["tpuaf", "tpuaf_plus"])
def test_false_losses_and_teammates_back_are_the_same(grid, strategy):
    """A short timeout under heavy loss: live teammates are taken for lost and come back."""
    python, sp, native, sn = _pair(grid, map="grid", strategy=strategy, robots=5, duration_s=400,
                                   seed=3, loss=0.6, teammate_timeout_s=3.0,
                                   fail=[(2, 120.0)], stall=[(4, 60.0)])
    _assert_same(python, sp, native, sn)
    assert sp["liveness"]["false_losses"] > 10
    assert sp["liveness"]["teammate_timeout_s"] == 3.0


def test_every_robot_dead(grid):
    """The field grows uncovered once nobody is left; a death at t = 0 too."""
    python, sp, native, sn = _pair(grid, map="grid", strategy="tpuaf", robots=3, duration_s=300,
                                   seed=1, fail=[(0, 0.0), (1, 100.0), (2, 100.0)])
    _assert_same(python, sp, native, sn)
    assert sp["dead_robots"] == [0, 1, 2]
    assert not [v for v in sp["visits_per_vertex"].values() if v > 50]


def test_cumberland_twelve_robots_three_deaths(shared_maps):
    cumberland = load_map(shared_maps / "cumberland")
    for strategy in ("tpuaf", "tpuaf_plus"):
        python, sp, native, sn = _pair(cumberland, map="cumberland", strategy=strategy,
                                       robots=12, duration_s=900, seed=1,
                                       fail=[(0, 450.0), (5, 450.0), (9, 450.0)])
        _assert_same(python, sp, native, sn)
        assert sp["interferences"] > 0


def test_results_folders_with_faults_are_equal(grid, tmp_path):
    texts = summary_json_of_both_engines(grid, tmp_path, map="grid", strategy="tpuaf", robots=4,
                                         duration_s=300, seed=2, fail=[(1, 120.0)],
                                         stall=[(3, 60.0)])
    assert texts[0] == texts[1]
    assert texts[0]["recovery"] and texts[0]["liveness"]["deaths"]
    for name in ("visits.csv", "config.yaml"):
        if (tmp_path / "python" / name).exists():
            python_text = (tmp_path / "python" / name).read_text()
            native_text = (tmp_path / "native" / name).read_text()
            if name == "config.yaml":  # the native run names its engine
                native_text = "\n".join(line for line in native_text.splitlines()
                                        if not line.startswith("engine:")) + "\n"
            assert python_text == native_text


def test_auto_engine_runs_faults_natively(grid):
    config = RunConfig(map="grid", strategy="tpuaf", robots=3, fail=[(0, 10.0)],
                       stall=[(1, 5.0)], fail_random=1)
    assert unsupported_options(config) == []
    run, why = make_run(config, grid)
    assert isinstance(run, NativeRun) and run.native_policy and "native" in why
    run, _ = make_run(RunConfig(map="grid", strategy="cgg", robots=3, fail=[(0, 10.0)]), grid,
                      "native")
    assert isinstance(run, NativeRun) and not run.native_policy


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
