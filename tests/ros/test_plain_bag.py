"""A wall-clock rehearsal of a hardware run, recorded with a plain `rosbag record`, then
`tpuaf analyze` on that bag: visit counts equal the agents' own reports.

Setup (as on TurtleBot3s, the simulator standing in for the robots): own roscore, tpuaf_stage in
wall-clock rehearsal mode (real time, wall stamps, no /clock, map -> odom on tf), 2 Burgers on
`lab`, one `roslaunch tpuaf_ros robot.launch` per robot (tf localisation, wall clock, the first
agent announces the start), the monitor in hardware mode (visits from the agents' REACHED
events, positions from tf) and `rosbag record` of the team topics, tf and the agent events:
no ground truth, no monitor topics. The agents' reports are counted from the bag with ROS's
own `rosbag` Python API, independently of tpuaf's reader (rosbags).
"""

from __future__ import annotations

import csv
import json
import subprocess
import time
from pathlib import Path

import pytest

from .conftest import REPO, ros_master

pytestmark = [pytest.mark.ros, pytest.mark.slow]

TPUAF = str(REPO / ".venv" / "bin" / "tpuaf")
ROBOTS = 2
RUN_S = 60.0  # [s of wall time] of patrol after the start
RECORDED = ["/team/visits", "/team/intentions", "/team/idleness", "/tf", "/tf_static",
            "/fleet/agent_events", "/fleet/start"]


def count_reports(bag: Path) -> dict:
    """The agents' reports in the bag, read with ROS's rosbag API: Visit messages and START /
    REACHED events as (robot, stamp [s]) lists, and the start announced on /fleet/start."""
    code = f"""
import json, rosbag
out = {{"visits": [], "events": [], "start": None}}
with rosbag.Bag({str(bag)!r}) as b:
    for topic, msg, _t in b.read_messages(topics=["/team/visits", "/fleet/agent_events",
                                                  "/fleet/start"]):
        if topic == "/team/visits":
            out["visits"].append((msg.robot_index, msg.header.stamp.to_sec()))
        elif topic == "/fleet/start":
            epoch = msg.header.stamp.to_sec()  # tpuaf_ros/RunStart, re-latched by every agent
            out["start"] = epoch if out["start"] is None else min(out["start"], epoch)
        elif msg.event in (0, 2) and msg.vertex >= 0:  # START, REACHED
            out["events"].append((msg.robot_index, msg.header.stamp.to_sec(), msg.vertex))
print(json.dumps(out))
"""
    from .conftest import VENV_PYTHON, workspace_env

    out = subprocess.run([str(VENV_PYTHON), "-c", code], capture_output=True, text=True,
                         timeout=120, env=workspace_env())
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def per_robot(reports: list, t0: float = -1.0, t1: float = float("inf")) -> dict[int, int]:
    counts = {r: 0 for r in range(ROBOTS)}
    for r, t, *_ in reports:
        if t0 <= t <= t1:
            counts[r] += 1
    return counts


@pytest.fixture(scope="module")
def rehearsal(tmp_path_factory):
    """Run the rehearsal once; yields (folder, plain bag, monitor results folder)."""
    folder = tmp_path_factory.mktemp("rehearsal")
    prep = subprocess.run([TPUAF, "fleet", "--map", "lab", "--robots", str(ROBOTS),
                           "--duration", str(RUN_S), "--out", str(folder / "prep"),
                           "--prepare-only"], capture_output=True, text=True, timeout=60)
    assert prep.returncode == 0, prep.stderr
    world = folder / "prep" / "world.resolved.yaml"
    assert world.is_file()
    bag = folder / "plain.bag"
    results = folder / "monitor"
    with ros_master(folder / "ros") as ros:
        ros.run_python("import rospy; rospy.set_param('/use_sim_time', False)", timeout=30)
        recorder = ros.start(["rosbag", "record", "-O", str(bag), *RECORDED], name="record")
        ros.start(["rosrun", "tpuaf_stage", "tpuaf_stage", f"_world:={world}",
                   "_wall_clock:=true", "_publish_map_tf:=true"], name="stage")
        ros.start(["rosrun", "tpuaf_ros", "monitor", "_map:=lab", f"_robots:={ROBOTS}",
                   f"_duration:={RUN_S}", "_pose_source:=tf", "_announce_start:=false",
                   "_death_timeout:=10.0", f"_out:={results}"], name="monitor")
        for i in range(ROBOTS):
            ros.start(["roslaunch", "--wait", "tpuaf_ros", "robot.launch", f"index:={i}",
                       f"robots:={ROBOTS}", "map:=lab", "output:=screen"], name=f"agent{i}")
        deadline = time.monotonic() + RUN_S + 90.0
        while time.monotonic() < deadline and not (results / "summary.json").is_file():
            time.sleep(1.0)
        time.sleep(2.0)  # the recorder writes the last messages
        ros.stop(recorder)  # SIGINT: rosbag closes the bag
        logs = {name: ros.output(name)[-3000:] for name in ("stage", "monitor", "agent0")}
    assert bag.is_file(), logs
    return folder, bag, results, logs


