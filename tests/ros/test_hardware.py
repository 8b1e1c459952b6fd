"""The hardware path rehearsed on this machine: the simulator in wall-clock mode (tpuaf_stage
~wall_clock: real-time pace, wall-clock stamps, no /clock; /use_sim_time unset = false), TurtleBot3
Burgers named tb3_<i> with their laser on `scan`, one `roslaunch tpuaf_ros robot.launch` per robot
with the hardware defaults (tf localisation, built-in navigator, run start on /fleet/start).

- two Burgers on lab and on grid (in parallel) keep visiting for 120 s of wall time;
- clock skew (0.5 s: silent and harmless; 3 s: named in a warning), malformed team messages
  (ignored with a reason), one robot stopped (the others detect it and drop its intentions);
- the move_base backend against a test action server (tests/ros/move_base_mock.py: move_base is
  not packaged here, so a mock drives the simulated robot).
About 3.5 minutes of wall time in all."""

from __future__ import annotations

import contextlib
import csv
import json
import re
import time
from pathlib import Path

import pytest
import yaml

from .conftest import VENV_PYTHON, ros_master

pytestmark = [pytest.mark.ros, pytest.mark.slow]

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


# --- 120 s rehearsal, lab and grid in parallel ----------------------------------------------


RUN_S = 120.0


def test_two_burgers_keep_visiting_on_the_wall_clock(tmp_path):
    maps = ("lab", "grid")
    with contextlib.ExitStack() as stack:
        envs = {m: stack.enter_context(ros_master(tmp_path / m)) for m in maps}
        for m, ros in envs.items():
            start_world(ros, m, 2)
            # What a user records for `tpuaf analyze` (docs/HARDWARE.md): no ground truth.
            ros.start(["rosbag", "record", "-O", str(ros.home / "run.bag"), "/tf", "/tf_static",
                       "/team/visits", "/team/intentions", "/team/idleness",
                       "/team/task_requests", "/team/task_bids", "/fleet/agent_events",
                       "/fleet/start", "/tb3_0/odom", "/tb3_1/odom"], name="rosbag")
            for i in range(2):
                start_robot(ros, m, 2, i)
        t0 = {m: wait_started(ros, 2) for m, ros in envs.items()}
        time.sleep(RUN_S - (time.time() - max(t0.values())))
        rows = {m: events(ros) for m, ros in envs.items()}
        logs = {m: [ros.output(f"tb3_{i}") for i in range(2)] for m, ros in envs.items()}
        topics = {m: ros.run_python(
            "import rospy, rosgraph; m = rosgraph.Master('/t');"
            "print(sorted(t for t, _ in m.getPublishedTopics('')))").stdout for m, ros in envs.items()}
        for ros in envs.values():
            ros.stop_all()
    for m in maps:
        start = t0[m]
        for i in range(2):
            visits = reached(rows[m], i, start)
            beats = [t for t, r, e, _ in rows[m] if r == i and t >= start]
            gap = max_gap([start] + [t for t, _ in visits] + [start + RUN_S])
            print(f"rehearsal {m} tb3_{i}: {len(visits)} visits in {RUN_S:g} s, longest gap "
                  f"{gap:.1f} s, heartbeat gap {max_gap(beats):.1f} s")
            assert len(visits) >= (6 if m == "lab" else 3), (m, i, visits, logs[m][i][-3000:])
            # Still visiting in the last third of the run; heartbeats never stopped.
            assert visits[-1][0] > start + 0.6 * RUN_S, (m, i, visits)
            assert max_gap(beats) < 3.0, (m, i, max_gap(beats))
            assert beats[-1] > start + RUN_S - 5.0
            log = logs[m][i]
            assert "localisation tf map" in log and "wall clock" in log
            assert "robot stopped" not in log, log[-3000:]
        # One run start for the team, announced once on /fleet/start (latched).
        epochs = {re.findall(r"run start (?:\(epoch\) )?(\d+\.\d+) s", log)[-1]
                  for log in logs[m]}
        assert len(epochs) == 1, epochs
        assert "/clock" not in topics[m]
        bag = tmp_path / m / "run.bag"
        assert bag.is_file() and bag.stat().st_size > 10_000


# --- rehearsal on a map whose edges cross walls (issue 18) -----------------------------------

WALLS_RUN_S = 150.0
QUIET_S = 60.0  # [s] no robot goes this long without a visit or a stuck report...
BURGER_MPS = 0.22  # ...unless one edge alone takes longer at a Burger's speed (example: 15.6 m)


