"""One run start and one time base (issue: a ROS package that behaves like one).

- the team's epoch: the earliest start heard wins, whatever the order (tpuaf.team.epoch);
- a bag with several run starts (a robot restarted and announced a new run) is analysed from
  the earliest, with a note naming the conflict, and its death is counted;
- every results file is in run time (0 at the start), `start_time_s` is the epoch, on a
  hardware bag stamped with the wall clock (1.7e9 s);
- bags recorded with the version 1 messages (bare `time stamp`, Float64 run start) give the
  same analysis as version 2 ones (std_msgs/Header, tpuaf_ros/RunStart)."""

from __future__ import annotations

import csv
import json
import subprocess

import pytest
from tpuaf.measure.bag import analyze, inspect
from tpuaf.team.epoch import ADOPTED, EARLIER, INVALID, KEPT, RunEpoch

from .test_bag import GRID, T0, TPUAF, plain_bag


def test_the_earliest_start_wins_in_any_order():
    expected = {(10.0, 5.0, 7.0): [ADOPTED, EARLIER, KEPT],
                (5.0, 10.0, 7.0): [ADOPTED, KEPT, KEPT],
                (7.0, 10.0, 5.0): [ADOPTED, KEPT, EARLIER]}
    for order, results in expected.items():
        epoch = RunEpoch()
        assert [epoch.offer(s, f"agent{s:g}") for s in order] == results
        assert epoch.epoch_s == 5.0 and epoch.announcer == "agent5"
    epoch = RunEpoch()
    assert epoch.offer(float("nan")) == INVALID and epoch.offer(-1.0) == INVALID
    assert not epoch.known
    assert epoch.offer(3.0) == ADOPTED and epoch.offer(3.0 + 1e-9) == KEPT  # a re-latched copy
    assert epoch.offer(4.0) == KEPT and epoch.epoch_s == 3.0  # a restarted agent's new start


def test_a_restart_that_announced_a_new_start_does_not_split_the_run(tmp_path):
    # robot 1 goes silent at +20 s (dead for the analysis); a new start at +30 s is what a
    # restarted agent of version 1 announced
    plain_bag(tmp_path, poses="tf", events=True, silent_after={1: T0 + 20.0},
              starts=(0.0, 30.0))
    info = inspect(tmp_path / "run.bag")
    assert [round(s - T0, 3) for s, _ in info.fleet_starts] == [0.0, 30.0]
    assert info.fleet_start_s == pytest.approx(T0)
    result = analyze(tmp_path / "run.bag", GRID)
    assert result.start_s == pytest.approx(T0, abs=0.2)  # the whole run
    assert result.summary["deaths"] == 1 and result.summary["dead_robots"] == [1]
    (note,) = [n for n in result.notes if "different run starts" in n]
    assert "+30.0 s" in note and "/tb3_1/patrol_agent" in note and "the earliest" in note
    # one start (re-latched by every agent): no note
    plain_bag(tmp_path, name="one.bag", poses="tf", events=True)
    assert not [n for n in analyze(tmp_path / "one.bag", GRID).notes if "run starts" in n]


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def test_results_of_a_wall_clock_bag_are_in_run_time(tmp_path):
    spec = plain_bag(tmp_path, poses="tf", events=True, silent_after={1: T0 + 20.0})
    out = tmp_path / "analysis"
    proc = subprocess.run([*TPUAF, "analyze", str(tmp_path / "run.bag"), "--map", "grid",
                           "--out", str(out)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["start_time_s"] == pytest.approx(T0, abs=0.2)  # the epoch, ROS time
    assert "run time" in summary["time_base"]
    duration = summary["duration_s"]
    visits = [float(r["time_s"]) for r in read_csv(out / "visits.csv")]
    rows = [float(r["time_s"]) for r in read_csv(out / "timeseries.csv")]
    assert visits and rows
    assert 0.0 <= min(visits) and max(visits) <= duration + 1e-6
    assert 0.0 < rows[0] <= 1.0 + 1e-6 and rows[-1] <= duration + 1e-6
    # the first visit after the START ones is the bag's first arrival, in run time
    arrivals = sorted(t - summary["start_time_s"] for t, _, _ in spec.visits)
    assert sorted(visits)[2] == pytest.approx(arrivals[2], abs=0.2)
    # idleness.csv (patrolling_sim) was already run time: the same clock as visits.csv
    ps_times = [float(line.split(";")[0]) for line in
                (out / "idleness.csv").read_text().splitlines()[1:]]
    assert max(ps_times) <= duration + 0.1
    # the death is dated in run time, in the summary and on the screen
    (rec,) = summary["recovery"]
    assert 15.0 <= rec["time_s"] <= 30.0
    assert "1,7" not in proc.stdout and "1.7e" not in proc.stdout


def test_version_1_bags_give_the_same_analysis(tmp_path):
    (tmp_path / "v1").mkdir()
    (tmp_path / "v2").mkdir()
    for version in (1, 2):
        plain_bag(tmp_path / f"v{version}", poses="odom", events=True, msg_version=version,
                  silent_after={0: T0 + 25.0})
    v1, v2 = (analyze(tmp_path / f"v{k}" / "run.bag", GRID) for k in (1, 2))
    types = inspect(tmp_path / "v1" / "run.bag").types
    assert types["/fleet/start"] == "std_msgs/msg/Float64"
    assert inspect(tmp_path / "v2" / "run.bag").types["/fleet/start"] == "tpuaf_ros/msg/RunStart"
    assert v1.start_s == v2.start_s and v1.reports == v2.reports > 0
    for key in ("visits", "idleness_avg_s", "worst_idleness_s", "deaths", "uncertainty_mean",
                "start_time_s", "duration_s"):
        assert v1.summary[key] == v2.summary[key], key
