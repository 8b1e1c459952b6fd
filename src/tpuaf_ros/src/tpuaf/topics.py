"""ROS topic names and message ids shared by the nodes, `tpuaf fleet` and bag analysis.

Per-robot names are relative (resolved in the robot's namespace); global ones start with '/'.
Team topics live under the team namespace (agent parameter ~team_ns, default /team).
"""

from __future__ import annotations

# Team topics (relative to the team namespace) of each message type.
# Keyed by the name of the message class (tpuaf.team.messages), so that this module stays below
# the team layer.
TEAM_TOPICS: dict[str, str] = {
    "Visit": "visits",
    "Intention": "intentions",
    "IdlenessEstimate": "idleness",
    "TaskRequest": "task_requests",
    "TaskBid": "task_bids",
    "LaneClaim": "lane_claims",  # the lane layer's (docs/LANES.md), not handed to policies
}
DEFAULT_TEAM_NS = "/team"
EVENTS_TOPIC = "/fleet/agent_events"  # tpuaf_ros/AgentEvent of every agent
METRICS_TOPIC = "/fleet/metrics"  # tpuaf_ros/LiveMetrics of the monitor (1 Hz)
START_TOPIC = "/fleet/start"  # std_msgs/Float64, latched: ROS time [s] of the run start
CLOCK_TOPIC = "/clock"
# std_msgs/String, latched per agent: JSON {"robot": index, "by_reason": {reason: count}} of the
# team messages and events its inbox refused (tpuaf.team.inbox); the monitor's summary
REJECTIONS_TOPIC = "/fleet/agent_rejections"

# Per robot (relative).
CMD_VEL = "cmd_vel"  # geometry_msgs/Twist (hardware, teleop, rehearsal)
# geometry_msgs/TwistStamped: lock-step answer of an agent; header.stamp = the stamp of the odom
# tick it answers (the simulator advances once every live agent has answered the latest tick).
CMD_VEL_STAMPED = "cmd_vel_stamped"
# std_msgs/Int64MultiArray: an agent's team message counts in lock-step (tpuaf.team.lockstep):
# [stamp of the tick answered last in ns, team messages sent, received from robot 0..n-1].
LOCKSTEP_TEAM = "lockstep_team"
ODOM = "odom"
GROUND_TRUTH = "base_pose_ground_truth"
SCAN = "base_scan"
AMCL_POSE = "amcl_pose"
STALLED = "stalled"

# AgentEvent.event values (= the constants of AgentEvent.msg).
# REACHED: a visit (tpuaf_core.VisitRule); DWELL: a goal ended without one (docs/RUNTIMES.md).
# STUCK: a navigator recovery started; GIVE_WAY: a refuge driven to (robot health, issue 33).
# LANE_WAIT: a lane request not granted at once (stamped at the request); LANE_ENTER: granted
# after such a wait (docs/LANES.md; the monitor's lane waits and their seconds).
# VERTEX_CLOSED: a lost teammate's body cuts `vertex` off (robot/lanes.py): the recovery
# figures over the reachable vertices leave it out (measure/recovery.py).
START, GOAL, REACHED, FAILED, HEARTBEAT, DWELL, STUCK, GIVE_WAY = 0, 1, 2, 3, 4, 5, 6, 7
LANE_WAIT, LANE_ENTER, VERTEX_CLOSED = 8, 9, 10
EVENT_NAMES = {START: "START", GOAL: "GOAL", REACHED: "REACHED", FAILED: "FAILED",
               HEARTBEAT: "HEARTBEAT", DWELL: "DWELL", STUCK: "STUCK", GIVE_WAY: "GIVE_WAY",
               LANE_WAIT: "LANE_WAIT", LANE_ENTER: "LANE_ENTER", VERTEX_CLOSED: "VERTEX_CLOSED"}


def team_topic(team_ns: str, message_class: type) -> str:
    return f"{team_ns.rstrip('/')}/{TEAM_TOPICS[message_class.__name__]}"
