"""Lock-step fleets with the same seed (issue 33 item 7): two `tpuaf fleet` runs (grid, 3
robots, 60 s, lock-step at full speed, the team barrier) with the same seed give the same
figures and byte-identical visit sequences. Every agent begins the run at the announced start
itself (their START events are stamped with the monitor's start_time_s, in both runs), the live
monitor and `tpuaf analyze` of the bag agree exactly, and no team message was given up on by
the simulator's barrier. About 1.5 min of wall time."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
from tpuaf.measure.bag_decode import RawEvent

from .test_fleet import run_fleet

pytestmark = [pytest.mark.ros, pytest.mark.slow]

REPO = Path(__file__).resolve().parents[2]
TPUAF = str(REPO / ".venv" / "bin" / "tpuaf")
SAME = ("visits", "idleness_avg_s", "idleness_max_s", "start_time_s", "deaths")


def start_stamps(bag: Path) -> list[float]:
    from rosbags.rosbag1 import Reader

    with Reader(bag) as reader:
        conns = [c for c in reader.connections if c.topic == "/fleet/agent_events"]
        events = [RawEvent(raw) for _, _, raw in reader.messages(connections=conns)]
    return sorted(e.t for e in events if e.event == 0)  # START


def one_run(out: Path) -> dict:
    proc = run_fleet(out, robots=3, duration=60.0, seed=4, extra=("--rtf", "0"))  # full speed
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    live = json.loads((out / "summary.json").read_text())
    analysis = subprocess.run([TPUAF, "analyze", str(out / "run.bag"), "--out",
                               str(out / "analysis")], capture_output=True, text=True,
                              timeout=300)
    assert analysis.returncode == 0, analysis.stdout[-3000:]  # 1: a metric DIFFERS
    bag = json.loads((out / "analysis" / "summary.json").read_text())
    for key in SAME:  # the same bag, the same figures
        assert bag[key] == pytest.approx(live[key], abs=1e-6), (key, bag[key], live[key])
    starts = start_stamps(out / "run.bag")
    assert len(starts) == 3 and all(abs(s - live["start_time_s"]) < 0.05 for s in starts), (
        starts, live["start_time_s"])
    return live


def test_two_lockstep_runs_with_one_seed(tmp_path):
    a, b = one_run(tmp_path / "a"), one_run(tmp_path / "b")
    assert a["deaths"] == b["deaths"] == 0
    assert a["visits"] > 10
    for key in (*SAME, "interferences", "unvisited_vertices"):
        assert a.get(key) == b.get(key), (key, a.get(key), b.get(key))
    visits_a = (tmp_path / "a" / "visits.csv").read_bytes()
    assert visits_a == (tmp_path / "b" / "visits.csv").read_bytes()
    for run in ("a", "b"):  # the barrier waited for every team message
        sim = json.loads((tmp_path / run / "simulator.json").read_text())
        assert not [e for e in sim["events"] if e["event"] == "team_lost"], sim["events"]
