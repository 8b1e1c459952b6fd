"""What a bag holds for an analysis (`inspect(path)` -> BagInfo): its span on the messages'
clock, its robots and their names, the run starts on /fleet/start, the monitor's last metrics,
the visit reports (agent events, Visit team messages), the team topics and the pose sources of
every robot (ground truth, tf, amcl, odom). Read with tpuaf.measure.bag_decode; analysed by
tpuaf.measure.bag.
"""

from __future__ import annotations

import math
import re
import statistics
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tpuaf.measure.bag_decode import (
    NS,
    BagError,
    guarded,
    is_type,
    open_bag,
    raw_readers,
    read_messages,
    stamp_of,
    typestore,
)
from tpuaf.measure.poses import POSE_SOURCES, feed_chains, robot_chains
from tpuaf.team import messages as team_messages
from tpuaf.team.epoch import RunEpoch
from tpuaf.topics import (
    AMCL_POSE,
    EVENTS_TOPIC,
    GROUND_TRUTH,
    METRICS_TOPIC,
    ODOM,
    REACHED,
    START,
    START_TOPIC,
    TEAM_TOPICS,
)

# /<robot name>/<kind>: a robot's pose topics; a name ends in its index (robot_0, tb3_1).
POSE_TOPIC = re.compile(
    rf"^/(?P<name>(?P<prefix>[^/]*?)(?P<index>\d+))/(?P<kind>{GROUND_TRUTH}|{AMCL_POSE}|{ODOM})$")
POSE_KIND = {GROUND_TRUTH: "ground_truth", AMCL_POSE: "amcl", ODOM: "odom"}
TF_TOPICS = ("/tf", "/tf_static")
# /fleet/start: tpuaf_ros/RunStart (messages version 2), std_msgs/Float64 in version 1 bags.
FLEET_TYPES = {(START_TOPIC, "tpuaf_ros/RunStart"), (START_TOPIC, "std_msgs/Float64"),
               (METRICS_TOPIC, "tpuaf_ros/LiveMetrics"), (EVENTS_TOPIC, "tpuaf_ros/AgentEvent")}
# [s] run starts closer than this are one start (re-latched copies of it)
SAME_START_S = 1e-3
MAP_FRAME = "map"
BASE_FRAME = "base_footprint"
# Team topic basename -> message kind (the team namespace may differ from /team).
TEAM_BASENAMES = {name: class_name for class_name, name in TEAM_TOPICS.items()}
VISITS_BASENAME = TEAM_TOPICS[team_messages.Visit.__name__]
# [s] messages stamped this far outside the bag's span are ignored (garbled or foreign stamps).
STAMP_MARGIN_S = 5.0
# [s] a record-time/stamp offset larger than this is a recorder on another clock.
CLOCK_OFFSET_S = 5.0
# [s] a connection whose messages lag the bag's clock more than this is on another clock: its
# lag does not widen the replay's reorder window
MAX_LATENESS_S = 600.0


