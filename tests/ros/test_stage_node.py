"""tpuaf_stage with a real roscore: interface contract, rates in simulated time, tf, /clock,
watchdog, reset service, refusal of bad configuration.

Test-side ROS clients run in a probe subprocess (rospy initialises once per process).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.ros

N = 4
POSES = [(2.0, 2.0, 0.0), (8.0, 2.0, math.pi / 2), (8.0, 8.0, math.pi), (2.0, 8.0, -math.pi / 2)]
ODOM_RATE, SCAN_RATE = 20.0, 10.0  # [Hz of sim time]


def write_room(folder: Path) -> Path:
    """A 10 m x 10 m room (0.05 m cells) with 0.2 m walls, as map_server YAML + PGM."""
    occ = np.zeros((200, 200), dtype=bool)
    occ[:4, :] = occ[-4:, :] = occ[:, :4] = occ[:, -4:] = True
    pixels = np.where(occ[::-1], 0, 254).astype(np.uint8)  # image row 0 = top of the map
    (folder / "room.pgm").write_bytes(b"P5\n200 200\n255\n" + pixels.tobytes())
    (folder / "room.yaml").write_text("image: room.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\n"
                                      "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return folder / "room.yaml"


def write_world(folder: Path) -> Path:
    write_room(folder)
    poses = ", ".join(f"[{x}, {y}, {th}]" for x, y, th in POSES)
    path = folder / "world.yaml"
    path.write_text(f"map: room.yaml\nseed: 3\nlaser: {{rate: {SCAN_RATE}, noise_std: 0.0}}\n"
                    f"robots: [{poses}]\n")
    return path


PROBE = r'''
import json, math, sys, time
import rospy, rosgraph, tf2_ros
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Empty

N = int(sys.argv[1])
out = {}
rospy.init_node("probe", anonymous=True)

# Wait until the node has advertised everything.
deadline = time.monotonic() + 60
want = {f"/robot_{i}/{t}" for i in range(N) for t in ("odom", "base_scan", "base_pose_ground_truth")}
while time.monotonic() < deadline:
    published = dict(rospy.get_published_topics())
    if want <= set(published) and "/clock" in published:
        break
    time.sleep(0.2)
master = rosgraph.Master("/probe")
out["types"] = dict(master.getTopicTypes())
# What the simulator subscribes to, with types, from the node itself (as rosnode info does).
import xmlrpc.client
node_uri = master.lookupNode("/tpuaf_stage")
out["node_subscriptions"] = dict(xmlrpc.client.ServerProxy(node_uri).getSubscriptions("/probe")[2])

stamps = {}
def keep(name):
    def cb(msg):
        stamps.setdefault(name, []).append(msg.header.stamp.to_sec())
    return cb
truth = {}
def keep_truth(i):
    def cb(msg):
        p = msg.pose.pose
        yaw = 2 * math.atan2(p.orientation.z, p.orientation.w)
        truth[i] = (p.position.x, p.position.y, yaw, msg.twist.twist.angular.z, msg.header.stamp.to_sec())
    return cb
scans = {}
def keep_scan(i):
    def cb(msg):
        scans[i] = {"n": len(msg.ranges), "frame": msg.header.frame_id, "min": msg.angle_min,
                    "inc": msg.angle_increment, "rmax": msg.range_max, "ranges": list(msg.ranges)}
    return cb
subs = []
for i in range(N):
    subs.append(rospy.Subscriber(f"/robot_{i}/odom", Odometry, keep(f"odom{i}"), queue_size=1000))
    subs.append(rospy.Subscriber(f"/robot_{i}/base_scan", LaserScan, keep(f"scan{i}"), queue_size=1000))
    subs.append(rospy.Subscriber(f"/robot_{i}/base_scan", LaserScan, keep_scan(i), queue_size=1))
    subs.append(rospy.Subscriber(f"/robot_{i}/base_pose_ground_truth", Odometry, keep_truth(i), queue_size=1))
clock = []
subs.append(rospy.Subscriber("/clock", Clock, lambda m: clock.append(m.clock.to_sec()), queue_size=1))
buf = tf2_ros.Buffer(cache_time=rospy.Duration(3600))
listener = tf2_ros.TransformListener(buf)
pubs = [rospy.Publisher(f"/robot_{i}/cmd_vel", Twist, queue_size=1) for i in range(N)]

# /clock against wall time.
while not clock:
    time.sleep(0.05)
c0, w0 = clock[-1], time.monotonic()
time.sleep(2.0)
out["clock_sim_s"], out["clock_wall_s"] = clock[-1] - c0, time.monotonic() - w0
time.sleep(1.0)
out["stamps"] = {k: v for k, v in stamps.items()}

# tf chain of every robot.
out["tf"] = {}
for i in range(N):
    chain = {}
    for parent, child in ((f"robot_{i}/odom", f"robot_{i}/base_scan"),
                          ("map", f"robot_{i}/base_scan"),
                          ("map", f"robot_{i}/base_footprint")):
        try:
            t = buf.lookup_transform(parent, child, rospy.Time(0), rospy.Duration(10.0))
            tr = t.transform.translation
            q = t.transform.rotation
            chain[f"{parent}->{child}"] = [tr.x, tr.y, tr.z, 2 * math.atan2(q.z, q.w)]
        except Exception as err:
            chain[f"{parent}->{child}"] = str(err)
    out["tf"][i] = chain
out["scans"] = scans
out["truth_before"] = dict(truth)

# Watchdog: robots 0 and 1 get a fresh turn command; then robot 1 stops receiving them.
def drive(which, seconds):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        for i in which:
            m = Twist(); m.angular.z = 1.0
            pubs[i].publish(m)
        time.sleep(0.01)
time.sleep(1.0)  # connections up
drive([0, 1], 2.0)
out["turning"] = {i: truth[i][3] for i in range(N)}
drive([0], 2.0)
out["after_stale"] = {i: truth[i][3] for i in range(N)}
time.sleep(1.0)

# reset_positions.
rospy.wait_for_service("/reset_positions", 10.0)
rospy.ServiceProxy("/reset_positions", Empty)()
time.sleep(1.0)
out["after_reset"] = dict(truth)
print("RESULT " + json.dumps(out))
'''


@pytest.fixture(scope="module")
def stage(module_roscore, tmp_path_factory):
    """The node with 4 robots (real-time factor 5, watchdog 1 s) and one probe run."""
    ros = module_roscore
    folder = tmp_path_factory.mktemp("world")
    world = write_world(folder)
    node = ros.start(["rosrun", "tpuaf_stage", "tpuaf_stage", f"_world:={world}",
                      f"_odom_rate:={ODOM_RATE}", "_real_time_factor:=5.0",
                      "_cmd_vel_timeout:=1.0", "_status_period:=2.0"], name="stage")
    result = ros.run_python(PROBE, timeout=240, args=[str(N)])
    alive = node.poll() is None
    log = ros.output("stage")
    ros.stop(node)
    lines = [ln for ln in result.stdout.splitlines() if ln.startswith("RESULT ")]
    assert lines, f"probe failed:\n{result.stdout[-2000:]}\n{result.stderr[-4000:]}\nnode:\n{log[-3000:]}"
    return {"out": json.loads(lines[-1][7:]), "log": log, "alive": alive}


def test_node_comes_up_and_logs_effective_values(stage):
    assert stage["alive"]
    assert "parameters (effective)" in stage["log"] and "'cmd_vel_timeout': 1.0" in stage["log"]
    assert "world (effective)" in stage["log"] and "'robots': 4" in stage["log"]


def test_topics_have_the_contract_types(stage):
    types = stage["out"]["types"]
    assert types["/clock"] == "rosgraph_msgs/Clock"
    assert types["/tf"] == "tf2_msgs/TFMessage"
    assert types["/tf_static"] == "tf2_msgs/TFMessage"
    for i in range(N):
        assert types[f"/robot_{i}/odom"] == "nav_msgs/Odometry"
        assert types[f"/robot_{i}/base_pose_ground_truth"] == "nav_msgs/Odometry"
        assert types[f"/robot_{i}/base_scan"] == "sensor_msgs/LaserScan"
        assert stage["out"]["node_subscriptions"][f"/robot_{i}/cmd_vel"] == "geometry_msgs/Twist"


def test_rates_in_simulated_time(stage):
    stamps = stage["out"]["stamps"]
    for i in range(N):
        for key, rate in ((f"odom{i}", ODOM_RATE), (f"scan{i}", SCAN_RATE)):
            s = np.array(stamps[key])
            assert len(s) >= 20, key
            period = np.median(np.diff(s))
            assert period == pytest.approx(1.0 / rate, rel=0.05), key


def test_clock_runs_faster_than_wall_time(stage):
    out = stage["out"]
    assert out["clock_sim_s"] > 2.0 * out["clock_wall_s"]


def test_tf_chain_resolves_for_every_robot(stage):
    for i, (x, y, th) in enumerate(POSES):
        chain = stage["out"]["tf"][str(i)]
        for key, value in chain.items():
            assert isinstance(value, list), f"robot {i} {key}: {value}"
        # base_scan sits at (-0.032, 0, 0.172 + 0.010) from base_footprint (Burger preset).
        mx, my, mz, myaw = chain[f"map->robot_{i}/base_scan"]
        assert mx == pytest.approx(x - 0.032 * math.cos(th), abs=1e-3)
        assert my == pytest.approx(y - 0.032 * math.sin(th), abs=1e-3)
        assert mz == pytest.approx(0.182, abs=1e-6)
        assert math.cos(myaw - th) == pytest.approx(1.0, abs=1e-6)
        ox, oy, _, oyaw = chain[f"robot_{i}/odom->robot_{i}/base_scan"]
        assert (ox, oy, oyaw) == pytest.approx((-0.032, 0.0, 0.0), abs=1e-3)


def test_scans_see_the_room(stage):
    for i in range(N):
        scan = stage["out"]["scans"][str(i)]
        assert scan["n"] == 360 and scan["frame"] == f"robot_{i}/base_scan"
        assert scan["inc"] == pytest.approx(math.pi / 180)
        # Beam 180 points backwards; every robot stands 1.8 m from two inner walls, and the laser
        # is 0.032 m behind the centre: the wall behind is at 1.8 - 0.032 m.
        assert scan["ranges"][180] == pytest.approx(1.8 - 0.032, abs=1e-4)
        # Ahead the wall is 6.2 m away, beyond the 3.5 m range: no return reads inf.
        assert math.isinf(scan["ranges"][0])


def test_stale_cmd_vel_stops_only_that_robot(stage):
    out = stage["out"]
    assert out["turning"]["0"] == pytest.approx(1.0) and out["turning"]["1"] == pytest.approx(1.0)
    assert out["turning"]["2"] == 0.0 and out["turning"]["3"] == 0.0
    assert out["after_stale"]["0"] == pytest.approx(1.0)
    assert out["after_stale"]["1"] == 0.0


def test_reset_positions_service(stage):
    after = stage["out"]["after_reset"]
    for i, (x, y, th) in enumerate(POSES):
        px, py, pyaw, _w, _stamp = after[str(i)]
        assert (px, py) == pytest.approx((x, y), abs=1e-9)
        assert math.cos(pyaw - th) == pytest.approx(1.0, abs=1e-9)


def run_refused(ros, args, name):
    node = ros.start(["rosrun", "tpuaf_stage", "tpuaf_stage", *args], name=name)
    code = node.wait(60)
    return code, ros.output(name)


def test_bad_world_file_is_refused(module_roscore, tmp_path):
    roscore = module_roscore
    write_room(tmp_path)
    bad = tmp_path / "bad.yaml"
    bad.write_text("map: room.yaml\nrobots: [[2.0, 2.0]]\nlaser:\n  beams: 360\n  rnage_max: 4\n")
    code, text = run_refused(roscore, [f"_world:={bad}"], "bad_world")
    assert code != 0
    assert f"{bad}:4: unknown key(s) rnage_max in laser" in text
    assert "Traceback" not in text
    inside = tmp_path / "inside.yaml"
    inside.write_text("map: room.yaml\nrobots: [[0.1, 2.0]]\n")
    code, text = run_refused(roscore, [f"_world:={inside}"], "inside_wall")
    assert code != 0 and "robots[0]" in text and "overlaps a wall" in text


def test_unknown_parameter_is_refused(module_roscore, tmp_path):
    roscore = module_roscore
    world = write_world(tmp_path)
    code, text = run_refused(roscore, [f"_world:={world}", "_odom_hz:=5"], "bad_param")
    assert code != 0
    assert "unknown parameter(s) ~odom_hz" in text and "~odom_rate" in text
    code, text = run_refused(roscore, [], "no_world")
    assert code != 0 and "~world" in text


LOCKSTEP_PROBE = r"""
import json, sys, time
import rospy
from geometry_msgs.msg import TwistStamped
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from std_msgs.msg import String

