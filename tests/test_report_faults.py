"""Fault scenarios in sweeps and reports (issue 12 item 3, issue 13 item 3).

Scenarios: one factor at a time, names, deaths as counts or fractions of the team, the folder
layout; a tiny real sweep with loss, delay and a death; the report of a hand-made table: the
ratio to the best-known tour, where TPUAF loses, the fault tables, the degradation curves and
the physics section."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
from tpuaf.cli import main
from tpuaf.experiments.report import load, write_report
from tpuaf.experiments.sweep.folders import key_of
from tpuaf.experiments.sweep.grid import (
    NOMINAL,
    RunKey,
    Scenario,
    SweepError,
    make_scenarios,
    make_spec,
)
from tpuaf.experiments.sweep.tables import RESULT_COLUMNS


def test_scenarios_are_one_factor_at_a_time():
    sc = make_scenarios(loss=[0.0, 0.3], delay_s=[5], deaths=["1/4", "2", "0"])
    assert [s.name for s in sc] == [NOMINAL, "loss0.3", "delay5", "deaths1of4", "deaths2"]
    assert all(sum(bool(x) for x in (s.loss, s.delay_s, s.deaths != "0")) <= 1 for s in sc)
    assert make_scenarios(runtime="physics")[0].name == "physics"
    assert make_scenarios(loss=[0.5], runtime="physics")[1].name == "physics-loss0.5"
    assert make_scenarios(deaths=["1"], death_time_s=600)[1].name == "deaths1@600"
    assert [s.name for s in make_scenarios(deaths=["2/8", "1/4", "4/8", "8/8"])] == [
        NOMINAL, "deaths1of4", "deaths1of2", "deaths1of1"]


@pytest.mark.parametrize("deaths, n, count, applies", [
    ("1/4", 1, 0, False), ("1/4", 4, 1, True), ("1/4", 8, 2, True), ("1/4", 12, 3, True),
    ("3", 4, 3, True), ("4", 4, 4, False), ("0", 4, 0, True)])
def test_death_counts(deaths, n, count, applies):
    s = Scenario(deaths=deaths)
    assert s.death_count(n) == count
    assert s.applies(n) == applies


def test_dying_robots_are_spread_over_the_team_at_half_the_run():
    assert Scenario(deaths="1/4").failures(8, 3600.0) == [(0, 1800.0), (4, 1800.0)]
    assert Scenario(deaths="3", death_time_s=100).failures(12, 3600.0) == [
        (0, 100.0), (4, 100.0), (8, 100.0)]


@pytest.mark.parametrize("kwargs, message", [
    ({"loss": [1.5]}, "probability"), ({"delay_s": [-1]}, "delay"),
    ({"deaths": ["x"]}, "expected a number of robots"), ({"deaths": ["3/2"]}, "0 <= A <= B"),
    ({"runtime": "stage"}, "unknown runtime")])
def test_bad_scenarios_are_refused(kwargs, message):
    with pytest.raises(SweepError, match=message):
        make_scenarios(**kwargs)


def test_death_scenarios_need_a_survivor_and_time_in_the_run():
    with pytest.raises(SweepError, match="keeps a survivor"):
        make_spec(["grid"], ["tpuaf"], [1], 1, 600.0, scenarios=make_scenarios(deaths=["1"]))
    with pytest.raises(SweepError, match="not before the end"):
        make_spec(["grid"], ["tpuaf"], [4], 1, 600.0,
                  scenarios=make_scenarios(deaths=["1"], death_time_s=600))
    spec = make_spec(["grid"], ["tpuaf"], [1, 4], 2, 600.0,
                     scenarios=make_scenarios(deaths=["1/4"]))
    assert {(k.robots, k.scenario) for k in spec.keys()} == {
        (1, NOMINAL), (4, NOMINAL), (4, "deaths1of4")}  # nobody dies in a team of one
    task = spec.task(RunKey("grid", "tpuaf", 4, 0, "deaths1of4"))
    assert task["failures"] == [[0, 300.0]] and task["deaths"] == 1


def test_scenario_folders_round_trip(tmp_path):
    for key in (RunKey("grid", "tpuaf", 4, 2), RunKey("grid", "tpuaf", 4, 2, "loss0.3"),
                RunKey("1r5", "cgg", 12, 0, "deaths1of4")):
        folder = key.folder(tmp_path)
        assert key_of(folder) == key
    assert RunKey("grid", "gbs", 8, 1).folder(tmp_path) == tmp_path / "runs/grid/gbs/N8/seed1"


@pytest.mark.slow
def test_a_tiny_fault_sweep_runs_every_scenario(tmp_path, capsys):
    out = tmp_path / "faults"
    args = ["compare", "--maps", "grid", "--strategies", "tpuaf", "cgg", "--robots", "4",
            "--duration", "240", "--seeds", "1", "--loss", "0.5", "--delay", "5",
            "--deaths", "1", "--workers", "1", "--quiet", "--out", str(out)]
    assert main(args) == 0, capsys.readouterr().err
    with open(out / "results.csv", newline="") as f:
        rows = {(r["strategy"], r["scenario"]): r for r in csv.DictReader(f)}
    assert set(rows) == {(s, sc) for s in ("tpuaf", "cgg")
                         for sc in (NOMINAL, "loss0.5", "delay5", "deaths1")}
    assert all(r["status"] == "ok" for r in rows.values())
    assert rows[("tpuaf", "loss0.5")]["loss"] == "0.5"
    assert rows[("tpuaf", "deaths1")]["deaths"] == "1"
    summary = json.loads((RunKey("grid", "tpuaf", 4, 0, "deaths1").folder(out)
                          / "summary.json").read_text())
    assert summary["deaths"] == 1
    lost = json.loads((RunKey("grid", "tpuaf", 4, 0, "loss0.5").folder(out)
                       / "summary.json").read_text())["messages"]
    assert lost["lost"] > 0
    history = json.loads((out / "sweep.json").read_text())["history"]
    assert len(history) == 1 and history[0]["ran"] == 8
    assert main(args) == 0  # resumed: nothing to do, no new history entry
    assert len(json.loads((out / "sweep.json").read_text())["history"]) == 1
    text = write_report(out).read_text()
    assert "### 5 s message delay (`delay5`)" in text and "## Fault scenarios" in text
    assert "## Degradation curves" not in text  # one level per factor is no curve


# ---------------------------------------------------------------------------- hand-made tables


def _row(m, s, n, seed, scenario=NOMINAL, runtime="graph", loss=0.0, delay=0.0, deaths=0,
         imax=100.0, x=1.0, ins=20.0, duration=3600):
    return {"map": m, "strategy": s, "robots": n, "seed": seed, "duration_s": duration,
            "scenario": scenario, "runtime": runtime, "loss": loss, "delay_s": delay,
            "deaths": deaths, "status": "ok", "idleness_avg_s": ins, "idleness_max_s": imax,
            "idleness_ins_mean_s": ins, "uncertainty_mean": x, "idleness_std_s": 1.0,
            "interference_rate_per_min": 0.1, "wall_time_s": 2.0}


def _write(root: Path, rows: list[dict]) -> None:
    root.mkdir(parents=True)
    with open(root / "results.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=RESULT_COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow(r)


@pytest.fixture
def table(tmp_path) -> Path:
    """grid N = 4, 8: TPUAF beaten by MSP on I_max at N = 8; loss and death curves."""
    rows = []
    for seed in (0, 1):
        j = 1 + 0.01 * seed
        for n, t_max, msp_max in ((4, 80.0, 90.0), (8, 40.0, 20.0)):
            rows.append(_row("grid", "tpuaf", n, seed, imax=t_max * j, x=0.5 * j))
            rows.append(_row("grid", "msp", n, seed, imax=msp_max * j, x=0.6 * j))
        for lv in (0.3, 0.6, 0.9):
            rows.append(_row("grid", "tpuaf", 8, seed, f"loss{lv:g}", loss=lv,
                             imax=40 * (1 + lv) * j, x=0.5 * (1 + lv)))
            rows.append(_row("grid", "msp", 8, seed, f"loss{lv:g}", loss=lv, imax=20 * j))
        for k in (1, 2):
            rows.append(_row("grid", "tpuaf", 8, seed, f"deaths{k}", deaths=k, imax=40 + 10 * k))
            rows.append(_row("grid", "msp", 8, seed, f"deaths{k}", deaths=k, imax=300.0 * j))
        rows.append(_row("grid", "msp", 8, seed, "deaths1of4", deaths=2, imax=300.0 * j))
        rows.append(_row("grid", "tpuaf", 8, seed, "deaths1of4", deaths=2, imax=60.0 * j))
        for n in (1, 2):
            rows.append(_row("lab", "tpuaf", n, seed, "physics", runtime="physics",
                             ins=100.0 / n * j, x=2.0 / n, duration=900))
    root = tmp_path / "table"
    _write(root, rows)
    bounds = tmp_path / "bounds.csv"
    bounds.write_text("map,N,best_known_worst_idleness_s\ngrid,4,37.05\ngrid,8,18.52\n")
    return root


def test_report_tells_where_tpuaf_loses_and_the_ratio_to_the_best_tour(table, tmp_path):
    text = write_report(table, bounds=tmp_path / "bounds.csv", paper=None).read_text()
    assert "- I_max: TPUAF is beaten in 1 of 2 (map, N ≥ 2) cases; the best there: grid N=8 " \
           "(MSP 20.10 vs 40.20, 0.50×)" in text
    assert "| grid | 8 | 40.20 → MSP 0.50 |" in text
    assert "| best-known tour [s] | 37.05 | 18.52 |" in text
    assert "| TPUAF | 2.17 | 2.17 |" in text   # 80.4 / 37.05, 40.2 / 18.52
    assert "| MSP | 2.44 | **1.09** |" in text
    assert "lab: not in bounds.csv, so no ratio to a best-known tour." in text


def test_report_fault_tables_curves_and_physics(table, tmp_path):
    text = write_report(table, bounds=tmp_path / "bounds.csv", paper=None).read_text()
    assert "### a quarter of the team dies at half the run (`deaths1of4`)" in text
    # fault tables: the ratio to the strategy's own fault-free mean
    assert "| TPUAF | **60.30** (1.50×) |" in text
    assert "| MSP | 301.5 (15.00×) |" in text
    assert "## Degradation curves" in text and "### grid, N = 8" in text
    assert (table / "figures" / "degradation_grid_N8.png").read_bytes()[:4] == b"\x89PNG"
    # deaths 2 pools the runs of deaths2 and deaths1of4 (2 of 8 robots both): 60 and 60.3 s
    assert "| TPUAF | 40.20 | 52.26 | 64.32 | 76.38 | 50.00 | 60.15 |" in text
    assert "Every curve is roughly monotone in I_max." in text
    assert "## Physics runtime (`physics`" in text
    assert "TPUAF's I_ins and X fall as N grows in the physics runs (as TPUAF's in the paper's " \
           "Table 4): **reproduced**" in text
    data = load(table, paper=None)
    assert data.scenarios()[0] == NOMINAL
    assert len(data.subset("physics").rows) == 4
