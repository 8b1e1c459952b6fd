"""The native graph runtime (C++ event loop) equals the Python graph runtime to the last digit.

Golden equivalence (issue 14): for the same configuration and seed, `NativeRun` (with the C++
decision path of TPUAF, or Python policies called back from C++) and `BatchRun` give equal
summaries (every value of summary.json), the same visit sequence, the same 1 Hz rows and the
same interference episodes.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import tpuaf_core
from tpuaf.experiments.results import ResultsWriter
from tpuaf.maps import load_map
from tpuaf.runtimes.config import RunConfig
from tpuaf.runtimes.graph import BatchRun
from tpuaf.runtimes.native import NativeRun, make_run

CASES = [
    # (map, strategy, N, duration [s], delay [s], loss)
    ("grid", "tpuaf", 1, 1200, 0.0, 0.0),
    ("grid", "tpuaf", 4, 1200, 1.0, 0.2),
    ("grid", "tpuaf", 12, 900, 0.0, 0.1),
    ("cumberland", "tpuaf", 12, 900, 0.5, 0.1),
    ("cumberland", "tpuaf", 4, 900, 0.0, 0.0),
    ("grid", "gbs", 4, 900, 0.0, 0.3),
    ("cumberland", "gbs", 12, 600, 0.5, 0.1),
    ("grid", "dtag", 12, 600, 0.7, 0.1),
    ("cumberland", "dtag", 4, 900, 0.0, 0.0),
    ("grid", "gbs", 1, 600, 0.0, 0.0),
    ("cumberland", "tpuaf_plus", 12, 900, 0.5, 0.1),
    ("grid", "tpuaf_plus", 1, 600, 0.0, 0.0),
]


@pytest.mark.parametrize(("strategy", "robots", "delay", "loss"),
                         [("cgg", 4, 0.5, 0.2), ("dtap", 6, 0.0, 0.1), ("tpuaf", 5, 1.0, 0.1)])
def test_python_policies_called_back_from_cpp_equal_the_python_runtime(maps, strategy, robots,
                                                                       delay, loss):
    python, sp, native, sn = _pair(
        maps["grid"], native_policy=False, map="grid", strategy=strategy, robots=robots,
        duration_s=600, seed=9, delay_s=delay, loss=loss,
    )
    assert not native.native_policy
    _assert_same(python, sp, native, sn)


@pytest.fixture(scope="module")
def maps(shared_maps):
    return {"grid": load_map("grid"), "cumberland": load_map(shared_maps / "cumberland")}


def _pair(patrol_map, native_policy=True, **kwargs):
    python = BatchRun(RunConfig(**kwargs), patrol_map)
    native = NativeRun(RunConfig(**kwargs), patrol_map, native_policy=native_policy)
    return python, python.run(), native, native.run()


def _assert_same(python, sp, native, sn):
    assert sn == sp  # every summary value, exactly
    assert native.recorder.visits == python.recorder.visits
    assert native.recorder.visit_idleness == pytest.approx(python.recorder.visit_idleness,
                                                           nan_ok=True, rel=0, abs=0)
    assert native.recorder.timeseries == python.recorder.timeseries
    assert native.recorder.interferences == python.recorder.interferences
    assert np.array_equal(native.recorder.uncertainty(), python.recorder.uncertainty())
    assert native.now == python.now


@pytest.mark.parametrize(("map_name", "strategy", "robots", "duration", "delay", "loss"), CASES)
def test_native_engine_equals_python_runtime(maps, map_name, strategy, robots, duration, delay,
                                             loss):
    python, sp, native, sn = _pair(
        maps[map_name], map=map_name, strategy=strategy, robots=robots, duration_s=duration,
        seed=robots + 3, delay_s=delay, loss=loss,
    )
    assert native.native_policy  # every case runs its C++ decision path
    _assert_same(python, sp, native, sn)
    assert sp["visits"] > 50 * robots ** 0.5
    if loss > 0:
        assert sp["messages"]["lost"] > 0
    if robots == 12:
        assert sp["interferences"] > 0  # the spatial-hash interference path is exercised


def test_tpuaf_python_callbacks_equal_its_cpp_path(maps):
    """TPUAF run as a Python policy called back from the C++ loop equals its C++ path."""
    kwargs = dict(map="grid", strategy="tpuaf", robots=6, duration_s=600, seed=11, delay_s=0.5,
                  loss=0.1)
    python, sp, callbacks, sc = _pair(maps["grid"], native_policy=False, **kwargs)
    assert not callbacks.native_policy
    _assert_same(python, sp, callbacks, sc)
    native = NativeRun(RunConfig(**kwargs), maps["grid"])
    assert native.run() == sc


def summary_json_of_both_engines(patrol_map, tmp_path, **kwargs) -> list[dict]:
    """summary.json of the python and the native engine's results folders for one config (the
    wall-clock field dropped)."""
    texts = []
    for name, engine in (("python", BatchRun(RunConfig(**kwargs), patrol_map)),
                         ("native", NativeRun(RunConfig(**kwargs), patrol_map))):
        writer = ResultsWriter(tmp_path / name, engine.effective_config())
        summary = engine.run()
        writer.finish(summary, engine.recorder)
        values = json.loads((tmp_path / name / "summary.json").read_text())
        values.pop("real_duration_s", None)  # wall clock, not a result
        texts.append(values)
        assert (tmp_path / name / "visits.csv").exists()
    return texts


def test_results_folders_have_equal_summary_json(maps, tmp_path):
    texts = summary_json_of_both_engines(maps["grid"], tmp_path, map="grid", strategy="tpuaf",
                                         robots=4, duration_s=300, seed=2)
    assert texts[0] == texts[1]
    assert (tmp_path / "python" / "visits.csv").read_text() == (
        tmp_path / "native" / "visits.csv").read_text()


def test_auto_engine_selection(maps):
    run, why = make_run(RunConfig(map="grid", strategy="tpuaf", robots=2), maps["grid"])
    assert isinstance(run, NativeRun) and "native" in why
    run, why = make_run(RunConfig(map="grid", strategy="dtag", robots=2), maps["grid"])
    assert isinstance(run, NativeRun) and run.native_policy
    # A Python policy called back from the C++ loop is still faster than BatchRun: auto too.
    run, why = make_run(RunConfig(map="grid", strategy="cgg", robots=2), maps["grid"])
    assert isinstance(run, NativeRun) and not run.native_policy and "no C++ decision path" in why
    run, _ = make_run(RunConfig(map="grid", strategy="cgg", robots=2), maps["grid"], "native")
    assert isinstance(run, NativeRun) and not run.native_policy
    run, _ = make_run(RunConfig(map="grid", strategy="tpuaf", robots=2), maps["grid"], "python")
    assert isinstance(run, BatchRun)


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


def _cli(capsys, *argv):
    from tpuaf.cli import main

    code = main(["run", "--map", "grid", "--robots", "3", "--duration", "300", "--seed", "4",
                 *argv])
    out, err = capsys.readouterr()
    table = [line for line in out.splitlines() if line.startswith("  ") and "wall" not in line]
    return code, table, err


def test_cli_engine_option(capsys):
    code_n, table_n, err_n = _cli(capsys, "--engine", "native", "--delay", "1")
    code_p, table_p, err_p = _cli(capsys, "--engine", "python", "--delay", "1")
    assert code_n == code_p == 0
    assert table_n == table_p and len(table_n) >= 10  # the same summary table
    assert "native engine" in err_n and "python engine" in err_p
    # Faults run on the native engine too, with the python engine's results.
    code_f, table_f, err_f = _cli(capsys, "--fail", "0@100", "--stall", "1@50")
    code_p, table_p, _ = _cli(capsys, "--engine", "python", "--fail", "0@100", "--stall", "1@50")
    assert code_f == code_p == 0 and "native engine" in err_f
    assert table_f == table_p and len(table_f) >= 10
    assert any("death of robot 0" in line for line in table_f)