N = int(sys.argv[1])
rospy.init_node("agents", anonymous=True)
clock, events = [], []
rospy.Subscriber("/clock", Clock, lambda m: clock.append(m.clock.to_sec()), queue_size=10)
rospy.Subscriber("/fleet/sim_events", String, lambda m: events.append(json.loads(m.data)),
                 queue_size=100)
stamps = {i: [] for i in range(N)}
pubs = {}
silent = set()
def on_odom(msg, i):
    stamps[i].append(msg.header.stamp.to_sec())
    if i in pubs and i not in silent:
        time.sleep(0.002)  # a slow agent
        answer = TwistStamped()
        answer.header.stamp = msg.header.stamp  # the tick it answers
        answer.twist.angular.z = 0.5
        pubs[i].publish(answer)
for i in range(N):
    rospy.Subscriber(f"/robot_{i}/odom", Odometry, on_odom, callback_args=i, queue_size=10)
deadline = time.monotonic() + 60.0  # a loaded machine: wait for the first /clock, not 3 s
while not clock and time.monotonic() < deadline:
    time.sleep(0.1)
time.sleep(2.0)
gate = sorted(set(clock))
for i in range(N):
    pubs[i] = rospy.Publisher(f"/robot_{i}/cmd_vel_stamped", TwistStamped, queue_size=10)
