"""The hardware path rehearsed on this machine (tests/ros/hardware.py): the simulator in
wall-clock mode, TurtleBot3 Burgers named tb3_<i> with their laser on `scan`, one `roslaunch
tpuaf_ros robot.launch` per robot with the hardware defaults (tf localisation, built-in
navigator, run start on /fleet/start).

- clock skew (0.5 s: silent and harmless; 3 s: named in a warning), malformed team messages
  (ignored with a reason), one robot stopped (the others detect it and drop its intentions);
- the move_base backend against a test action server (tests/ros/move_base_mock.py: move_base is
  not packaged here, so a mock drives the simulated robot);
- an agent whose laser stops halts, says so and resumes.
The long rehearsals are in test_hardware_rehearsal.py and test_hardware_walls.py."""

from __future__ import annotations

import json
import re
import time

import pytest

from .conftest import VENV_PYTHON, ros_master
from .hardware import (
    HERE,
    events,
    reached,
    start_robot,
    start_world,
    wait_started,
)

pytestmark = [pytest.mark.ros, pytest.mark.slow]

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
        # teammate_timeout 10 s, then two visits each: polled, so that a loaded machine slows
        # the test instead of failing it
        deadline = time.monotonic() + 75.0
        while True:
            time.sleep(2.0)
            rows = events(ros)
            logs = [ros.output(f"tb3_{i}") for i in range(2)]
            done = all("teammate tb3_2 silent" in log for log in logs) and all(
                len(reached(rows, i, stop_t + 2.0)) >= 2 for i in range(2))
            if done or time.monotonic() > deadline:
                break
    log0, log1 = logs
    # Skew: 3 s is named (by both), 0.5 s is not.
    assert re.search(r"clock of tb3_2 is \+(2\.9|3\.0)\d s off ours", log0), log0[-3000:]
    assert "clock of tb3_1" not in log0
    assert "clock of tb3_2" in log1 and "clock of tb3_0" not in log1
    # Messages from a node that is not the robot's: refused for their sender (SenderCheck)
    # before their content is read (the content checks: tests/test_agent_inputs.py); an
    # index outside the team: refused as unknown. Nobody crashed.
    for why in ("unknown robot index 9", "published by node /intruder, not by robot 1's"):
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
        # three visits take ~20 s on an idle machine; poll (up to 90 s) rather than a fixed
        # sleep, so that a loaded machine slows the test instead of failing it
        deadline = time.monotonic() + 90.0
        while len(reached(events(ros), 0, start)) < 3 and time.monotonic() < deadline:
            time.sleep(1.0)
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