def test_rehearsal_keeps_visiting_and_the_monitor_counts_the_reports(rehearsal):
    folder, bag, results, logs = rehearsal
    assert (results / "summary.json").is_file(), logs
    summary = json.loads((results / "summary.json").read_text())
    assert summary["complete"] is True, logs
    reports = count_reports(bag)
    visits = per_robot(reports["events"])  # START / REACHED: the agents' visit reports
    assert all(c >= 3 for c in visits.values()), visits  # both robots kept visiting
    # a Visit team message goes with each (TPUAF also sends one when it decides again after a
    # failed goal, so there may be more of those)
    assert all(per_robot(reports["visits"])[r] >= visits[r] for r in visits), reports
    # (no assert on deaths: on a loaded machine an agent may miss its heartbeats for longer than
    # the death timeout; its reports still count, in the monitor and in the analysis alike)
    assert summary["uncertainty_mean"] is not None  # X from tf
    end = summary["start_time_s"] + summary["duration_s"]
    counted = monitor_visits(results)
    assert summary["visits"] == len(counted)
    assert_reported(counted, reports["events"], summary["start_time_s"], end)


def monitor_visits(results: Path) -> list[tuple[int, float, int]]:
    """(robot, run time [s], vertex id) of each visit in a results folder's visits.csv."""
    with open(results / "visits.csv") as f:
        return sorted((int(row["robot"]), float(row["time_s"]), int(row["vertex_id"]))
                      for row in csv.DictReader(f))


REPORT_LAG_S = 2.0  # [s] an agent's REACHED report may follow the monitor's pose-based visit


def assert_reported(counted: list, events: list, start: float, end: float) -> None:
    """The monitor's visits (robot, run time [s], vertex id) up to the run's end `end` [s]
    are the agents' START / REACHED reports (robot, stamp [s], vertex id), robot by robot and
    in order: the same vertices, each report within REPORT_LAG_S of its visit, every report
    stamped by the end counted; a visit near the end may be reported just after it (the
    monitor reads poses, the agent reports on its own clock: under load up to ~1 s later)."""
    for robot in range(ROBOTS):
        mine = [(start + t, v) for r, t, v in counted if r == robot]
        told = sorted((t, v) for r, t, v in events if r == robot)
        by_end = [t for t, _ in told if t <= end]
        assert len(by_end) <= len(mine) <= len(told), (robot, mine, told, end)
        assert [v for _, v in mine] == [v for _, v in told[:len(mine)]], (robot, mine, told)
        lags = [b[0] - a[0] for a, b in zip(mine, told, strict=False)]
        assert all(-0.5 <= lag <= REPORT_LAG_S for lag in lags), (robot, lags)
        late = told[len(by_end):len(mine)]  # counted, reported after the end
        assert all(t <= end + REPORT_LAG_S for t, _ in late), (robot, late, end)


def test_analyze_of_the_plain_bag_counts_the_agents_reports(rehearsal):
    folder, bag, results, logs = rehearsal
    out = folder / "analysis"
    proc = subprocess.run([TPUAF, "analyze", str(bag), "--map", "lab", "--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    analysis = summary["analysis"]
    assert analysis["pose_source"] == "tf"
    # the analysed span is the bag's, from the announced start, reported as such
    assert summary["duration_s"] <= analysis["bag_span_s"] + 1e-6
    assert analysis["analysed_to_s"] <= analysis["bag_span_s"] + 1e-6
    reports = count_reports(bag)
    end = summary["start_time_s"] + summary["duration_s"]
    expected = per_robot(reports["events"], t1=end)
    assert analysis["visit_reports"] == sum(expected.values()), (analysis, expected)
    counted = {r: 0 for r in range(ROBOTS)}
    with open(out / "visits.csv") as f:
        for row in csv.DictReader(f):
            counted[int(row["robot"])] += 1
    assert counted == expected, (counted, expected)  # robot by robot
    # the live monitor and the analysis of the plain bag agree over the monitor's run
    live = json.loads((results / "summary.json").read_text())
    live_end = live["start_time_s"] + live["duration_s"]
    live_visits = monitor_visits(results)
    assert live["visits"] == len(live_visits)
    assert_reported(live_visits, reports["events"], live["start_time_s"], live_end)
