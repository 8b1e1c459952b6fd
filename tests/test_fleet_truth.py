"""Issue 33: the fleet monitor's figures through restarts (outages, not deaths)."""

from __future__ import annotations

from tpuaf.experiments.results import ResultsWriter
from tpuaf.measure.monitor import FleetMonitor
from tpuaf.topics import HEARTBEAT, START

from tests.test_metrics import line_map


def restart_run(duration_s: float = 60.0) -> tuple[FleetMonitor, list[int]]:
    """3 robots: robot 1 silent from 20 s to 35 s (a restart), robot 2 silent from 40 s for
    good. Returns the monitor and robots_alive at every second."""
    mon = FleetMonitor(line_map(), 3, duration_s, lag_s=1.0, death_timeout_s=5.0)
    for r in range(3):
        mon.on_event(r, START, r, 0.0)
    alive = []
    for k in range(int(duration_s) + 3):
        t = float(k)
        mon.on_event(0, HEARTBEAT, -1, t)
        if t <= 20 or t >= 35:
            mon.on_event(1, HEARTBEAT, -1, t)
        if t <= 40:
            mon.on_event(2, HEARTBEAT, -1, t)
        for r in range(3):
            mon.on_pose(r, t, 10.0 * r, 0.0)
        alive.append(mon.live()["robots_alive"])
    return mon, alive


def test_a_robot_heard_again_is_alive_and_only_the_silent_one_dies(tmp_path):
    mon, alive = restart_run()
    assert mon.finished
    # silent 20 s -> out at the first pose group > 25 s; back at 35 s (processed at 36 s)
    assert alive[20] == 3 and alive[30] == 2 and alive[40] == 3 and alive[-1] == 2
    s = mon.summary()
    assert s["outages"] == [
        {"robot": 1, "start_s": 20.0, "end_s": 35.0, "cause": "silent"},
        {"robot": 2, "start_s": 40.0, "end_s": None, "cause": "silent"}]
    assert s["deaths"] == 1 and s["dead_robots"] == [2]
    (rec,) = s["recovery"]
    assert rec["robot"] == 2 and rec["time_s"] == 40.0 and rec["survivors"] == 2
    assert [r for _, r in mon.deaths] == [2]
    # info.csv termination follows the deaths
    with ResultsWriter(tmp_path / "run", {"map": "line3"}, plots=False) as writer:
        writer.finish(s, mon.recorder)
    assert open(tmp_path / "run" / "info.csv").read().split(";")[13] == "FAIL"


def test_a_restarted_robot_is_no_death(tmp_path):
    mon, alive = restart_run(duration_s=38.0)  # the run ends before robot 2 falls silent
    s = mon.summary()
    assert s["deaths"] == 0 and s["dead_robots"] == [] and "recovery" not in s
    assert s["outages"] == [{"robot": 1, "start_s": 20.0, "end_s": 35.0, "cause": "silent"}]
    assert mon.live()["robots_alive"] == 3
    with ResultsWriter(tmp_path / "run", {"map": "line3"}, plots=False) as writer:
        writer.finish(s, mon.recorder)
    assert open(tmp_path / "run" / "info.csv").read().split(";")[13] == "TIMEOUT"