@dataclass
class BagInfo:
    """What a bag holds for an analysis (inspect); `out_of_span` is counted by the analysis."""

    path: Path
    start_s: float  # bag span on the messages' clock [s]
    end_s: float
    topics: dict[str, int] = field(default_factory=dict)  # topic -> message count
    types: dict[str, str] = field(default_factory=dict)  # topic -> message type
    robots: int = 0  # robots seen (max index + 1)
    names: dict[int, str] = field(default_factory=dict)  # robot index -> name (robot_0)
    prefix: str = "robot_"
    fleet_start_s: float | None = None  # the run's start: the earliest in the span [s]
    fleet_starts: list[tuple[float, str]] = field(default_factory=list)  # every distinct
    # start on /fleet/start, (epoch [s], announcer), in time order
    ignored_starts: int = 0  # later starts not adopted (tpuaf.team.epoch: one start per run)
    # [s] without a start on /fleet/start: the first START event (else the first agent event or
    # team message) stamped in the bag, the analysis' documented fallback start
    first_report_s: float | None = None
    fleet_duration_s: float | None = None  # /fleet/metrics duration [s]
    monitor_finished: bool = False
    monitor_final: dict | None = None
    clock_offset_s: float = 0.0  # record time - stamp [s], when the recorder's clock differs
    # [s] how much later than usual (the median record time - stamp) an agent event or team
    # message was recorded, at most: the replay's reorder window covers it
    max_lateness_s: float = 0.0
    events: int = 0  # AgentEvent messages
    visit_events: int = 0  # START (with a vertex) and REACHED events: the visits reported
    visit_messages: int = 0  # Visit team messages
    team_topics: dict[str, str] = field(default_factory=dict)  # topic -> Visit, Intention...
    pose_topics: dict[str, dict[int, str]] = field(default_factory=dict)  # source -> i -> topic
    tf_robots: set[int] = field(default_factory=set)  # robots whose tf chain reaches map
    out_of_span: int = 0  # messages of an analysis ignored: stamped outside the bag's span

    @property
    def span_s(self) -> float:
        return self.end_s - self.start_s

    @property
    def start_time(self) -> float | None:  # the monitored run's start (compatibility)
        return self.fleet_start_s

    @property
    def duration(self) -> float | None:
        return self.fleet_duration_s

    def pose_sources(self, n: int) -> list[str]:
        """Sources (best first) that give every robot 0..n-1 a pose."""
        out = []
        for source in POSE_SOURCES:
            have = self.tf_robots if source == "tf" else set(self.pose_topics.get(source, {}))
            if n and all(i in have for i in range(n)):
                out.append(source)
        return out


def is_visit(kind: int, vertex: int) -> bool:
    """START (the start vertex's first visit) and REACHED are the agents' visit reports."""
    return kind in (START, REACHED) and vertex >= 0


def _team_kind(topic: str) -> str | None:
    base = topic.rsplit("/", 1)[-1]
    return TEAM_BASENAMES.get(base) if topic.count("/") >= 2 else None


@guarded
def inspect(path: str | Path) -> BagInfo:
    """What the bag holds for an analysis: its span, robots, team and pose topics (one pass
    over the small topics, and over /tf until every robot's chain to map is known)."""

    path = Path(path)
    with open_bag(path) as reader:
        return inspect_reader(path, reader)


def inspect_reader(path: Path, reader: Any) -> BagInfo:
    """inspect() of a bag open in `reader`."""
    store = typestore(reader)
    if reader.message_count == 0:
        raise BagError(f"{path}: the bag holds no messages")
    info = BagInfo(path, reader.start_time * NS, reader.end_time * NS)
    small, tf_conns = [], []
    for conn in reader.connections:
        info.topics[conn.topic] = info.topics.get(conn.topic, 0) + conn.msgcount
        info.types[conn.topic] = conn.msgtype
        m = POSE_TOPIC.match(conn.topic)
        if m:
            kind = POSE_KIND[m["kind"]]
            if is_type(conn, "geometry_msgs/PoseWithCovarianceStamped" if kind == "amcl"
                        else "nav_msgs/Odometry"):
                info.pose_topics.setdefault(kind, {})[int(m["index"])] = conn.topic
                info.names.setdefault(int(m["index"]), m["name"])
        elif conn.topic in TF_TOPICS and is_type(conn, "tf2_msgs/TFMessage"):
            tf_conns.append(conn)
        elif (conn.topic, conn.msgtype.replace("/msg/", "/")) in FLEET_TYPES:
            small.append(conn)
        elif _team_kind(conn.topic) and conn.msgtype.startswith("tpuaf_ros/"):
            info.team_topics[conn.topic] = _team_kind(conn.topic)
            small.append(conn)
    # (connection, robot) -> record time - stamp [s] of its first 200 messages, and the largest
    offsets: dict[tuple[int, int], list[float]] = {}
    latest: dict[tuple[int, int], float] = {}
    starts: list[float] = []  # in record order
    first_start, first_any = math.inf, math.inf
    for conn, t_rec, msg in read_messages(path, reader, store, small, raw_readers(small)):
        if conn.topic == START_TOPIC:
            starts.append(_add_start(info, msg))
        elif conn.topic == METRICS_TOPIC:
            info.fleet_duration_s = float(msg.duration)
            if msg.finished:
                info.monitor_finished = True
                info.monitor_final = {k: getattr(msg, k) for k in (
                    "elapsed", "visits", "idleness_avg", "interferences", "robots_alive")}
        else:  # agent events and team messages: robots, names, clock
            r = int(msg.robot_index)
            if 0 <= r < 10_000:
                info.robots = max(info.robots, r + 1)
                if msg.robot:
                    info.names.setdefault(r, str(msg.robot).strip("/"))
            t = stamp_of(msg)
            if math.isfinite(t):
                first_any = min(first_any, t)
            if conn.topic == EVENTS_TOPIC:
                info.events += 1
                info.visit_events += is_visit(int(msg.event), int(msg.vertex))
                if int(msg.event) == START and math.isfinite(t):
                    first_start = min(first_start, t)
            elif info.team_topics[conn.topic] == "Visit":
                info.visit_messages += 1
            if math.isfinite(t):
                key = (conn.id, r)
                lag = offsets.setdefault(key, [])
                if len(lag) < 200:
                    lag.append(t_rec - t)
                latest[key] = max(latest.get(key, -math.inf), t_rec - t)
    if info.pose_topics:
        info.robots = max(info.robots, max(max(d) for d in info.pose_topics.values()) + 1)
    _clock_and_start(info, offsets, latest, starts)
    first = first_start if math.isfinite(first_start) else first_any
    info.first_report_s = first if math.isfinite(first) else None
    names = {r: info.names.get(r, f"{_prefix(info)}{r}") for r in range(info.robots)}
    info.prefix = _prefix(info)
    if tf_conns and names:
        chains = robot_chains([names[r] for r in range(info.robots)], MAP_FRAME, BASE_FRAME)
        for _conn, _t, msg in read_messages(path, reader, store, tf_conns):
            for r in feed_chains(chains, msg.transforms):
                if chains[r].pose() is not None:
                    info.tf_robots.add(r)
            if len(info.tf_robots) == len(chains):
                break
    return info


