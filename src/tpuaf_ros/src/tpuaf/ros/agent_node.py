"""patrol_agent: one robot's strategy and navigator on ROS 1 (thin adapter, see docs/FLEET.md).

In the robot's namespace: subscribes base_scan (sensor_msgs/LaserScan), its pose from
base_pose_ground_truth or odom (nav_msgs/Odometry) or amcl_pose
(geometry_msgs/PoseWithCovarianceStamped), the team topics (/team/*, typed tpuaf_ros messages)
and /fleet/start; publishes cmd_vel (one per pose message), team messages on events and
AgentEvent on /fleet/agent_events. Private parameters: tpuaf.params.AgentParams (strict).
"""

import math
import threading
import warnings

import rospy
from geometry_msgs.msg import PoseWithCovarianceStamped, Twist
from nav_msgs.msg import Odometry
from rospy.numpy_msg import numpy_msg
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Float64

from tpuaf_ros.msg import AgentEvent

from ..maps import MapError, load_map, start_vertices
from ..navigation import ControllerConfig, Scan, scan_points
from ..params import AgentParams, NodeParamError, parse
from ..policies import REGISTRY, ParameterError
from ..runtimes.agent import AgentRuntime
from . import convert
from .node import private_params, run_node, yaw_of

NODE = "patrol_agent"
warnings.filterwarnings("ignore", message="The publisher should be created with an explicit")


