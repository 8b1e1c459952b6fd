"""Issue 33: the fleet monitor's figures through restarts (outages, not deaths)."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
from tpuaf.experiments.results import ResultsWriter
from tpuaf.measure.monitor import FleetMonitor
from tpuaf.topics import HEARTBEAT, START

from tests.test_metrics import line_map

TPUAF = Path(__file__).resolve().parents[1] / ".venv" / "bin" / "tpuaf"


def restart_run(duration_s: float = 60.0, **kw) -> tuple[FleetMonitor, list[int]]:
    """3 robots: robot 1 silent from 20 s to 35 s (a restart), robot 2 silent from 40 s for
    good (it stands on v2). Returns the monitor and robots_alive at every second."""
    mon = FleetMonitor(line_map(), 3, duration_s, lag_s=1.0, death_timeout_s=5.0, **kw)
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


def test_the_monitor_leaves_a_vertex_under_a_dead_body_out_of_the_reachable_recovery():
    # robot 2 dies standing on v2 (id 12): with the map's robot radius no robot keeping the
    # controller's safety margin (0.08 m) from it can come within the visit radius (0.15 m) of
    # it; a robot of 2 cm radius leaves room (2 x 0.02 + 0.08 < 0.15)
    s = restart_run()[0].summary()
    assert s["vertices_under_bodies"] == [12]
    assert "worst_idleness_after_reachable_s" in s["recovery"][0]
    s = restart_run(body_radius_m=0.02)[0].summary()
    assert "vertices_under_bodies" not in s
    assert "worst_idleness_after_reachable_s" not in s["recovery"][0]


def test_a_restarted_robot_is_no_death(tmp_path):
    mon, alive = restart_run(duration_s=38.0)  # the run ends before robot 2 falls silent
    s = mon.summary()
    assert s["deaths"] == 0 and s["dead_robots"] == [] and "recovery" not in s
    assert s["outages"] == [{"robot": 1, "start_s": 20.0, "end_s": 35.0, "cause": "silent"}]
    assert mon.live()["robots_alive"] == 3
    with ResultsWriter(tmp_path / "run", {"map": "line3"}, plots=False) as writer:
        writer.finish(s, mon.recorder)
    assert open(tmp_path / "run" / "info.csv").read().split(";")[13] == "TIMEOUT"


def health_run(stuck_after_s: float = 20.0):
    """2 robots: robot 0 drives on and reports recoveries, a failed goal and a give-way; robot 1
    stands still from 30 s to 70 s. Returns the monitor, the run time robot 1's spell was first
    reported and the live figures at 60 s."""
    from tpuaf.topics import FAILED, GIVE_WAY, GOAL, STUCK

    mon = FleetMonitor(line_map(), 2, 100.0, lag_s=1.0, stuck_after_s=stuck_after_s)
    mon.on_event(0, START, 0, 0.0)
    mon.on_event(1, START, 2, 0.0)
    events = {1: (GOAL, 1), 5: (STUCK, 1), 6: (STUCK, 1), 8: (GOAL, 2), 9: (STUCK, 2),
              12: (FAILED, 2), 15: (GIVE_WAY, 2)}
    reported, live60 = None, None
    for k in range(103):
        t = float(k)
        for r in range(2):
            mon.on_event(r, HEARTBEAT, -1, t)
        if k in events:
            mon.on_event(0, events[k][0], events[k][1], t, 0)
        mon.on_pose(0, t, 5.0 + 0.5 * (k % 20), 1.0)
        x1 = 0.5 * min(k, 30) + 0.5 * max(k - 70, 0)
        mon.on_pose(1, t, x1, 3.0)
        if reported is None and any("robot 1 made no progress" in n for n in mon.news):
            reported = t
        mon.news.clear()
        if k == 60:
            live60 = mon.live()
    return mon, reported, live60


def test_robot_health_reaches_the_summary_and_the_live_metrics():
    mon, reported, live60 = health_run()
    # stood still from 30 s; reported within 5 s of 30 + 20 s
    assert reported is not None and 50.0 <= reported <= 55.0
    assert live60["no_progress"] == [False, True]
    assert live60["recoveries"] == [3, 0] and live60["stuck_episodes"] == [2, 0]
    assert live60["failed_goals"] == [1, 0] and live60["give_ways"] == [1, 0]
    # its START at 0 s is its only visit; the monitor runs lag_s (1 s) behind the poses
    assert live60["since_last_visit"][1] == 59.0
    s = mon.summary()
    assert (s["stuck_episodes"], s["recoveries"], s["failed_goals"], s["give_ways"]) == (2, 3, 1, 1)
    h0, h1 = s["robot_health"]
    assert (h0["stuck_episodes"], h0["recoveries"], h0["failed_goals"], h0["give_ways"]) == (
        2, 3, 1, 1)
    assert h1["no_progress"] == [{"start_s": 30.0, "end_s": 71.0}] and s["no_progress_spells"] == 1
    assert h1["last_visit_s"] == 0.0 and h1["since_last_visit_s"] == 100.0
    assert h0["no_progress"] == []
    assert mon.live()["no_progress"] == [False, False]


def test_live_health_fits_the_live_metrics_message():
    import io

    from tpuaf.measure.bag_decode import _RAW_EVENTS

    from tpuaf_ros.msg import AgentEvent, LiveMetrics

    mon, _, live60 = health_run()
    for live in (live60, mon.live(), FleetMonitor(line_map(), 2, 10.0).live()):
        msg = LiveMetrics()
        for key, value in live.items():
            setattr(msg, key, value)
        buf = io.BytesIO()
        msg.serialize(buf)
        back = LiveMetrics().deserialize(buf.getvalue())
        assert list(back.recoveries) == list(live["recoveries"])
    # the bag reader reads this version's events from their bytes
    assert ("tpuaf_ros/msg/AgentEvent", AgentEvent._md5sum) in _RAW_EVENTS


# --- complete means complete (item 5) ---------------------------------------------------------


def test_a_full_disk_is_never_a_complete_run(small_disk):
    from tpuaf.experiments.run_files import ResultsError, incomplete
    from tpuaf.measure.metrics import RunRecorder

    rec = RunRecorder(line_map(), 2, ground_truth=False)
    for k in range(30000):  # ~1 MB of visits.csv
        rec.record_visit(k % 2, k % 3, 0.01 * k)
    out = small_disk / "run"
    writer = ResultsWriter(out, {"map": "line3"}, plots=False)
    writer.sync(rec)  # fills the disk: remembered, not raised
    assert writer.write_error and "No space left" in writer.write_error
    with pytest.raises(ResultsError, match="No space left"):
        writer.finish(rec.summary(300.0), rec)
    path = out / "summary.json"
    if path.exists():
        assert json.loads(path.read_text())["complete"] is False
    assert "complete" in incomplete(out) or "no summary.json" in incomplete(out)
    # the readers say so: tpuaf render on the folder names it incomplete
    proc = subprocess.run([str(TPUAF), "render", str(out), "--summary"], capture_output=True,
                          text=True, timeout=120)
    assert "incomplete" in proc.stderr, proc.stderr


def test_incomplete_names_the_reasons(tmp_path):
    from tpuaf.experiments.run_files import incomplete

    (tmp_path / "summary.json").write_text(json.dumps({"complete": True}))
    assert incomplete(tmp_path) is None
    (tmp_path / "summary.json").write_text(json.dumps(
        {"complete": False, "incomplete_files": ["run.bag not closed"]}))
    assert "run.bag not closed" in incomplete(tmp_path)
    (tmp_path / "summary.json").unlink()
    assert "no summary.json" in incomplete(tmp_path)


def test_a_bag_is_closed_only_with_its_index(tmp_path):
    from rosbags.rosbag1 import Writer
    from tpuaf.cli.fleet_supervisor import bag_problem, run_file_problems

    bag = tmp_path / "run.bag"
    from rosbags.typesys import Stores, get_typestore

    with Writer(bag) as w:
        w.add_connection("/x", "std_msgs/msg/Int8", typestore=get_typestore(Stores.ROS1_NOETIC))
    assert bag_problem(bag) is None
    raw = bytearray(bag.read_bytes())
    i = raw.index(b"index_pos=") + len(b"index_pos=")
    raw[i:i + 8] = bytes(8)  # as rosbag leaves a bag it never closed
    bag.write_bytes(bytes(raw))
    assert "not closed" in bag_problem(bag)
    bag.write_bytes(b"")
    assert "empty" in bag_problem(bag)
    (tmp_path / "simulator.json").write_text("")
    problems = run_file_problems(tmp_path, bag, True)
    assert "run.bag is empty" in problems and "visits.csv missing" in problems
    assert any(p.startswith("simulator.json empty") for p in problems)


def test_rviz_marks_a_robot_that_makes_no_progress():
    from tpuaf.measure.markers import PatrolView

    view = PatrolView(line_map(), 2)
    for r in range(2):
        view.on_pose(r, 0.0, 10.0 * r, 0.0)
    view.on_health(1, True)
    stuck = {m.id: m for m in view.markers(1.0) if m.ns == "stuck"}
    assert stuck[1].text == "STUCK" and stuck[1].color[3] == 1.0
    assert stuck[0].color[3] == 0.0  # sent, transparent: replaces an earlier STUCK
    view.on_health(1, False)
    assert [m for m in view.markers(2.0) if m.ns == "stuck"][1].color[3] == 0.0