time.sleep(5.0)
silent.add(N - 1)  # the last agent stops answering (alive, but hung)
clock_at_silence = clock[-1]
count_at_silence = {i: len(stamps[i]) for i in range(N)}
time.sleep(4.0)
print("RESULT " + json.dumps({"gate_clock": gate, "clock_end": clock[-1] if clock else None,
                              "clock_at_silence": clock_at_silence,
                              "count_at_silence": count_at_silence,
                              "stamps": stamps, "events": events}))
"""


def test_lockstep_waits_for_every_agent_and_goes_on_without_a_silent_one(module_roscore,
                                                                          tmp_path):
    ros = module_roscore
    world = write_world(tmp_path)
    summary = tmp_path / "sim_summary.json"
    node = ros.start(["rosrun", "tpuaf_stage", "tpuaf_stage", f"_world:={world}",
                      f"_odom_rate:={ODOM_RATE}", "_lockstep:=true", "_lockstep_timeout:=1.0",
                      "_start_timeout:=600.0", "_cmd_vel_timeout:=1.0",
                      f"_summary_file:={summary}", "__name:=stage_lockstep"],
                     name="stage_lockstep")
    try:
        result = ros.run_python(LOCKSTEP_PROBE, timeout=120, args=[str(N)], name="lockstep_probe")
        log = ros.output("stage_lockstep")
    finally:
        ros.stop(node)
    lines = [ln for ln in result.stdout.splitlines() if ln.startswith("RESULT ")]
    assert lines, f"probe failed:\n{result.stderr[-3000:]}\nnode:\n{log[-3000:]}"
    out = json.loads(lines[-1][7:])
    # Before every robot's cmd_vel_stamped had a publisher the clock stood at the first step.
    assert out["gate_clock"] == [pytest.approx(0.01)]
    assert "every robot has a cmd_vel_stamped publisher" in log
    # While all answered, no tick was skipped: each robot saw every odom tick, 1 / rate apart.
    for i in range(N):
        s = np.array(out["stamps"][str(i)][1:out["count_at_silence"][str(i)]])
        assert len(s) > 10
        assert np.diff(s) == pytest.approx(1.0 / ODOM_RATE, abs=1e-6)
    # The silent agent was declared unresponsive once, and the run went on without it.
    unresponsive = [e for e in out["events"] if e["event"] == "unresponsive"]
    assert [e["robot"] for e in unresponsive] == [N - 1]
    assert out["clock_end"] > out["clock_at_silence"] + 1.0
    assert "robot_3" in log and "unresponsive" in log
    # The node writes its summary on exit: the event is counted.
    data = json.loads(summary.read_text())
    assert data["unresponsive_events"] == 1 and data["unresponsive_per_robot"] == [0, 0, 0, 1]


def test_wall_clock_mode_stamps_wall_time_without_clock(module_roscore, tmp_path):
    ros = module_roscore
    world = write_world(tmp_path)
    node = ros.start(["rosrun", "tpuaf_stage", "tpuaf_stage", f"_world:={world}",
                      "_wall_clock:=true", "__name:=stage_wall"], name="stage_wall")
    probe = r"""
