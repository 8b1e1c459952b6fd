"""monitor: measures a ROS run with tpuaf.metrics (thin adapter, see docs/FLEET.md).

Subscribes /<robot_prefix><i>/base_pose_ground_truth (nav_msgs/Odometry) for every robot and
/fleet/agent_events (tpuaf_ros/AgentEvent). Publishes /fleet/start (std_msgs/Float64, latched:
the run's start, ROS time [s]) once every agent is ready, /fleet/metrics (tpuaf_ros/LiveMetrics)
at 1 Hz of run time and once more with finished = true after writing the results folder.
Private parameters: tpuaf.params.MonitorParams (strict).
"""

import math
import threading
import time
import warnings
from pathlib import Path

import rospy
import yaml
from nav_msgs.msg import Odometry
from std_msgs.msg import Float64

from tpuaf_ros.msg import AgentEvent, LiveMetrics

from ..maps import MapError, load_map
from ..monitor import FleetMonitor
from ..params import MonitorParams, NodeParamError, parse
from . import convert
from .node import private_params, run_node

NODE = "monitor"
warnings.filterwarnings("ignore", message="The publisher should be created with an explicit")


def run_config(p, patrol_map):
    config = {"runtime": "ros", "map": p.map, "map_name": patrol_map.name,
              "strategy": p.strategy, "robots": p.robots, "duration_s": p.duration,
              "seed": p.seed, "death_timeout_s": p.death_timeout}
    if p.config_file:
        extra = yaml.safe_load(Path(p.config_file).read_text()) or {}
        config.update(extra)
    return config


class MonitorNode:
    def __init__(self, p, patrol_map):
        self.p = p
        self.lock = threading.Lock()
        self.patrol_map = patrol_map
        self.fm = FleetMonitor(patrol_map, p.robots, p.duration, start_after=math.inf,
                               death_timeout_s=p.death_timeout)
        self.metrics_pub = rospy.Publisher(convert.METRICS_TOPIC, LiveMetrics, queue_size=10,
                                           latch=True)
        self.start_pub = rospy.Publisher("/fleet/start", Float64, queue_size=1, latch=True)
        self.msg = LiveMetrics()
        self.msg.duration = p.duration
        self.next_metrics = -math.inf
        self.announced = False
        self.done = False
        self.writer = None
        self.config = run_config(p, patrol_map)
        self.ready = [False] * p.robots
        self.ready_wall = None
        rospy.Subscriber(convert.EVENTS_TOPIC, AgentEvent, self.on_event, queue_size=500)
        for i in range(p.robots):
            rospy.Subscriber(f"/{p.robot_prefix}{i}/base_pose_ground_truth", Odometry,
                             self.on_pose, callback_args=i, queue_size=100, tcp_nodelay=True)

    def on_event(self, msg):
        with self.lock:
            r = msg.robot_index
            self.fm.on_event(r, msg.event, self.vertex_index(msg.vertex), msg.stamp.to_sec())
            if 0 <= r < len(self.ready):
                self.ready[r] = True
            if not self.announced and all(self.ready) and self.recorder_ready():
                # Let every subscriber (agents, recorder) finish connecting before the start.
                if self.ready_wall is None:
                    self.ready_wall = time.monotonic()
                if time.monotonic() - self.ready_wall < self.p.start_wall_delay:
                    return
                start = msg.stamp.to_sec() + self.p.start_delay
                self.fm.start_after = start
                self.start_pub.publish(Float64(start))
                self.announced = True
                rospy.loginfo(f"{NODE}: all {self.p.robots} agents ready, run starts at t = "
                              f"{start:.2f} s for {self.p.duration:g} s")

    def vertex_index(self, vid):
        return -1 if vid < 0 else self.patrol_map.index_of(vid)

    def recorder_ready(self):
        if not self.p.wait_for_recorder:
            return True
        try:
            _, subs, _ = rospy.get_master().getSystemState()[2]
        except Exception:  # noqa: BLE001 - the master answers slowly: try on the next event
            return False
        me = rospy.get_name()
        for topic, nodes in subs:
            if topic == convert.EVENTS_TOPIC:
                return any(n != me for n in nodes)
        return False

    def on_pose(self, msg, i):
        with self.lock:
            if self.done:
                return
            pos = msg.pose.pose.position
            self.fm.on_pose(i, msg.header.stamp.to_sec(), pos.x, pos.y)
            if not self.fm.started:
                return
            if self.writer is None:
                self.open_results()
            if self.fm.finished:
                self.finish()
            elif self.fm.now >= self.next_metrics:
                self.publish_metrics()
                self.next_metrics = self.fm.now + 1.0
                if self.writer is not None:
                    self.writer.sync(self.fm.recorder)

    def open_results(self):
        if self.p.out:
            from ..results import ResultsWriter

            self.config["start_time_s"] = self.fm.start_time
            self.writer = ResultsWriter(self.p.out, self.config)

    def publish_metrics(self, finished=False):
        m = self.msg
        m.stamp = rospy.Time.from_sec(max(self.fm.now, 0.0))
        for key, value in self.fm.live().items():
            setattr(m, key, value)
        m.finished = finished
        self.metrics_pub.publish(m)

    def finish(self, interrupted=False):
        if self.done:
            return
        self.done = True
        if self.fm.started:
            summary = self.fm.summary()
            if self.writer is not None:
                self.writer.finish(summary, self.fm.recorder, interrupted=interrupted)
            self.publish_metrics(finished=not interrupted)
            rospy.loginfo(f"{NODE}: run {'interrupted' if interrupted else 'finished'}: "
                          f"{summary['visits']} visits, I_avg = {summary['idleness_avg_s']} s, "
                          f"deaths {summary['deaths']}"
                          + (f"; results in {self.p.out}" if self.p.out else ""))


def main():
    rospy.init_node(NODE)
    try:
        p = parse(MonitorParams, private_params(), rospy.get_name())
        patrol_map = load_map(p.map)
        node = MonitorNode(p, patrol_map)
    except (NodeParamError, MapError, OSError, yaml.YAMLError) as err:
        rospy.logfatal(f"{rospy.get_name()}: {err}")
        return 2
    rospy.on_shutdown(lambda: node.finish(interrupted=True))
    rospy.spin()
    return 0


def entry() -> int:
    return run_node(NODE, __doc__.splitlines()[0].split(": ", 1)[-1], MonitorParams, main)
