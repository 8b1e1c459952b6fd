"""Results folder: files parse back; an interrupted run leaves valid files."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
import yaml
from tpuaf.experiments.results import (
    PS_IDLENESS_HEADER,
    PS_INFO_COLUMNS,
    PS_TIMERESULTS_HEADER,
    TIMESERIES_COLUMNS,
    VISIT_COLUMNS,
    ResultsWriter,
)
from tpuaf.maps import load_map
from tpuaf.measure.metrics import RunRecorder

CONFIG = {"map": "lab", "n_robots": 2, "strategy": "tpuaf", "seed": 3,
          "strategy_params": {"utility": "eq11"}, "duration_s": 1900.0}


def simulate(rec: RunRecorder, writer: ResultsWriter, end: float, stop_at: float | None = None):
    """Two robots alternate between lab vertices 0..4 and 10..14 every 5 s."""
    pm = rec.patrol_map
    t = 0.0
    k = 0
    while t < end:
        t += 5.0
        k += 1
        for robot, base in ((0, 0), (1, 10)):
            v = pm.index_of(base + k % 5)
            rec.record_visit(robot, v, t)
        rec.record_positions(t, pm.positions[[pm.index_of(k % 5), pm.index_of(10 + k % 5)]])
        if k % 10 == 0:
            writer.sync(rec)
        if stop_at is not None and t >= stop_at:
            raise KeyboardInterrupt


def read_csv(path, delimiter=","):
    with open(path, newline="") as f:
        return list(csv.reader(f, delimiter=delimiter))


def test_complete_run_files_parse_back(tmp_path):
    pm = load_map("lab")
    rec = RunRecorder(pm, 2)
    with ResultsWriter(tmp_path / "run", CONFIG) as writer:
        simulate(rec, writer, 1900.0)
        summary = rec.summary(1900.0)
        writer.finish(summary, rec)
    out = tmp_path / "run"
    assert yaml.safe_load((out / "config.yaml").read_text()) == CONFIG
    s = json.loads((out / "summary.json").read_text())
    assert s["complete"] is True
    assert s["idleness_avg_s"] == pytest.approx(summary["idleness_avg_s"])
    assert s["visits"] == len(rec.visits) == 760

    visits = read_csv(out / "visits.csv")
    assert visits[0] == VISIT_COLUMNS
    assert len(visits) - 1 == len(rec.visits)
    assert float(visits[1][0]) == 5.0 and visits[1][4] == ""  # first visit: no idleness
    idl = [float(r[4]) for r in visits[1:] if r[4]]
    assert np.mean(idl) == pytest.approx(summary["idleness_avg_s"])

    ts = read_csv(out / "timeseries.csv")
    assert ts[0] == TIMESERIES_COLUMNS
    assert len(ts) - 1 == 1900
    assert float(ts[-1][0]) == 1900.0

    ps_idl = read_csv(out / "idleness.csv", ";")
    assert ps_idl[0] == PS_IDLENESS_HEADER
    assert len(ps_idl) - 1 == summary["idleness_samples"]
    assert all(len(r) == 5 for r in ps_idl)

    tr = read_csv(out / "timeresults.csv", ";")
    assert tr[0] == PS_TIMERESULTS_HEADER
    assert [float(r[0]) for r in tr[1:]] == [900.0, 1800.0]
    assert float(tr[2][2]) == pytest.approx(summary["idleness_avg_s"], abs=0.06)

    info = read_csv(out / "info.csv", ";")
    assert len(info) == 1 and len(info[0]) == len(PS_INFO_COLUMNS) == 22
    row = dict(zip(PS_INFO_COLUMNS, info[0], strict=True))
    assert row["map"] == "lab" and row["teamsize"] == "2" and row["algorithm"] == "tpuaf"
    assert row["termination"] == "TIMEOUT"
    assert float(row["duration_s"]) == 1900.0
    assert int(row["complete_patrol_cycles"]) == summary["complete_cycles"]


def test_interrupted_run_leaves_valid_files(tmp_path):
    pm = load_map("lab")
    rec = RunRecorder(pm, 2)
    out = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        with ResultsWriter(out, CONFIG) as writer:
            simulate(rec, writer, 1900.0, stop_at=333.0)
    s = json.loads((out / "summary.json").read_text())
    assert s["complete"] is False
    assert s["duration_s"] == pytest.approx(335.0)
    visits = read_csv(out / "visits.csv")
    assert len(visits) - 1 == len(rec.visits) == 134
    ts = read_csv(out / "timeseries.csv")
    assert [float(r[0]) for r in ts[1:]] == [float(k) for k in range(1, 336)]
    info = read_csv(out / "info.csv", ";")
    assert info[0][PS_INFO_COLUMNS.index("termination")] == "ABORT"
    assert read_csv(out / "timeresults.csv", ";") == [PS_TIMERESULTS_HEADER]


def test_streams_are_valid_before_finish(tmp_path):
    """What a killed process leaves: the streamed CSVs up to the last sync."""
    pm = load_map("lab")
    rec = RunRecorder(pm, 2)
    writer = ResultsWriter(tmp_path / "run", CONFIG)
    simulate(rec, writer, 100.0)  # syncs at 50 s and 100 s
    visits = read_csv(tmp_path / "run" / "visits.csv")
    assert len(visits) - 1 == 40
    ts = read_csv(tmp_path / "run" / "timeseries.csv")
    assert len(ts) - 1 == 100 and all(len(r) == len(TIMESERIES_COLUMNS) for r in ts)
    writer.close()