def test_three_burgers_keep_visiting_where_edges_cross_walls(tmp_path, shared_maps):
    """docs/HARDWARE.md's rehearsal (robot.launch, tf localisation, wall clock, a plain bag) on
    patrolling_sim's `example`, 5 of whose 34 edges run straight through a wall: the built-in
    navigator plans round them. Every robot keeps visiting, and none goes QUIET_S without a
    visit or a stuck report (or 1.2 x its longest edge's driving time, where one edge takes
    longer than that)."""
    from tpuaf.maps import load_map
    from tpuaf.navigation.planner import PathPlanner

    patrol_map = str(shared_maps / "example")
    longest_m = max(c.planned_m for c in PathPlanner(load_map(patrol_map), 0.105).check_edges())
    quiet_s = max(QUIET_S, 1.2 * longest_m / BURGER_MPS)
    with ros_master(tmp_path / "walls") as ros:
        start_world(ros, patrol_map, 3)
        ros.start(["rosbag", "record", "-O", str(ros.home / "run.bag"), "/tf", "/tf_static",
                   "/team/visits", "/team/intentions", "/fleet/agent_events", "/fleet/start"],
                  name="rosbag")
        for i in range(3):
            start_robot(ros, patrol_map, 3, i)
        start = wait_started(ros, 3, timeout=90.0)
        time.sleep(max(0.0, WALLS_RUN_S - (time.time() - start)))
        rows = events(ros)
        logs = [ros.output(f"tb3_{i}") for i in range(3)]
        ros.stop_all()
    for i in range(3):
        visits = reached(rows, i, start)
        failed = [t for t, r, e, _ in rows if r == i and e == FAILED and t >= start]
        stuck = [start + float(m) for m in re.findall(r"stuck on the way to vertex \d+ at run "
                                                       r"time ([0-9.]+) s", logs[i])]
        news = sorted([start] + [t for t, _ in visits] + failed + stuck + [start + WALLS_RUN_S])
        print(f"walls rehearsal tb3_{i}: {len(visits)} visits, {len(failed)} failed goals, "
              f"{len(stuck)} stuck reports in {WALLS_RUN_S:g} s; longest quiet "
              f"{max_gap(news):.1f} s")
        assert len(visits) >= 2, (i, visits, logs[i][-3000:])
        assert visits[-1][0] > start + 0.5 * WALLS_RUN_S, (i, visits)
        assert max_gap(news) < quiet_s, (i, quiet_s, news, logs[i][-3000:])
        assert "localisation tf map" in logs[i] and "wall clock" in logs[i]
    assert (tmp_path / "walls" / "run.bag").is_file()


# --- skew, malformed messages, a robot stopped -----------------------------------------------


MALFORMED = r"""
import math, sys, time, rospy, genpy
from tpuaf_ros.msg import Visit, Intention, IdlenessEstimate
rospy.init_node("intruder")
pv = rospy.Publisher("/team/visits", Visit, queue_size=10)
pi = rospy.Publisher("/team/intentions", Intention, queue_size=10)
pe = rospy.Publisher("/team/idleness", IdlenessEstimate, queue_size=10)
time.sleep(2.0)
now = rospy.Time.now()
def visit(robot, index, vertex, stamp):
    m = Visit(); m.robot, m.robot_index, m.vertex, m.next_vertex, m.header.stamp = robot, index, vertex, -1, stamp
    return m
for _ in range(3):
    pv.publish(visit("tb3_9", 9, 1, now))                         # unknown robot
    pv.publish(visit("tb3_1", 1, 999, now))                       # vertex not on the map
    pv.publish(visit("tb3_1", 1, 1, now + genpy.Duration(1e6)))   # far future
    i = Intention(); i.robot, i.robot_index, i.from_vertex, i.vertex = "tb3_1", 1, 1, 2
    i.header.stamp, i.expected_arrival, i.travel_time = now, math.nan, 3.0
    pi.publish(i)                                                 # non-finite arrival
    e = IdlenessEstimate(); e.robot, e.robot_index, e.header.stamp = "tb3_1", 1, now
    e.vertices, e.idleness, e.next_vertex = [1, 2], [0.0, 1.0], -1
    pe.publish(e)                                                 # wrong length
    time.sleep(0.3)
print("sent")
"""


def test_skew_malformed_messages_and_a_stopped_robot(tmp_path):
    # grid at 1 m/s: room for three robots, a visit every ~6 s (the test is not about Burgers).
    with ros_master(tmp_path / "ros") as ros:
        start_world(ros, "grid", 3, speed=1.0)
        start_robot(ros, "grid", 3, 0, speed=1.0)
        start_robot(ros, "grid", 3, 1, "clock_offset:=0.5", speed=1.0)
        victim = start_robot(ros, "grid", 3, 2, "clock_offset:=3.0", speed=1.0)
        wait_started(ros, 3)
        time.sleep(8.0)
        out = ros.run_python(MALFORMED, timeout=30, name="intruder")
        assert "sent" in out.stdout, out.stderr
        stop_t = time.time()
        ros.stop(victim)
        time.sleep(18.0)  # teammate_timeout 10 s + margin
        rows = events(ros)
        logs = [ros.output(f"tb3_{i}") for i in range(2)]
    log0, log1 = logs
    # Skew: 3 s is named (by both), 0.5 s is not.
    assert re.search(r"clock of tb3_2 is \+(2\.9|3\.0)\d s off ours", log0), log0[-3000:]
    assert "clock of tb3_1" not in log0
    assert "clock of tb3_2" in log1 and "clock of tb3_0" not in log1
    # Malformed messages: ignored, each with its reason; nobody crashed.
    for why in ("unknown robot index 9", "has no vertex 999", "from our clock",
                "expected_arrival nan is not finite", "estimate of 2 vertices"):
        assert why in log0, (why, log0[-3000:])
    # The stopped robot is detected by both others, which keep visiting.
    for i, log in enumerate(logs):
        assert re.search(r"teammate tb3_2 silent for 1\d\.\d s: lost, its intentions dropped", log), log
        assert len(reached(rows, i, stop_t + 2.0)) >= 2, (i, reached(rows, i))
        assert "Traceback" not in log
    # Robots 1 (0.5 s ahead) and 2 (3 s ahead) visited before; their visits were accepted.
    assert reached(rows, 1) and reached(rows, 2, 0.0)
    assert "ignored a team message from 'tb3_2'" not in log0


