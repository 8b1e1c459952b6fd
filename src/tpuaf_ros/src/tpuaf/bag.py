"""Bag analysis with `rosbags` (no ROS installation needed): replays a fleet run's bag through
the same `FleetMonitor` (and so the same RunRecorder) as the live monitor node.

What it reads (fleet.launch records it): /<prefix><i>/base_pose_ground_truth
(nav_msgs/Odometry), /fleet/agent_events (tpuaf_ros/AgentEvent), /fleet/start (std_msgs/Float64:
the run's start [s]) and /fleet/metrics (tpuaf_ros/LiveMetrics: duration). Message types are
taken from the definitions stored in the bag.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .errors import TpuafError
from .monitor import FleetMonitor
from .topics import EVENTS_TOPIC, METRICS_TOPIC, START_TOPIC

GT_TOPIC = re.compile(r"^/(?P<prefix>.*?)(?P<index>\d+)/base_pose_ground_truth$")


class BagError(TpuafError):
    """The bag is missing, unreadable or lacks what the analysis needs."""


@dataclass
class BagInfo:
    path: Path
    robots: int
    prefix: str
    start_time: float | None  # from /fleet/start [s]
    duration: float | None  # from /fleet/metrics [s]
    topics: dict[str, int] = field(default_factory=dict)  # topic -> message count
    monitor_finished: bool = False
    monitor_final: dict | None = None


def _typestore(reader: Any):
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    types: dict = {}
    for conn in reader.connections:
        if conn.msgtype not in store.types and conn.msgdef is not None:
            try:
                types.update(get_types_from_msg(conn.msgdef.data, conn.msgtype))
            except Exception as err:  # noqa: BLE001 - name the topic
                raise BagError(f"{reader.path}: cannot parse the definition of {conn.msgtype} "
                               f"({conn.topic}): {err}") from None
    if types:
        store.register(types)
    return store


@contextmanager
def _open(path: Path) -> Iterator[Any]:
    """An open rosbags Reader; a damaged or foreign file is a BagError naming it."""
    from rosbags.rosbag1 import Reader, ReaderError

    reader = Reader(path)
    try:
        reader.open()
    except ReaderError as err:
        raise BagError(
            f"{path}: not a readable ROS 1 bag ({err}); a bag cut short by a crash can often be "
            "repaired with `rosbag reindex`"
        ) from None
    try:
        yield reader
    finally:
        reader.close()


def inspect(path: str | Path) -> BagInfo:
    """Robots, start and duration of a fleet bag (one pass over the small topics)."""

    path = Path(path)
    if not path.is_file():
        raise BagError(f"{path}: bag not found")
    with _open(path) as reader:
        store = _typestore(reader)
        robots: dict[int, str] = {}
        topics = {}
        for conn in reader.connections:
            topics[conn.topic] = topics.get(conn.topic, 0) + conn.msgcount
            m = GT_TOPIC.match(conn.topic)
            if m:
                robots[int(m["index"])] = m["prefix"]
        if not robots:
            raise BagError(f"{path}: no /<prefix><i>/base_pose_ground_truth topic in the bag "
                           f"(topics: {', '.join(sorted(topics)) or 'none'})")
        prefixes = set(robots.values())
        if len(prefixes) > 1:
            raise BagError(f"{path}: ground truth under several prefixes: {sorted(prefixes)}")
        info = BagInfo(path, max(robots) + 1, prefixes.pop(), None, None, topics)
        small = [c for c in reader.connections if c.topic in (START_TOPIC, METRICS_TOPIC)]
        for conn, _t, raw in reader.messages(connections=small):
            msg = store.deserialize_ros1(raw, conn.msgtype)
            if conn.topic == START_TOPIC:
                info.start_time = float(msg.data)
            else:
                info.duration = float(msg.duration)
                if msg.finished:
                    info.monitor_finished = True
                    info.monitor_final = {k: getattr(msg, k) for k in (
                        "elapsed", "visits", "idleness_avg", "interferences", "robots_alive")}
    return info


def replay(path: str | Path, patrol_map: Any, *, robots: int | None = None,
           duration: float | None = None, start_time: float | None = None,
           death_timeout_s: float = 5.0) -> tuple[FleetMonitor, BagInfo]:
    """Feed the bag's ground truth and agent events, in bag order, to a FleetMonitor."""

    info = inspect(path)
    n = robots or info.robots
    duration = duration if duration is not None else info.duration
    if duration is None:
        raise BagError(f"{path}: no /fleet/metrics in the bag: give the duration")
    start = start_time if start_time is not None else info.start_time
    if start is None:
        raise BagError(f"{path}: no /fleet/start in the bag: give the start time")
    monitor = FleetMonitor(patrol_map, n, duration, start_after=start,
                           death_timeout_s=death_timeout_s)
    with _open(Path(path)) as reader:
        store = _typestore(reader)
        wanted, robot_of = [], {}
        for conn in reader.connections:
            m = GT_TOPIC.match(conn.topic)
            if m and int(m["index"]) < n:
                robot_of[conn.id] = int(m["index"])
                wanted.append(conn)
            elif conn.topic == EVENTS_TOPIC:
                wanted.append(conn)
        index_of = patrol_map.index_of
        for conn, _t, raw in reader.messages(connections=wanted):
            msg = store.deserialize_ros1(raw, conn.msgtype)
            r = robot_of.get(conn.id)
            if r is not None:
                st = msg.header.stamp
                p = msg.pose.pose.position
                monitor.on_pose(r, st.sec + st.nanosec * 1e-9, p.x, p.y)
            else:
                st = msg.stamp
                v = -1 if msg.vertex < 0 else index_of(int(msg.vertex))
                monitor.on_event(int(msg.robot_index), int(msg.event), v,
                                 st.sec + st.nanosec * 1e-9)
            if monitor.finished:
                break
    if not monitor.started:
        raise BagError(f"{path}: the run never started in the bag (no complete set of poses "
                       f"after t = {start:.2f} s)")
    if not monitor.finished:
        monitor.end(monitor.now)  # the bag ends early: metrics up to its last pose set
    return monitor, info
