"""Clean ends (issue 33 item 3), on the wall clock as on hardware: the monitor exits by itself
after the run (exit code 0, a complete summary.json), and agents stopped by Ctrl-C (on their
robot.launch, while the simulator still publishes tf) print no traceback. About 50 s of wall
time."""

from __future__ import annotations

import json
import subprocess

import pytest

from .conftest import ros_master
from .hardware import start_robot, start_world, wait_started

pytestmark = [pytest.mark.ros, pytest.mark.slow]

ROBOTS = 2


def test_the_monitor_exits_after_the_run_and_agents_stop_quietly(tmp_path):
    out = tmp_path / "live"
    with ros_master(tmp_path / "ros") as ros:
        start_world(ros, "grid", ROBOTS, speed=1.0)
        monitor = ros.start(["rosrun", "tpuaf_ros", "monitor", "_map:=grid",
                             f"_robots:={ROBOTS}", "_duration:=15", "_robot_prefix:=tb3_",
                             "_pose_source:=tf", "_announce_start:=false", f"_out:={out}"],
                            name="monitor")
        robots = [start_robot(ros, "grid", ROBOTS, i, speed=1.0) for i in range(ROBOTS)]
        wait_started(ros, ROBOTS)
        try:
            code = monitor.wait(timeout=90.0)
        except subprocess.TimeoutExpired:
            code = None
        codes = [ros.stop(robot) for robot in robots]  # Ctrl-C, tf still flowing
        logs = [ros.output(f"tb3_{i}") for i in range(ROBOTS)]
        monitor_log = ros.output("monitor")
    assert code == 0, monitor_log[-3000:]
    assert "run finished" in monitor_log and "exiting in" in monitor_log, monitor_log[-3000:]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["complete"] is True and summary["duration_s"] == pytest.approx(15.0)
    assert len(summary["robot_health"]) == ROBOTS and summary["deaths"] == 0, summary
    for i, log in enumerate(logs):
        assert "Traceback" not in log and "closed topic" not in log, (i, log[-4000:])
    assert all(c is not None for c in codes), codes