def _clock_and_start(info: BagInfo, offsets: dict, latest: dict, starts: list) -> None:
    """The bag's clock offset and reorder lateness (from the report messages' record time -
    stamp per (connection, robot)), then the run's one start (the agents' rule, record order)."""
    if offsets:
        offset = clock_offset(offsets)
        info.max_lateness_s = max([0.0, *(x - offset for x in latest.values()
                                         if x - offset <= MAX_LATENESS_S)])
        if abs(offset) > CLOCK_OFFSET_S:  # e.g. recorded without use_sim_time
            info.clock_offset_s = offset
            info.start_s -= offset
            info.end_s -= offset
    epoch = RunEpoch()
    for s in starts:
        if s is not None and info.start_s - STAMP_MARGIN_S <= s < info.end_s:
            epoch.offer(s)
    info.fleet_start_s = epoch.epoch_s
    info.ignored_starts = max(0, len(info.fleet_starts) - 1)


def clock_offset(offsets: dict[tuple[int, int], list[float]]) -> float:
    """[s] record time - stamp of the bag's clock: the median of each connection's messages of
    one robot, then the one most others agree with (within CLOCK_OFFSET_S; ties: the smallest,
    as a late robot's all lag). A node stamping on another clock (a rogue, a node started
    before use_sim_time was set) cannot move it unless it holds most of them."""
    medians = sorted(statistics.median(v) for v in offsets.values() if v)
    return max(medians, key=lambda c: (sum(abs(c - d) <= CLOCK_OFFSET_S for d in medians), -c))


def _add_start(info: BagInfo, msg: Any) -> None:
    """A run start on /fleet/start: RunStart (its header stamp) or, version 1, Float64."""
    if hasattr(msg, "data"):
        start, announcer = float(msg.data), ""
    else:
        start, announcer = stamp_of(msg), str(msg.announcer)
    if not math.isfinite(start):
        return None
    if all(abs(start - s) > SAME_START_S for s, _ in info.fleet_starts):
        info.fleet_starts.append((start, announcer))
        info.fleet_starts.sort()
    return start


def _prefix(info: BagInfo) -> str:
    """The robots' name prefix (robot_ of robot_0, tb3_ of tb3_1)."""
    for name in info.names.values():
        m = re.match(r"^(.*?)\d+$", name)
        if m:
            return m.group(1)
    return "robot_"
