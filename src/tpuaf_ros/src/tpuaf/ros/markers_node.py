"""patrol_markers: RViz markers of a patrol (thin adapter of tpuaf.measure.markers, see docs/HARDWARE.md).

Subscribes the team's Visit and Intention messages (<team_ns>/visits, <team_ns>/intentions),
/fleet/agent_events (GOAL events: each robot's goal) and the robots' poses (~pose_source:
tf map -> <robot_prefix><i>/base_footprint, ground_truth, odom or amcl_pose). Publishes
~markers (visualization_msgs/MarkerArray, in ~map_frame) at ~rate Hz: the patrol graph, its
vertices coloured by idleness or uncertainty (~color_by), each robot's footprint, heading, goal
and announced intention. Works on the wall clock and on sim time.
Private parameters: MarkersParams below (strict; `patrol_markers --help`).
"""

import math
import threading
import warnings
from dataclasses import dataclass

import rospy
from geometry_msgs.msg import Point, PoseWithCovarianceStamped
from nav_msgs.msg import OccupancyGrid, Odometry
from std_msgs.msg import ColorRGBA
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import Marker as RosMarker
from visualization_msgs.msg import MarkerArray

from tpuaf.errors import MapError
from tpuaf.maps import load_map
from tpuaf.measure.markers import MODES, Marker, PatrolView
from tpuaf.measure.poses import POSE_SOURCES, feed_chains, robot_chains
from tpuaf.params import NodeParamError, opt, parse, req
from tpuaf.ros import convert
from tpuaf.ros.node import fatal, private_params, publish, run_node, yaw_of
from tpuaf.team import messages
from tpuaf.topics import (
    AMCL_POSE,
    EVENTS_TOPIC,
    GOAL,
    GROUND_TRUTH,
    METRICS_TOPIC,
    ODOM,
    REACHED,
    team_topic,
)
from tpuaf_ros.msg import AgentEvent, Intention, LiveMetrics, Visit

NODE = "patrol_markers"
warnings.filterwarnings("ignore", message="The publisher should be created with an explicit")
KINDS = {"line_list": RosMarker.LINE_LIST, "sphere_list": RosMarker.SPHERE_LIST,
         "cylinder": RosMarker.CYLINDER, "arrow": RosMarker.ARROW,
         "line_strip": RosMarker.LINE_STRIP, "text": RosMarker.TEXT_VIEW_FACING}


@dataclass
class MarkersParams:
    """Private parameters of patrol_markers (units in the comments)."""

    map: str = req("", "patrol map name or path")
    map_params: dict = opt({}, dict)  # overrides of the map's settings {key: value}, e.g. {sensing_radius: 2.0} (tpuaf.maps.params; {} = the map's)
    robots: int = req(-1, "team size N")
    robot_prefix: str = "robot_"  # robot i is <robot_prefix><i> (namespace and tf prefix)
    team_ns: str = "/team"  # namespace of the team topics
    pose_source: str = "tf"  # tf | ground_truth | odom | amcl
    map_frame: str = "map"  # frame of the markers and root of the tf chains
    base_frame: str = "base_footprint"  # tf: robot i's frame is <robot_prefix><i>/<base_frame>
    color_by: str = "idleness"  # idleness | uncertainty
    idleness_scale: float = 0.0  # [s] idleness drawn red; 0 = from the graph and team size
    rate: float = 2.0  # [Hz] marker updates
    publish_map: bool = True  # the map's occupancy grid on ~map (latched), for RViz's Map display