# --- move_base backend -----------------------------------------------------------------------


def test_move_base_backend_reaches_vertices_through_the_action_server(tmp_path):
    with ros_master(tmp_path / "ros") as ros:
        start_world(ros, "lab", 1)
        ros.start([str(VENV_PYTHON), str(HERE / "move_base_mock.py"), "__ns:=tb3_0"],
                  name="move_base")
        start_robot(ros, "lab", 1, 0, "navigation:=move_base")
        start = wait_started(ros, 1)
        time.sleep(25.0)
        rows = events(ros)
        pubs = ros.run_python(
            "import rosgraph; m = rosgraph.Master('/t'); pubs, _, _ = m.getSystemState();"
            "print([n for t, n in pubs if t == '/tb3_0/cmd_vel'])").stdout
        log = ros.output("tb3_0")
        goals = ros.output("move_base")
    visits = reached(rows, 0, start)
    assert len(visits) >= 3, (visits, log[-3000:], goals[-2000:])
    sent = re.findall(r"GOAL \d+ map ", goals)
    assert len(sent) >= len(visits), goals
    assert "navigation move_base" in log
    # The agent publishes no velocity: only the planner (here the mock) drives.
    assert "['/tb3_0/move_base']" in pubs, pubs


# --- stale inputs: stop, say so, resume -----------------------------------------------------


FAKE_ROBOT = r"""
import json, math, time, rospy
from geometry_msgs.msg import TransformStamped, Twist
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage
rospy.init_node("fake_robot")
tf_pub = rospy.Publisher("/tf", TFMessage, queue_size=10)
scan_pub = rospy.Publisher("/tb3_0/scan", LaserScan, queue_size=10)
cmds = []
rospy.Subscriber("/tb3_0/cmd_vel", Twist, lambda m: cmds.append((time.time(), m.linear.x, m.angular.z)))
def tf(parent, child, x, y, stamp):
    t = TransformStamped(); t.header.frame_id, t.child_frame_id, t.header.stamp = parent, child, stamp
    t.transform.translation.x, t.transform.translation.y, t.transform.rotation.w = x, y, 1.0
    return t
scan = LaserScan(); scan.header.frame_id = "tb3_0/base_scan"
scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max = 0.0, math.radians(1), 0.12, 3.5
scan.ranges = [math.inf] * 360
phases = {}
t0 = time.time()
k = 0
while time.time() - t0 < 20.0:
    el = time.time() - t0
    scanning = not (8.0 <= el < 14.0)   # the laser stops for 6 s
    now = rospy.Time.now()
    tf_pub.publish(TFMessage([tf("map", "tb3_0/odom", 1.425, 24.225, now), tf("tb3_0/odom", "tb3_0/base_footprint", 0.0, 0.0, now)]))
    if scanning and k % 2 == 0:
        scan.header.stamp = now
        scan_pub.publish(scan)
    k += 1
    time.sleep(0.1)
print(json.dumps({"t0": t0, "cmds": cmds}))
"""


def test_an_agent_whose_laser_stops_halts_says_so_and_resumes(tmp_path):
    with ros_master(tmp_path / "ros") as ros:
        start_robot(ros, "grid", 1, 0, speed=1.0)
        out = ros.run_python(FAKE_ROBOT, timeout=60, name="fake_robot")
        log = ros.output("tb3_0")
    data = json.loads(out.stdout.strip().splitlines()[-1])
    t0, cmds = data["t0"], data["cmds"]
    moving = [(t - t0) for t, v, w in cmds if abs(v) > 1e-6 or abs(w) > 1e-6]
    assert any(t < 8.0 for t in moving), cmds[:20]  # drives while scans come
    halted = [(t - t0, v, w) for t, v, w in cmds if 10.5 <= t - t0 < 14.0]
    assert halted and all(v == 0 and w == 0 for _, v, w in halted), halted
    assert any(t > 14.5 for t in moving)  # resumes when the laser is back
    assert "robot stopped: scan (/tb3_0/scan) not advancing for" in log, log[-3000:]
    assert log.count("pose, scan and clock advancing: driving") >= 2
