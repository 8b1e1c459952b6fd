"""tpuaf.team.messages <-> tpuaf_ros.msg, vertex index <-> map vertex id, run time <-> ROS stamp.

Run time t [s] is ROS time minus the run's epoch (0 with simulated time; on hardware the epoch
shared by the team, see docs/FLEET.md), so the policies see the same clock as in batch.
"""

from __future__ import annotations

from typing import Any

from tpuaf.maps import MapError
from tpuaf.team import messages as m
from tpuaf.topics import EVENTS_TOPIC, METRICS_TOPIC, TEAM_TOPICS  # noqa: F401 - re-exported


class MalformedMessage(ValueError):
    """A team message that cannot be converted (unknown vertex id, wrong lengths)."""


def ros_types() -> dict[type, type]:
    """tpuaf message class -> generated ROS message class."""
    from tpuaf_ros import msg

    return {
        m.Visit: msg.Visit,
        m.Intention: msg.Intention,
        m.IdlenessEstimate: msg.IdlenessEstimate,
        m.TaskRequest: msg.TaskRequest,
        m.TaskBid: msg.TaskBid,
        m.LaneClaim: msg.LaneClaim,
    }


def stamp(t: float, epoch: float = 0.0):
    import genpy

    return genpy.Time.from_sec(max(0.0, float(t) + epoch))


def stamp_s(ros_msg: Any) -> float:
    """[s] ROS time of a tpuaf_ros message: its std_msgs/Header stamp (messages version 2) or
    its bare `stamp` (version 1 bags); genpy or rosbags time."""
    st = ros_msg.header.stamp if hasattr(ros_msg, "header") else ros_msg.stamp
    if hasattr(st, "to_sec"):
        return st.to_sec()
    return st.sec + st.nanosec * 1e-9


def run_start_message(epoch_s: float, announcer: str, team: list[str]):
    """tpuaf_ros/RunStart: the run's epoch [s of ROS time], who announced it, the team."""
    from tpuaf_ros.msg import RunStart

    out = RunStart()
    out.header.stamp = stamp(epoch_s)
    out.announcer = announcer
    out.robots = len(team)
    out.team = list(team)
    return out


def rejections_message(robot: int, by_reason: dict[str, int]):
    """std_msgs/String of an agent's refusal counts (tpuaf.topics.REJECTIONS_TOPIC)."""
    import json

    from std_msgs.msg import String

    return String(data=json.dumps({"robot": int(robot), "by_reason": dict(by_reason)}))


def parse_rejections(text: str) -> tuple[int, dict[str, int]] | None:
    """(robot, {reason: count}) of a rejections_message text; None when it is not one."""
    import json

    try:
        data = json.loads(text)
        robot = int(data["robot"])
        counts = {str(k): int(v) for k, v in data["by_reason"].items()}
    except (ValueError, TypeError, KeyError, AttributeError):
        return None
    return (robot, counts) if all(v >= 0 for v in counts.values()) else None


class Converter:
    """Converts team messages for one map and robot naming (`prefix` + index)."""

    def __init__(self, patrol_map: Any, prefix: str = "robot_", epoch: float = 0.0):
        self.patrol_map = patrol_map
        self.ids = [int(v) for v in patrol_map.vertex_ids]
        self.prefix = prefix
        self.epoch = float(epoch)
        self.types = ros_types()

    def vid(self, index: int) -> int:
        return -1 if index < 0 else self.ids[index]

    def index(self, vertex_id: int) -> int:
        return -1 if vertex_id < 0 else self.patrol_map.index_of(vertex_id)

    def time(self, ros_msg) -> float:
        """Run time [s] of a message's stamp."""
        return stamp_s(ros_msg) - self.epoch

    def to_ros(self, message: Any):
        cls = self.types[type(message)]
        out = cls()
        out.robot = f"{self.prefix}{message.robot}"
        out.robot_index = int(message.robot)
        out.header.stamp = stamp(message.time, self.epoch)
        if isinstance(message, m.Visit):
            out.vertex, out.next_vertex = self.vid(message.vertex), self.vid(message.next_vertex)
        elif isinstance(message, m.Intention):
            out.from_vertex, out.vertex = self.vid(message.from_vertex), self.vid(message.vertex)
            out.expected_arrival = float(message.expected_arrival)
            out.travel_time = float(message.travel_time)
        elif isinstance(message, m.IdlenessEstimate):
            out.vertices = self.ids
            out.idleness = [float(x) for x in message.estimate]
            out.next_vertex = self.vid(message.next_vertex)
        elif isinstance(message, m.LaneClaim):  # a lane index, not a vertex
            out.lane, out.held = int(message.lane), bool(message.held)
            out.request_time = float(message.stamp)
            out.leg_from, out.leg_to = self.vid(message.leg[0]), self.vid(message.leg[1])
            out.x, out.y = float(message.position[0]), float(message.position[1])
        else:  # TaskRequest, TaskBid
            out.vertex, out.bid = self.vid(message.vertex), float(message.bid)
        return out

    def from_ros(self, ros_msg: Any) -> Any:
        """The tpuaf message of a ROS team message (type chosen by the ROS class name); a
        vertex id not on the map or an estimate of the wrong length is a MalformedMessage."""
        try:
            return self._from_ros(ros_msg)
        except (MapError, ValueError, IndexError) as err:
            raise MalformedMessage(str(err)) from None

    def _from_ros(self, ros_msg: Any) -> Any:
        kind = type(ros_msg).__name__.rsplit("_", 1)[-1]  # rosbags names: tpuaf_ros__msg__Visit
        t = self.time(ros_msg)
        r = int(ros_msg.robot_index)
        if kind == "Visit":
            return m.Visit(r, self.index(ros_msg.vertex), t, self.index(ros_msg.next_vertex))
        if kind == "Intention":
            return m.Intention(r, self.index(ros_msg.from_vertex), self.index(ros_msg.vertex),
                               float(ros_msg.expected_arrival), float(ros_msg.travel_time), t)
        if kind == "IdlenessEstimate":
            if len(ros_msg.vertices) != len(self.ids):
                raise ValueError(f"estimate of {len(ros_msg.vertices)} vertices (map has "
                                 f"{len(self.ids)})")
            est = [0.0] * len(self.ids)
            for vid, value in zip(ros_msg.vertices, ros_msg.idleness, strict=True):
                est[self.index(int(vid))] = float(value)
            return m.IdlenessEstimate(r, t, tuple(est), self.index(ros_msg.next_vertex))
        if kind == "TaskRequest":
            return m.TaskRequest(r, self.index(ros_msg.vertex), float(ros_msg.bid), t)
        if kind == "TaskBid":
            return m.TaskBid(r, self.index(ros_msg.vertex), float(ros_msg.bid), t)
        if kind == "LaneClaim":
            return m.LaneClaim(r, int(ros_msg.lane), float(ros_msg.request_time),
                               bool(ros_msg.held), t,
                               (self.index(ros_msg.leg_from), self.index(ros_msg.leg_to)),
                               (float(ros_msg.x), float(ros_msg.y)))
        raise TypeError(f"not a team message: {type(ros_msg).__name__}")
