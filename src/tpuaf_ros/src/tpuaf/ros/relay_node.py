"""team_relay: team messages between the agents of a simulated fleet with loss and delay (thin
adapter of tpuaf.team.relay.RelayModel, the batch TeamBus model; see docs/FLEET.md).

Subscribes each agent's team topics /team_agents/<prefix>i/<topic> (its own broadcasts: the
message's robot_index is i), mirrors every message at once on /team/<topic> (monitor, bag), and
delivers it to the other agents' namespaces after ~delay seconds of ROS time, each recipient
losing it with probability ~loss (seeded). Deliveries are checked on every /clock message.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import rospy
from rosgraph_msgs.msg import Clock

from tpuaf.params import NodeParamError, parse, req
from tpuaf.ros.convert import ros_types
from tpuaf.ros.node import fatal, private_params, publish, run_node
from tpuaf.team.relay import RelayModel
from tpuaf.topics import CLOCK_TOPIC, DEFAULT_TEAM_NS, TEAM_TOPICS

NODE = "team_relay"
AGENTS_NS = "/team_agents"  # agent i's team namespace: AGENTS_NS/<robot_prefix>i


@dataclass
class RelayParams:
    """Private parameters of team_relay (units in the comments)."""

    robots: int = req(-1, "team size N")
    robot_prefix: str = "robot_"  # agent i's namespace is /team_agents/<robot_prefix>i
    delay: float = 0.0  # [s of ROS time] team message delay
    loss: float = 0.0  # loss probability per recipient
    seed: int = 0  # run seed (the loss stream is seeded with [seed, 1, 7])
    team_ns: str = DEFAULT_TEAM_NS  # where every message is mirrored unaltered


class RelayNode:
    def __init__(self, p: RelayParams):
        self.p = p
        self.lock = threading.Lock()
        self.model = RelayModel(p.robots, p.delay, p.loss, p.seed)
        self.deliver_pub: dict[tuple[int, str], rospy.Publisher] = {}
        self.mirror_pub: dict[str, rospy.Publisher] = {}
        for cls, ros_cls in ros_types().items():
            topic = TEAM_TOPICS[cls.__name__]
            self.mirror_pub[topic] = rospy.Publisher(f"{p.team_ns.rstrip('/')}/{topic}", ros_cls,
                                                     queue_size=1000)
            for i in range(p.robots):
                name = f"{AGENTS_NS}/{p.robot_prefix}{i}/{topic}"
                self.deliver_pub[(i, topic)] = rospy.Publisher(name, ros_cls, queue_size=1000)
                rospy.Subscriber(name, ros_cls, self.on_message, callback_args=(i, topic),
                                 queue_size=1000)
        rospy.Subscriber(CLOCK_TOPIC, Clock, self.on_clock, queue_size=10)

    def on_message(self, msg, where):
        owner, topic = where
        if msg.robot_index != owner:
            return  # a delivery to `owner` (ours), not its own broadcast
        publish(self.mirror_pub[topic], msg)
        with self.lock:
            self.model.submit(owner, (topic, msg), rospy.get_time())
            due = self.model.due(rospy.get_time()) if self.p.delay == 0 else []
        self.deliver(due)

    def on_clock(self, _msg):
        with self.lock:
            due = self.model.due(rospy.get_time())
        self.deliver(due)

    def deliver(self, due):
        for recipient, (topic, msg) in due:
            publish(self.deliver_pub[(recipient, topic)], msg)


def main() -> int:
    rospy.init_node(NODE)
    try:
        p = parse(RelayParams, private_params(), rospy.get_name())
        if p.robots < 1:
            raise NodeParamError(f"~robots must be >= 1, got {p.robots}")
        if not (p.delay >= 0):
            raise NodeParamError(f"~delay must be >= 0 s, got {p.delay}")
        if not 0 <= p.loss <= 1:
            raise NodeParamError(f"~loss must be in [0, 1], got {p.loss}")
        node = RelayNode(p)
    except NodeParamError as err:
        return fatal(err)
    rospy.loginfo(f"{NODE}: {p.robots} agents, delay {p.delay} s, loss {p.loss}")
    rospy.spin()
    s = node.model.stats
    rospy.loginfo(f"{NODE}: sent {s.sent}, delivered {s.delivered}, lost {s.lost}")
    return 0


def entry() -> int:
    return run_node(NODE, __doc__.splitlines()[0].split(": ", 1)[-1], RelayParams, main)