import json, time
import rospy, rosgraph
from nav_msgs.msg import Odometry
rospy.init_node("wall_probe", anonymous=True)
got = []
rospy.Subscriber("/robot_0/base_pose_ground_truth", Odometry,
                 lambda m: got.append((m.header.stamp.to_sec(), time.time())), queue_size=100)
time.sleep(4.0)
topics = [t for t, _ in rospy.get_published_topics()]
print("RESULT " + json.dumps({"got": got, "topics": topics}))
"""
    try:
        result = ros.run_python(probe, timeout=60, name="wall_probe")
    finally:
        log = ros.output("stage_wall")
        ros.stop(node)
    lines = [ln for ln in result.stdout.splitlines() if ln.startswith("RESULT ")]
    assert lines, f"probe failed:\n{result.stderr[-3000:]}\nnode:\n{log[-3000:]}"
    out = json.loads(lines[-1][7:])
    assert "/clock" not in out["topics"]
    stamps = np.array([s for s, _ in out["got"]])
    walls = np.array([w for _, w in out["got"]])
    assert len(stamps) >= 15  # 10 Hz of real time for a few seconds
    assert np.abs(stamps - walls).max() < 1.5  # wall-clock stamps, not simulated seconds
    assert (stamps[-1] - stamps[0]) / (walls[-1] - walls[0]) == pytest.approx(1.0, abs=0.1)
