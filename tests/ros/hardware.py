"""Helpers of the hardware rehearsals (tests/ros/test_hardware*.py): the simulator on the wall
clock with TurtleBot3 Burgers named tb3_<i>, one robot.launch per robot, and the agents' events
as a plain `rostopic echo` sees them. The rehearsals are split over files so that the suite's
workers run them at the same time (each waits on the wall clock)."""

from __future__ import annotations

import contextlib
import csv
import time
from pathlib import Path

import yaml

HERE = Path(__file__).resolve().parent
START, GOAL, REACHED, FAILED, HEARTBEAT = 0, 1, 2, 3, 4


def start_world(ros, patrol_map: str, robots: int, speed: float = 0.22):
    world = {"patrol_map": patrol_map, "seed": 0,
             "robot": {"preset": "burger", "max_linear_speed": speed},
             "laser": {"preset": "lds01"}, "robots": robots}
    path = ros.home / "world.yaml"
    path.write_text(yaml.safe_dump(world))
    ros.start(["rosrun", "tpuaf_stage", "tpuaf_stage", f"_world:={path}", "_wall_clock:=true",
               "_robot_prefix:=tb3_", "_scan_topic:=scan", "_status_period:=0"], name="stage")
    # The agents' events with their wall-clock receipt time (CSV; plain rostopic).
    ros.start(["rostopic", "echo", "-p", "/fleet/agent_events"], name="events")


def start_robot(ros, patrol_map: str, robots: int, index: int, *args: str, speed: float = 0.22):
    return ros.start(["roslaunch", "tpuaf_ros", "robot.launch", f"map:={patrol_map}",
                      f"robots:={robots}", f"index:={index}", "prefix:=tb3_", "scan_topic:=scan",
                      f"max_linear_speed:={speed}", "output:=screen", *args], name=f"tb3_{index}")


def events(ros) -> list[tuple[float, int, int, int]]:
    """(wall receipt time [s], robot index, event, vertex id) of every AgentEvent so far."""
    path = ros.home / "events.out"
    rows = []
    with contextlib.suppress(FileNotFoundError), path.open() as f:
        for row in csv.DictReader(f):
            try:
                rows.append((int(row["%time"]) * 1e-9, int(row["field.robot_index"]),
                             int(row["field.event"]), int(row["field.vertex"])))
            except (KeyError, ValueError, TypeError):
                continue  # a line being written
    return rows


def wait_started(ros, robots: int, timeout: float = 60.0) -> float:
    """Wall time when every robot has sent START."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        started = {r for _, r, e, _ in events(ros) if e == START}
        if len(started) == robots:
            return time.time()
        time.sleep(0.5)
    raise AssertionError(f"not every robot started within {timeout} s: {started}\n"
                         + "\n".join(ros.output(f"tb3_{i}")[-2000:] for i in range(robots)))


def reached(rows, robot, after=0.0):
    return [(t, v) for t, r, e, v in rows if r == robot and e == REACHED and t >= after]


def max_gap(times: list[float]) -> float:
    return max((b - a for a, b in zip(times, times[1:], strict=False)), default=0.0)