class AgentNode:
    def __init__(self, p, patrol_map):
        self.p = p
        self.lock = threading.Lock()
        sim = bool(rospy.get_param("/use_sim_time", False))
        epoch = p.epoch
        if epoch < 0:
            if sim:
                epoch = 0.0
            else:  # hardware: the team shares /tpuaf/epoch (the first agent sets it)
                if not rospy.has_param("/tpuaf/epoch"):
                    rospy.set_param("/tpuaf/epoch", math.floor(rospy.get_time()))
                epoch = float(rospy.get_param("/tpuaf/epoch"))
        self.epoch = epoch
        ns = rospy.get_namespace().strip("/")
        name = p.robot_name or ns or f"robot_{p.robot_index}"
        prefix = name[: -len(str(p.robot_index))] if name.endswith(str(p.robot_index)) else name + "_"
        self.conv = convert.Converter(patrol_map, prefix=prefix, epoch=epoch)
        self.name = name
        s = patrol_map.settings
        cfg = ControllerConfig(
            max_linear_speed=p.max_linear_speed or s.nominal_speed,
            max_angular_speed=p.max_angular_speed,
            robot_radius=p.robot_radius or s.robot_radius,
            safety_margin=p.safety_margin, plan_margin=p.plan_margin,
            stuck_timeout_s=p.stuck_timeout, backoff_s=p.backoff_time, max_retries=p.max_retries,
            retry_wait_s=0.5 + 0.5 * (p.robot_index % 4),  # staggered: breaks symmetric deadlocks
        )
        policy = REGISTRY.create(p.strategy, p.strategy_params)
        # Publishers.
        self.cmd_pub = rospy.Publisher("cmd_vel", Twist, queue_size=None, tcp_nodelay=True)
        self.event_pub = rospy.Publisher(convert.EVENTS_TOPIC, AgentEvent, queue_size=None)
        self.team_pub = {}
        for cls, ros_cls in self.conv.types.items():
            topic = f"{p.team_ns.rstrip('/')}/{convert.TEAM_TOPICS[cls]}"
            self.team_pub[cls] = rospy.Publisher(topic, ros_cls, queue_size=None)
        self.cmd = Twist()
        self.event = AgentEvent()
        self.event.robot = name
        self.event.robot_index = p.robot_index
        self.runtime = AgentRuntime(patrol_map, policy, p.robot_index, p.robots, p.seed,
                                    self.publish_team, self.publish_event, cfg,
                                    p.heartbeat_period, p.waypoint_tolerance)
        if p.wait_for_start:
            self.runtime.start_at = None
        self.points = None
        self._scan = None
        self.origin = None
        if p.localization == "odom":
            if p.initial_pose:
                if len(p.initial_pose) != 3:
                    raise NodeParamError(f"~initial_pose must be [x, y, yaw], got {p.initial_pose}")
                self.origin = tuple(float(v) for v in p.initial_pose)
            else:
                v = start_vertices(patrol_map, p.robots)[p.robot_index]
                self.origin = (*map(float, patrol_map.positions[v]), 0.0)
        # Subscribers.
        for cls, ros_cls in self.conv.types.items():
            topic = f"{p.team_ns.rstrip('/')}/{convert.TEAM_TOPICS[cls]}"
            rospy.Subscriber(topic, ros_cls, self.on_team, queue_size=200)
        rospy.Subscriber("/fleet/start", Float64, self.on_start, queue_size=1)
        rospy.Subscriber("base_scan", numpy_msg(LaserScan), self.on_scan, queue_size=1,
                         tcp_nodelay=True)
        if p.localization == "ground_truth":
            rospy.Subscriber("base_pose_ground_truth", Odometry, self.on_odom, queue_size=1,
                             tcp_nodelay=True)
        elif p.localization == "odom":
            rospy.Subscriber("odom", Odometry, self.on_odom, queue_size=1, tcp_nodelay=True)
        elif p.localization == "amcl":
            rospy.Subscriber("amcl_pose", PoseWithCovarianceStamped, self.on_amcl, queue_size=1)
            # amcl publishes on change only: control runs on the scans then.
        else:
            raise NodeParamError(f"~localization must be ground_truth, odom or amcl, got "
                                 f"{p.localization!r}")
        self.control_on_scan = p.localization == "amcl"

    # --- outputs ---
    def publish_team(self, message):
        self.team_pub[type(message)].publish(self.conv.to_ros(message))

    def publish_event(self, kind, vertex, from_vertex, t):
        e = self.event
        e.stamp = convert.stamp(t, self.epoch)
        e.event = kind
        e.vertex = self.conv.vid(vertex)
        e.from_vertex = self.conv.vid(from_vertex)
        self.event_pub.publish(e)

    # --- inputs ---
    def on_start(self, msg):
        with self.lock:
            self.runtime.start_at = msg.data - self.epoch

    def on_team(self, msg):
        if msg.robot_index == self.p.robot_index:
            return  # our own broadcast
        with self.lock:
            self.runtime.on_message(self.conv.from_ros(msg))

    def on_scan(self, msg):
        with self.lock:
            self._scan = msg
            self.points = None
            if self.control_on_scan:
                self.control(msg.header.stamp.to_sec() - self.epoch)

    def on_odom(self, msg):
        pose = msg.pose.pose
        x, y, th = pose.position.x, pose.position.y, yaw_of(pose.orientation)
        if self.origin is not None:  # odom frame -> map frame
            ox, oy, oth = self.origin
            c, s = math.cos(oth), math.sin(oth)
            x, y, th = ox + c * x - s * y, oy + s * x + c * y, th + oth
        t = msg.header.stamp.to_sec() - self.epoch
        with self.lock:
            self.runtime.on_pose(t, x, y, th)
            self.control(t)

    def on_amcl(self, msg):
        pose = msg.pose.pose
        with self.lock:
            self.runtime.on_pose(msg.header.stamp.to_sec() - self.epoch, pose.position.x,
                                 pose.position.y, yaw_of(pose.orientation))

    def control(self, t):
        if self.points is None and self._scan is not None:
            s = self._scan
            self.points = scan_points(Scan(s.ranges, s.angle_min, s.angle_increment,
                                           s.range_min, s.range_max))
        v, w = self.runtime.tick(t, self.points)
        self.cmd.linear.x, self.cmd.angular.z = v, w
        self.cmd_pub.publish(self.cmd)


def main():
    rospy.init_node(NODE)
    try:
        p = parse(AgentParams, private_params(), rospy.get_name())
        patrol_map = load_map(p.map)
        if not 0 <= p.robot_index < p.robots:
            raise NodeParamError(f"~robot_index {p.robot_index} not in 0..{p.robots - 1}")
        node = AgentNode(p, patrol_map)
    except (NodeParamError, MapError, ParameterError, KeyError) as err:
        rospy.logfatal(f"{rospy.get_name()}: {err}")
        return 2
    rospy.loginfo(f"{rospy.get_name()}: {p.strategy} robot {p.robot_index}/{p.robots} on "
                  f"{patrol_map.name}, localisation {p.localization}, epoch {node.epoch}")
    rospy.spin()
    return 0


def entry() -> int:
    return run_node(NODE, __doc__.splitlines()[0].split(": ", 1)[-1], AgentParams, main)
