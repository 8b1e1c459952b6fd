"""What every tpuaf rospy node shares: private parameters, `--help`, the one-line fatal error."""

from __future__ import annotations

import math
import sys
from collections.abc import Callable

from tpuaf.params import params_help


def private_params() -> dict:
    """This node's private parameters {name: value} (first level below ~)."""
    import rospy

    prefix = rospy.get_name() + "/"
    out = {}
    for name in rospy.get_param_names():
        if name.startswith(prefix):
            key = name[len(prefix):].split("/", 1)[0]
            out[key] = rospy.get_param("~" + key)
    return out


def yaw_of(q) -> float:
    """Yaw [rad] of a geometry_msgs/Quaternion."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def fatal(err: BaseException | str) -> int:
    """Log `err` as this node's one-line fatal error, naming the node once; returns exit code 2.

    Some messages name the node already (tpuaf.params.parse: "<node>: ~x must be ..."), most do
    not (MapError, the nodes' own checks): the node's name is added only when it is not there."""
    import rospy

    name = rospy.get_name()
    text = " ".join(str(err).split())  # one line
    if not text.startswith(f"{name}: "):
        text = f"{name}: {text}"
    rospy.logfatal(text)
    return 2


def sender_of(msg) -> str:
    """The node that published `msg` (its caller id, from rospy's connection header), '' when
    rospy does not say."""
    return getattr(msg, "_connection_header", None) and msg._connection_header.get(
        "callerid", "") or ""


def send_initial_pose(pose, map_frame: str):
    """Tell the localiser (amcl: `initialpose`, latched) where the robot starts: pose (x [m],
    y [m], yaw [rad]) in `map_frame`. Returns the publisher (keep it: the latch lives with it)."""
    import rospy
    from geometry_msgs.msg import PoseWithCovarianceStamped

    pub = rospy.Publisher("initialpose", PoseWithCovarianceStamped, queue_size=1, latch=True)
    msg = PoseWithCovarianceStamped()
    msg.header.frame_id = map_frame
    msg.header.stamp = rospy.Time.now()
    x, y, yaw = (float(v) for v in pose)
    msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
    msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    msg.pose.covariance[0] = msg.pose.covariance[7] = 0.25 ** 2
    msg.pose.covariance[35] = 0.2 ** 2
    publish(pub, msg)
    return pub


def publish(pub, msg) -> None:
    """pub.publish(msg); once the node shuts down (Ctrl-C while a callback or thread still
    runs) a publish to the closed topic is dropped quietly, not a traceback."""
    import rospy

    try:
        pub.publish(msg)
    except rospy.ROSException:
        if not (rospy.is_shutdown() or getattr(pub.impl, "closed", True)):
            raise


def run_node(name: str, summary: str, params_class: type, main: Callable[[], int]) -> int:
    """`--help` / `-h` prints the node's parameters (no master needed); otherwise `main()`.
    Ctrl-C before rospy takes over (loading the map) exits quietly (130)."""
    argv = [a for a in sys.argv[1:] if not a.startswith("__") and ":=" not in a]
    if "--help" in argv or "-h" in argv:
        print(f"{name}: {summary}\n\nPrivate parameters (~name, type, default, meaning):")
        print(params_help(params_class))
        return 0
    try:
        return int(main() or 0)
    except KeyboardInterrupt:
        return 130
