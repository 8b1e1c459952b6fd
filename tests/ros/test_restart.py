"""A restarted robot does not split the run (wall clock, as on hardware).

Three Burgers on grid, one `robot.launch` each, the simulator in wall-clock mode and a plain
`rosbag record`. The agent that announced the run start is stopped (Ctrl-C on its launch) for
longer than the death timeout, then started again. Every agent, the restarted one included,
keeps one epoch (the restarted agent adopts it from its teammates' latched /fleet/start instead
of announcing a new run), and `tpuaf analyze` of the bag and the live monitor cover the whole
run and count the stop as an outage ended by the restart, not a death. About 75 s of wall time."""

from __future__ import annotations

import json
import re
import subprocess
import time

import pytest

from .conftest import REPO, ros_master
from .hardware import start_robot, start_world, wait_started

pytestmark = [pytest.mark.ros, pytest.mark.slow]

ROBOTS = 3
TPUAF = str(REPO / ".venv" / "bin" / "tpuaf")
EPOCH = re.compile(r"run start (\d+\.\d+) s")


def epochs(log: str) -> set[str]:
    return set(EPOCH.findall(log))


def wait_for(predicate, timeout: float, what: str):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value is not None and value is not False and value != set():
            return value
        time.sleep(0.5)
    raise AssertionError(f"timed out after {timeout:g} s waiting for {what}")


def test_a_restarted_announcer_adopts_the_running_epoch(tmp_path):
    with ros_master(tmp_path / "ros") as ros:
        start_world(ros, "grid", ROBOTS)
        ros.start(["rosbag", "record", "-O", str(ros.home / "run.bag"), "/tf", "/tf_static",
                   "/team/visits", "/team/intentions", "/fleet/agent_events", "/fleet/start"],
                  name="rosbag")
        # the live monitor, as on hardware: follows the agents' start, positions from tf
        monitor = ros.start(["rosrun", "tpuaf_ros", "monitor", "_map:=grid",
                             f"_robots:={ROBOTS}", "_duration:=600", "_robot_prefix:=tb3_",
                             "_pose_source:=tf", "_announce_start:=false",
                             f"_out:={tmp_path / 'live'}"], name="monitor")
        robots = [start_robot(ros, "grid", ROBOTS, i) for i in range(ROBOTS)]
        wait_started(ros, ROBOTS)
        def who_announced():
            return next((i for i in range(ROBOTS)
                         if "announced the run start" in ros.output(f"tb3_{i}")), None)

        announcer = wait_for(who_announced, 30.0, "the agent that announced the start")
        first = {i: epochs(ros.output(f"tb3_{i}")) for i in range(ROBOTS)}
        time.sleep(10.0)
        stopping_at = time.time()
        ros.stop(robots[announcer])  # Ctrl-C on its robot.launch
        stopped_at = time.time()
        time.sleep(12.0)  # > the analysis' 5 s death timeout
        ros.start(["roslaunch", "tpuaf_ros", "robot.launch", "map:=grid", f"robots:={ROBOTS}",
                   f"index:={announcer}", "prefix:=tb3_", "scan_topic:=scan",
                   "max_linear_speed:=0.22", "output:=screen"], name="restarted")
        wait_for(lambda: epochs(ros.output("restarted")), 60.0, "the restarted agent's epoch")
        time.sleep(15.0)
        logs = {i: ros.output(f"tb3_{i}") for i in range(ROBOTS)}
        restarted = ros.output("restarted")
        ros.stop(monitor)  # first: the agents' own stops are no outage
        ros.stop_all()
        ended_at = time.time()
    team_epochs = set().union(*first.values())
    assert len(team_epochs) == 1, first
    assert epochs(restarted) == team_epochs, restarted[-3000:]
    assert "announced the run start" not in restarted, restarted[-3000:]
    for log in (*logs.values(), restarted):  # Ctrl-C on a robot.launch: no traceback
        assert "Traceback" not in log and "closed topic" not in log, log[-4000:]
    for i, log in logs.items():
        assert epochs(log) == team_epochs, (i, log[-3000:])
    # The bag: one start (re-latched copies), the whole run, the stop counted as a death.
    out = tmp_path / "analysis"
    proc = subprocess.run([TPUAF, "analyze", str(tmp_path / "ros" / "run.bag"), "--map", "grid",
                           "--robots", str(ROBOTS), "--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    analysis = summary["analysis"]
    assert not [n for n in analysis["notes"] if "run starts" in n], analysis["notes"]
    epoch = float(team_epochs.pop())
    assert epoch < stopped_at - 9.0
    assert summary["start_time_s"] == pytest.approx(epoch, abs=1.0)
    # from the run start (not the restart) to the bag's end
    assert summary["duration_s"] > ended_at - epoch - 10.0, (summary["duration_s"], analysis)
    # the stop is an outage of the announcer, ended by its restart: no death (issue 33)
    stop_s = (stopping_at - epoch - 2.0, stopped_at - epoch + 1.0)  # [s] run time
    for what, s in (("analysis", summary),
                    ("live monitor", json.loads((tmp_path / "live" / "summary.json").read_text()))):
        assert s["deaths"] == 0 and s["dead_robots"] == [] and "recovery" not in s, (what, s)
        gaps = [o for o in s["outages"] if o["robot"] == announcer]
        assert len(gaps) == 1 and gaps[0]["end_s"] is not None, (what, s["outages"])
        assert stop_s[0] < gaps[0]["start_s"] < stop_s[1], (what, gaps, stop_s)
        assert gaps[0]["end_s"] > gaps[0]["start_s"] + 10.0, (what, gaps)
    info = (tmp_path / "live" / "info.csv").read_text().split(";")
    assert info[13] == "ABORT", info  # stopped by Ctrl-C before its end, nobody dead