class MarkersNode:
    def __init__(self, p, patrol_map):
        self.p = p
        self.map = patrol_map
        self.lock = threading.Lock()
        self.view = PatrolView(patrol_map, p.robots, mode=p.color_by,
                               idleness_scale_s=p.idleness_scale, start_time=rospy.get_time())
        self.names = [f"{p.robot_prefix}{i}" for i in range(p.robots)]
        self.pub = rospy.Publisher("~markers", MarkerArray, queue_size=2)
        rospy.Subscriber(team_topic(p.team_ns, messages.Visit), Visit, self.on_visit,
                         queue_size=100)
        rospy.Subscriber(team_topic(p.team_ns, messages.Intention), Intention,
                         self.on_intention, queue_size=100)
        rospy.Subscriber(EVENTS_TOPIC, AgentEvent, self.on_event, queue_size=200)
        rospy.Subscriber(METRICS_TOPIC, LiveMetrics, self.on_metrics, queue_size=10)
        if p.pose_source == "tf":
            self.chains = robot_chains(self.names, p.map_frame, p.base_frame)
            rospy.Subscriber("/tf", TFMessage, self.on_tf, queue_size=50)
            rospy.Subscriber("/tf_static", TFMessage, self.on_tf, queue_size=10)
        else:
            topic, cls = {"ground_truth": (GROUND_TRUTH, Odometry), "odom": (ODOM, Odometry),
                          "amcl": (AMCL_POSE, PoseWithCovarianceStamped)}[p.pose_source]
            for i, name in enumerate(self.names):
                rospy.Subscriber(f"/{name}/{topic}", cls, self.on_pose, callback_args=i,
                                 queue_size=2)
        if p.publish_map:
            self.map_pub = rospy.Publisher("~map", OccupancyGrid, queue_size=1, latch=True)
            publish(self.map_pub, occupancy_msg(patrol_map.occupancy_grid(), p.map_frame))
        self.timer = rospy.Timer(rospy.Duration(1.0 / p.rate), self.publish)

    def on_visit(self, msg):
        v = self.map.lookup_index(msg.vertex)
        if v is not None and v >= 0:
            with self.lock:
                self.view.on_visit(msg.robot_index, v, convert.stamp_s(msg))

    def on_intention(self, msg):
        a, b = self.map.lookup_index(msg.from_vertex), self.map.lookup_index(msg.vertex)
        if a is not None and b is not None:
            with self.lock:
                self.view.on_intention(msg.robot_index, a, b)

    def on_metrics(self, msg):
        with self.lock:
            for r, stuck in enumerate(msg.no_progress):
                self.view.on_health(r, stuck)

    def on_event(self, msg):
        v = self.map.lookup_index(msg.vertex)
        if v is None:
            return
        with self.lock:
            if msg.event == GOAL:
                self.view.on_goal(msg.robot_index, v)
            elif msg.event == REACHED and v >= 0:
                self.view.on_visit(msg.robot_index, v, convert.stamp_s(msg))

    def on_pose(self, msg, i):
        pose = msg.pose.pose
        with self.lock:
            self.view.on_pose(i, msg.header.stamp.to_sec(), pose.position.x, pose.position.y,
                              yaw_of(pose.orientation))

    def on_tf(self, msg):
        with self.lock:
            for r in feed_chains(self.chains, msg.transforms):
                pose = self.chains[r].pose()
                if pose is not None:
                    self.view.on_pose(r, pose[3], pose[0], pose[1], pose[2])

    def publish(self, _event=None):
        now = rospy.Time.now()
        with self.lock:
            markers = self.view.markers(now.to_sec())
        out = MarkerArray()
        out.markers = [to_ros(m, self.p.map_frame, now) for m in markers]
        publish(self.pub, out)


def occupancy_msg(grid, frame: str) -> OccupancyGrid:
    """nav_msgs/OccupancyGrid of a tpuaf occupancy grid (same layout: row 0 at the bottom)."""
    out = OccupancyGrid()
    out.header.frame_id = frame
    out.header.stamp = rospy.Time.now()
    out.info.resolution = float(grid.resolution)
    out.info.width, out.info.height = int(grid.width), int(grid.height)
    out.info.origin.position.x, out.info.origin.position.y = map(float, grid.origin)
    out.info.origin.orientation.w = 1.0
    out.data = (grid.occupied.astype("int8") * 100).ravel().tolist()
    return out


def _colour(c):
    return ColorRGBA(float(c[0]), float(c[1]), float(c[2]), float(c[3]))


def to_ros(m: Marker, frame: str, stamp) -> RosMarker:
    out = RosMarker()
    out.header.frame_id = frame
    out.header.stamp = stamp
    out.ns, out.id, out.type = m.ns, int(m.id), KINDS[m.kind]
    out.action = RosMarker.ADD
    x, y, z, yaw = m.pose
    out.pose.position.x, out.pose.position.y, out.pose.position.z = x, y, z
    out.pose.orientation.z, out.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    out.scale.x, out.scale.y, out.scale.z = m.scale
    out.color = _colour(m.color)
    out.points = [Point(float(a), float(b), float(c)) for a, b, c in m.points]
    out.colors = [_colour(c) for c in m.colors]
    out.text = m.text
    out.lifetime = rospy.Duration(5.0)  # a marker no longer sent fades out
    out.frame_locked = False
    return out


def main():
    rospy.init_node(NODE)
    try:
        p = parse(MarkersParams, private_params(), rospy.get_name())
        if p.pose_source not in POSE_SOURCES:
            raise NodeParamError("~pose_source must be one of "
                                 f"{', '.join(POSE_SOURCES)}, got {p.pose_source!r}")
        if p.color_by not in MODES:
            raise NodeParamError("~color_by must be one of "
                                 f"{', '.join(MODES)}, got {p.color_by!r}")
        if p.robots < 1 or not p.rate > 0 or p.idleness_scale < 0:
            raise NodeParamError("~robots >= 1, ~rate > 0 and "
                                 f"~idleness_scale >= 0 needed, got {p.robots}, {p.rate:g}, "
                                 f"{p.idleness_scale:g}")
        patrol_map = load_map(p.map, params=p.map_params, params_origin="~map_params")
        MarkersNode(p, patrol_map)
    except (NodeParamError, MapError, OSError) as err:
        return fatal(err)
    rospy.spin()
    return 0


def entry() -> int:
    return run_node(NODE, __doc__.splitlines()[0].split(": ", 1)[-1], MarkersParams, main)

