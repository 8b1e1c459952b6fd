"""Bag analysis with `rosbags` (no ROS installation needed), of a `tpuaf fleet` bag or a plain
`rosbag record` of a robot run.

Visits are the agents' own reports (docs: "one definition of a visit"): START (the start
vertex's first visit) and REACHED events on /fleet/agent_events when the bag has them, else the
Visit team messages (/team/visits: a robot's first is its START). They
are replayed, with the robots' positions, through the same `FleetMonitor` (and so the same
RunRecorder) as the live monitor node. Positions come from the best source the bag holds for
every robot: ground truth (/<robot>/base_pose_ground_truth), tf (map -> <robot>/base_footprint
on /tf and /tf_static), /<robot>/amcl_pose, /<robot>/odom; without any, visits and idleness are
computed and X and interference are not (the notes say so). Liveness: the agents' heartbeats.

Time: the analysed span is the bag's own (record times, shifted onto the message stamps' clock
when the recorder ran on another one): it starts at /fleet/start (a fleet bag) or at the bag's
beginning plus `start_offset_s`, and ends after `duration_s` or at the bag's end; a span outside
the bag is refused. Memory: messages are streamed; state is per robot and per vertex, plus the
recorder's rows (one per second of the analysed span).

Entry points (pure functions of a file; every problem is a BagError naming it):
`inspect(path)` -> BagInfo and `analyze(path, patrol_map, ...)` -> Analysis.
"""

from __future__ import annotations

import bisect
import contextvars
import math
import re
import statistics
import struct
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tpuaf.errors import TpuafError
from tpuaf.measure.monitor import STAMP_EPS_S, FleetMonitor, with_epoch
from tpuaf.measure.poses import POSE_SOURCES, MonitorFeed, chain_pose, feed_chains, robot_chains
from tpuaf.team import messages as team_messages
from tpuaf.topics import (
    AMCL_POSE,
    DEFAULT_TEAM_NS,
    EVENTS_TOPIC,
    GROUND_TRUTH,
    HEARTBEAT,
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
NS = 1e-9


class BagError(TpuafError):
    """The bag is missing, unreadable or lacks what the analysis needs."""


# The message being handled (topic and type), named when its content does not fit its type.
_CURRENT = contextvars.ContextVar("tpuaf_bag_message", default="")
# What a message whose definition differs from ours (or holds impossible values) raises.
_UNFIT = (AttributeError, TypeError, ValueError, KeyError, IndexError, OverflowError,
          ZeroDivisionError, struct.error)


def _guarded(function):
    """A public entry point: every failure caused by the bag's content is a BagError."""
    import functools

    @functools.wraps(function)
    def wrapper(path, *args, **kwargs):
        token = _CURRENT.set("")
        try:
            return function(path, *args, **kwargs)
        except BagError:
            raise
        except _UNFIT as err:
            where = _CURRENT.get()
            raise BagError(f"{path}: " + (f"a message on {where}" if where else "the bag")
                           + f" does not fit what the analysis expects ({type(err).__name__}: "
                           f"{err})") from None
        finally:
            _CURRENT.reset(token)

    return wrapper


@dataclass
class BagInfo:
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
    fleet_duration_s: float | None = None  # /fleet/metrics duration [s]
    monitor_finished: bool = False
    monitor_final: dict | None = None
    clock_offset_s: float = 0.0  # record time - stamp [s], when the recorder's clock differs
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


@dataclass
class Analysis:
    summary: dict
    recorder: Any  # the RunRecorder (results writer input)
    info: BagInfo
    robots: int
    start_s: float  # analysed span [s], on the messages' clock
    end_s: float
    pose_source: str | None
    visit_source: str  # "REACHED events" | "Visit team messages" | "none"
    reports: int  # visit reports inside the span
    liveness: bool  # deaths were detected from heartbeats
    notes: list[str] = field(default_factory=list)

    @property
    def span_s(self) -> float:
        return self.end_s - self.start_s


# ---------------------------------------------------------------------------------------------
# Reading


def _typestore(reader: Any):
    """The types of the bag's connections, from the definitions the bag stores (ROS 1 bags
    carry them all): 0.07 s; the whole Noetic store (0.3 s more) only when one is missing.
    Stores are kept per set of definitions (inspect and analyze read the same bag)."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    definitions = {c.msgtype: (c.msgdef.data if c.msgdef else None, c.topic)
                   for c in reader.connections}
    key = tuple(sorted((t, d) for t, (d, _) in definitions.items()))
    if key in _STORES:
        return _STORES[key]
    complete = all(text for text, _ in definitions.values())
    store = get_typestore(Stores.EMPTY if complete else Stores.ROS1_NOETIC)
    types: dict = {}
    for msgtype, (text, topic) in definitions.items():
        if msgtype not in store.types and text:
            try:
                types.update(get_types_from_msg(text, msgtype))
            except Exception as err:  # noqa: BLE001 - name the topic
                raise BagError(f"{reader.path}: cannot parse the definition of {msgtype} "
                               f"({topic}): {err}") from None
    if types:
        try:
            store.register(types)
        except Exception as err:  # noqa: BLE001 - a definition clashing with a known type
            raise BagError(f"{reader.path}: message definitions do not fit the known types "
                           f"({err})") from None
    if len(_STORES) >= 8:
        _STORES.pop(next(iter(_STORES)))
    _STORES[key] = store
    return store


_STORES: dict = {}  # definitions -> typestore


def _damaged(path: Path, err: BaseException) -> BagError:
    return BagError(f"{path}: not a readable ROS 1 bag ({type(err).__name__}: {err}); a bag cut "
                    "short by a crash can often be repaired with `rosbag reindex`")


@contextmanager
def _open(path: Path) -> Iterator[Any]:
    """An open rosbags Reader; a damaged or foreign file is a BagError naming it."""
    from rosbags.rosbag1 import Reader

    if not path.is_file():
        raise BagError(f"{path}: bag not found")
    reader = Reader(path)
    try:
        reader.open()
    except Exception as err:  # noqa: BLE001 - ReaderError and what a garbled header raises
        raise _damaged(path, err) from None
    try:
        yield reader
    finally:
        reader.close()


# Poses read straight from the serialised bytes (60-90 us a message through rosbags, 1 us
# here): (stamp [s], x [m], y [m]) of the standard definitions (their md5 sums), whose header
# (uint32 seq, uint32 sec, uint32 nsec, string frame_id) is followed by the pose, after
# child_frame_id for an Odometry.
_RAW_POSES = {("nav_msgs/msg/Odometry", "cd5e73d190d741a2f92e81eda573aca7"): True,
              ("geometry_msgs/msg/PoseWithCovarianceStamped",
               "953b798c0f514ff060a53a3498ce6246"): False}
_U32 = struct.Struct("<I")
_STAMP = struct.Struct("<III")
_XY = struct.Struct("<dd")


def _raw_pose(raw: bytes, odometry: bool) -> tuple[float, float, float]:
    sec, nsec, frame_len = _STAMP.unpack_from(raw, 4)
    offset = 16 + frame_len
    if odometry:
        offset += 4 + _U32.unpack_from(raw, offset)[0]
    x, y = _XY.unpack_from(raw, offset)
    return sec + nsec * NS, x, y


class RawEvent:
    """A tpuaf_ros/AgentEvent (messages version 2) read from its bytes: the fields the
    analysis uses, `t` its header stamp [s]."""

    __slots__ = ("t", "robot", "robot_index", "event", "vertex", "from_vertex")

    def __init__(self, raw: bytes):
        sec, nsec, frame_len = _STAMP.unpack_from(raw, 4)
        offset = 16 + frame_len
        (name_len,) = _U32.unpack_from(raw, offset)
        offset += 4
        self.robot = raw[offset:offset + name_len].decode("utf-8", "replace")
        (self.robot_index, self.event, self.vertex,
         self.from_vertex) = _EVENT.unpack_from(raw, offset + name_len)
        self.t = sec + nsec * NS


_EVENT = struct.Struct("<iBqq")  # robot_index, event, vertex, from_vertex
# The AgentEvent definition read raw (its md5 sum, version 2).
_RAW_EVENT = ("tpuaf_ros/msg/AgentEvent", "3ce9ce20732c9c9397c66ce50f7f6d89")


def raw_readers(connections: list) -> dict:
    """connection id -> how `_stream` reads it raw: True / False (an Odometry or a
    PoseWithCovarianceStamped pose), RawEvent; connections of other definitions are absent."""
    out: dict = {}
    for conn in connections:
        if (conn.msgtype, conn.digest) == _RAW_EVENT:
            out[conn.id] = RawEvent
        elif raw_pose_reader(conn) is not None:
            out[conn.id] = raw_pose_reader(conn)
    return out


def raw_pose_reader(conn: Any) -> bool | None:
    """For a pose connection of a standard definition: whether it is an Odometry (the raw
    reader applies), else None (rosbags deserialises it)."""
    return _RAW_POSES.get((conn.msgtype, conn.digest))


_OP_MSGDATA, _OP_CONNECTION = 2, 7
_CHUNKS_KEPT = 8


def _record_fields(chunk: bytes, offset: int) -> tuple[dict[bytes, bytes], int]:
    """The header fields of the record at `offset` of a chunk, and where its data starts."""
    (size,) = _U32.unpack_from(chunk, offset)
    pos, end = offset + 4, offset + 4 + size
    fields = {}
    while pos < end:
        (n,) = _U32.unpack_from(chunk, pos)
        name, _, value = chunk[pos + 4:pos + 4 + n].partition(b"=")
        fields[name] = value
        pos += 4 + n
    if pos != end:
        raise ValueError("a record header overruns its size")
    return fields, end


def _messages(reader: Any, connections: list) -> Iterator[tuple[Any, int, bytes]]:
    """(connection, record time [ns], serialised message) of `connections`, in the order of
    rosbags' `Reader.messages` (record time; ties: the connections' order, then each one's
    index order), read from rosbags' index of the open bag at a few us a message instead of
    its generic record parser (60 us): the order is one numpy lexsort of the index."""
    import numpy as np

    indexes = [reader.indexes[c.id] for c in connections]
    count = sum(len(ix) for ix in indexes)
    if not count:
        return
    times = np.fromiter((e.time for ix in indexes for e in ix), np.int64, count)
    which = np.repeat(np.arange(len(indexes), dtype=np.int32), [len(ix) for ix in indexes])
    rank = np.concatenate([np.arange(len(ix), dtype=np.int64) for ix in indexes])
    order = np.lexsort((rank, which, times))
    del times
    connmap = {c.id: c for c in reader.connections}
    # Neighbouring chunks overlap in record time (the recorder writes topics through separate
    # queues): the last few decompressed chunks are kept (memory: _CHUNKS_KEPT x ~1 MB).
    recent: dict[int, bytes] = {}
    chunk_pos, chunk = None, b""
    for k in order.tolist():
        entry = indexes[which[k]][rank[k]]
        if entry.chunk_pos != chunk_pos:
            chunk_pos = entry.chunk_pos
            chunk = recent.pop(chunk_pos, None)
            if chunk is None:
                info = reader.chunks[chunk_pos]
                reader.bio.seek(info.datapos)
                chunk = info.decompressor(reader.bio.read(info.datasize))
                if len(recent) >= _CHUNKS_KEPT:
                    recent.pop(next(iter(recent)))
            recent[chunk_pos] = chunk
        offset = entry.offset
        while True:
            fields, data_at = _record_fields(chunk, offset)
            op = fields.get(b"op", b"\0")[0]
            (size,) = _U32.unpack_from(chunk, data_at)
            if op != _OP_CONNECTION:
                break
            offset = data_at + 4 + size
        if op != _OP_MSGDATA:
            raise ValueError("expected message data at an index entry")
        (conn_id,) = _U32.unpack_from(fields[b"conn"])
        yield connmap[conn_id], entry.time, chunk[data_at + 4:data_at + 4 + size]


def _stream(path: Path, reader: Any, store: Any, connections: list,
            raw_poses: dict | None = None) -> Iterator[tuple]:
    """(connection, record time [s], message) in record order; a damaged chunk or message
    is a BagError naming the bag (never a traceback). Connections in `raw_poses` (id ->
    is Odometry) give (stamp, x, y) tuples instead of messages."""
    if not connections:
        return
    raw_poses = raw_poses or {}
    it = _messages(reader, connections)
    while True:
        try:
            conn, t_ns, raw = next(it)
        except StopIteration:
            return
        except Exception as err:  # noqa: BLE001 - decompression, truncation, bad index
            raise _damaged(path, err) from None
        try:
            how = raw_poses.get(conn.id)
            if how is not None:
                _CURRENT.set(f"{conn.topic} ({conn.msgtype}, t = {t_ns * NS:.3f} s)")
                yield conn, t_ns * NS, how(raw) if how is RawEvent else _raw_pose(raw, how)
                continue
            msg = store.deserialize_ros1(raw, conn.msgtype)
        except Exception as err:  # noqa: BLE001
            raise BagError(f"{path}: message {t_ns * NS:.3f} s on {conn.topic} cannot be read "
                           f"as {conn.msgtype} ({type(err).__name__}: {err})") from None
        _CURRENT.set(f"{conn.topic} ({conn.msgtype}, t = {t_ns * NS:.3f} s)")
        yield conn, t_ns * NS, msg


def _stamp(msg: Any) -> float:
    if type(msg) is RawEvent:
        return msg.t
    st = msg.header.stamp if hasattr(msg, "header") else msg.stamp
    return st.sec + st.nanosec * NS


# [s of stamp time] rosbag's record times lag the message stamps by up to tens of seconds of
# simulated time on a loaded machine, and by different amounts per topic: the replay puts the
# messages back in stamp order within this window (memory: the messages of one window).
REORDER_WINDOW_S = 60.0


def _order_key(msg: Any, t_rec: float) -> float:
    """The stamp a message is replayed at: its header or own stamp, a TF message's first
    transform's, else its record time."""
    if type(msg) is tuple:  # a raw pose (stamp, x, y)
        return msg[0]
    try:
        if hasattr(msg, "transforms"):
            return _stamp(msg.transforms[0]) if len(msg.transforms) else t_rec
        return _stamp(msg)
    except AttributeError:
        return t_rec


def _in_stamp_order(stream: Iterator[tuple], window_s: float = REORDER_WINDOW_S
                    ) -> Iterator[tuple]:
    """(connection, record time, message) of `stream` in stamp order (ties: arrival order),
    given that no message is recorded more than `window_s` after one stamped later: a bounded
    reorder buffer, sorted in batches (Timsort on nearly sorted runs, instead of a heap
    operation per message); it holds at most about two windows of messages."""
    held: list[tuple] = []  # (key, seq, connection, record time, message)
    newest = -math.inf
    next_sort = -math.inf
    for seq, (conn, t_rec, msg) in enumerate(stream):
        key = _order_key(msg, t_rec)
        if key > newest:
            newest = key
        held.append((key, seq, conn, t_rec, msg))
        if newest >= next_sort:  # (key, seq) are unique: tuples compare on them alone
            held.sort()
            cut = bisect.bisect_left(held, (newest - window_s,))  # keys < newest - window
            yield from ((c, t, m) for _, _, c, t, m in held[:cut])
            del held[:cut]
            next_sort = newest + window_s
    held.sort()
    yield from ((c, t, m) for _, _, c, t, m in held)


def _team_kind(topic: str) -> str | None:
    base = topic.rsplit("/", 1)[-1]
    return TEAM_BASENAMES.get(base) if topic.count("/") >= 2 else None


def _is_type(conn: Any, short: str) -> bool:
    return conn.msgtype.replace("/msg/", "/") == short


@_guarded
def inspect(path: str | Path) -> BagInfo:
    """What the bag holds for an analysis: its span, robots, team and pose topics (one pass
    over the small topics, and over /tf until every robot's chain to map is known)."""

    path = Path(path)
    with _open(path) as reader:
        return _inspect(path, reader)


def _inspect(path: Path, reader: Any) -> BagInfo:
    store = _typestore(reader)
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
            if _is_type(conn, "geometry_msgs/PoseWithCovarianceStamped" if kind == "amcl"
                        else "nav_msgs/Odometry"):
                info.pose_topics.setdefault(kind, {})[int(m["index"])] = conn.topic
                info.names.setdefault(int(m["index"]), m["name"])
        elif conn.topic in TF_TOPICS and _is_type(conn, "tf2_msgs/TFMessage"):
            tf_conns.append(conn)
        elif (conn.topic, conn.msgtype.replace("/msg/", "/")) in FLEET_TYPES:
            small.append(conn)
        elif _team_kind(conn.topic) and conn.msgtype.startswith("tpuaf_ros/"):
            info.team_topics[conn.topic] = _team_kind(conn.topic)
            small.append(conn)
    offsets: list[float] = []
    for conn, t_rec, msg in _stream(path, reader, store, small, raw_readers(small)):
        if conn.topic == START_TOPIC:
            _add_start(info, msg)
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
            if conn.topic == EVENTS_TOPIC:
                info.events += 1
                info.visit_events += is_visit(int(msg.event), int(msg.vertex))
            elif info.team_topics[conn.topic] == "Visit":
                info.visit_messages += 1
            if len(offsets) < 2001:
                offsets.append(t_rec - _stamp(msg))
    if info.pose_topics:
        info.robots = max(info.robots, max(max(d) for d in info.pose_topics.values()) + 1)
    if offsets:
        offset = statistics.median(offsets)
        if abs(offset) > CLOCK_OFFSET_S:  # e.g. recorded without use_sim_time
            info.clock_offset_s = offset
            info.start_s -= offset
            info.end_s -= offset
    inside = [s for s, _ in info.fleet_starts
              if info.start_s - STAMP_MARGIN_S <= s < info.end_s]
    info.fleet_start_s = min(inside) if inside else None
    names = {r: info.names.get(r, f"{_prefix(info)}{r}") for r in range(info.robots)}
    info.prefix = _prefix(info)
    if tf_conns and names:
        chains = robot_chains([names[r] for r in range(info.robots)], MAP_FRAME, BASE_FRAME)
        for _conn, _t, msg in _stream(path, reader, store, tf_conns):
            for r in feed_chains(chains, msg.transforms):
                if chains[r].pose() is not None:
                    info.tf_robots.add(r)
            if len(info.tf_robots) == len(chains):
                break
    return info


def _add_start(info: BagInfo, msg: Any) -> None:
    """A run start on /fleet/start: RunStart (its header stamp) or, version 1, Float64."""
    if hasattr(msg, "data"):
        start, announcer = float(msg.data), ""
    else:
        start, announcer = _stamp(msg), str(msg.announcer)
    if not math.isfinite(start):
        return
    if all(abs(start - s) > SAME_START_S for s, _ in info.fleet_starts):
        info.fleet_starts.append((start, announcer))
        info.fleet_starts.sort()


def _start_notes(info: BagInfo, start_offset_s: float | None) -> list[str]:
    """Notes on the bag's run starts: several (a robot that restarted and announced a new
    run), or one outside the bag."""
    if not info.fleet_starts:
        return []

    def when(s):
        by = next((a for t, a in info.fleet_starts if t == s), "")
        return f"{s - info.start_s:+.1f} s" + (f" (by {by})" if by else "")
    if info.fleet_start_s is None:
        return [f"the run start{'s' if len(info.fleet_starts) > 1 else ''} on {START_TOPIC} "
                f"({', '.join(when(s) for s, _ in info.fleet_starts)} from the bag's beginning) "
                "lie outside the bag: analysed from its beginning"]
    if len(info.fleet_starts) == 1:
        return []
    used = ("--start" if start_offset_s is not None
            else f"the earliest, {when(info.fleet_start_s)}")
    return [f"the bag holds {len(info.fleet_starts)} different run starts on {START_TOPIC} "
            f"({', '.join(when(s) for s, _ in info.fleet_starts)} from the bag's beginning; "
            f"an agent that restarted and announced a new run?): analysed from {used}"]


def _prefix(info: BagInfo) -> str:
    for name in info.names.values():
        m = re.match(r"^(.*?)\d+$", name)
        if m:
            return m.group(1)
    return "robot_"


# ---------------------------------------------------------------------------------------------
# Analysis


@_guarded
def analyze(path: str | Path, patrol_map: Any, *, robots: int | None = None,
            start_offset_s: float | None = None, duration_s: float | None = None,
            death_timeout_s: float | None = None, pose_source: str | None = None,
            team_ns: str | None = None, teammate_timeout_s: float | None = None) -> Analysis:
    """Metrics of the run in the bag (see the module docstring).

    start_offset_s: the span starts this long after the bag's beginning (default: /fleet/start
    when the bag has it, else the beginning); duration_s: its length (default: the monitored
    run's duration when the bag holds all of it, else up to the bag's end); death_timeout_s:
    heartbeat silence that makes a robot dead (default 5 s; off without heartbeats);
    teammate_timeout_s: the agents' teammate timeout, for the recovery's floor at detection
    (default 10 s, the agents' default);
    pose_source: ground_truth | tf | amcl | odom (default: the best one the bag has)."""

    path = Path(path)
    with _open(path) as reader:  # one open: rosbags reads the whole index on opening
        return _analyze(path, reader, patrol_map, robots, start_offset_s, duration_s,
                        death_timeout_s, pose_source, team_ns, teammate_timeout_s)


def _analyze(path, reader, patrol_map, robots, start_offset_s, duration_s, death_timeout_s,
             pose_source, team_ns, teammate_timeout_s=None) -> Analysis:
    info = _inspect(path, reader)
    notes: list[str] = []
    n = int(robots) if robots else info.robots
    if n <= 0:
        raise BagError(f"{path}: no robot found (no team messages, agent events or "
                       f"/<robot>/odom, amcl_pose, base_pose_ground_truth topics); topics: "
                       f"{', '.join(sorted(info.topics)) or 'none'}")
    if info.robots > n:
        notes.append(f"the bag has reports of {info.robots} robots; robots >= {n} ignored")
    if info.clock_offset_s:
        notes.append(f"the recorder's clock differs from the message stamps by "
                     f"{info.clock_offset_s:+.1f} s: the span is taken on the stamps' clock")
    notes += _start_notes(info, start_offset_s)
    start, end = _span(info, start_offset_s, duration_s)
    if death_timeout_s is not None and not death_timeout_s > 0:
        raise BagError(f"death timeout must be > 0 s, got {death_timeout_s:g}")
    if teammate_timeout_s is not None and not teammate_timeout_s > 0:
        raise BagError(f"teammate timeout must be > 0 s, got {teammate_timeout_s:g}")
    mate_timeout = 10.0 if teammate_timeout_s is None else float(teammate_timeout_s)

    # Visits: REACHED events, else Visit team messages.
    team = {t: k for t, k in info.team_topics.items()
            if team_ns is None or t.startswith(team_ns.rstrip("/") + "/")}
    visit_topics = [t for t, k in team.items() if k == "Visit"]
    if info.visit_events:
        visit_source = f"START and REACHED events ({EVENTS_TOPIC})"
    elif info.visit_messages:
        visit_source = f"Visit team messages ({', '.join(visit_topics)})"
        notes.append(f"visits from the Visit team messages (no START/REACHED events on "
                     f"{EVENTS_TOPIC}): a strategy that also sends one when it decides again "
                     "after a failed goal (TPUAF) counts those too; record the events for exact "
                     "counts")
    else:
        visit_source = "none"
        notes.append(f"no visit reports: neither START/REACHED events on {EVENTS_TOPIC} nor "
                     f"Visit messages on {DEFAULT_TEAM_NS}/{VISITS_BASENAME}: visits and "
                     "idleness cannot be computed")
    # Liveness: heartbeats (agent events); team messages only when a timeout is given.
    liveness = info.events > 0 or death_timeout_s is not None
    timeout = death_timeout_s if death_timeout_s is not None else 5.0
    if not liveness:
        timeout = math.inf
        notes.append(f"deaths not detected: no agent heartbeats ({EVENTS_TOPIC}) in the bag "
                     "(give --death-timeout to judge liveness from the team messages)")
    elif not info.events:
        notes.append(f"liveness judged from the team messages (no heartbeats on "
                     f"{EVENTS_TOPIC}): a robot silent for {timeout:g} s is dead")

    # Poses.
    available = info.pose_sources(n)
    if pose_source is not None:
        if pose_source not in POSE_SOURCES:
            raise BagError(f"pose source must be one of {', '.join(POSE_SOURCES)}, got "
                           f"{pose_source!r}")
        if pose_source not in available:
            raise BagError(f"{path}: no {pose_source} poses for every robot 0..{n - 1} "
                           f"(available: {', '.join(available) or 'none'})")
        source = pose_source
    else:
        source = available[0] if available else None
    if source is None:
        notes.append(_missing_poses(info, n))
    else:
        notes.append(f"positions (X, interference) from {POSE_SOURCES[source]}")

    store = _typestore(reader)
    if source is None:
        recorder, reports = _replay_reports(path, reader, store, info, patrol_map, n, start,
                                            end, timeout, team, liveness)
        monitor = None
    else:
        monitor, reports = _replay(path, reader, store, info, patrol_map, n, start, end,
                                   timeout, team, source, mate_timeout)
        recorder = monitor.recorder
    if info.out_of_span:
        notes.append(f"{info.out_of_span} message(s) stamped outside the bag's span ignored")
    if monitor is not None:
        summary = monitor.summary()
        start_used = monitor.start_time
    else:
        summary = with_epoch(recorder.summary(end - start), start)
        start_used = start
    end_used = start_used + summary["duration_s"]
    # reports inside the analysed span (a START before it is the first visit at its start)
    eps = STAMP_EPS_S
    n_reports = sum(1 for t, first in reports
                    if (first or t >= start_used - eps) and t <= end_used + eps)
    if source is None:
        for key in ("uncertainty_mean", "uncertainty_final_mean", "interferences",
                    "interference_rate_per_min"):
            summary[key] = None
    return Analysis(summary, recorder, info, n, start_used, end_used, source, visit_source,
                    n_reports, liveness, notes)


def _missing_poses(info: BagInfo, n: int) -> str:
    have = []
    for source in POSE_SOURCES:
        robots = info.tf_robots if source == "tf" else set(info.pose_topics.get(source, {}))
        if robots:
            have.append(f"{source} for robot(s) {sorted(robots)}")
    names = ", ".join(info.names.get(r, f"{info.prefix}{r}") for r in range(n))
    return ("X and interference not computed: no positions of every robot (" + names + ") in "
            f"the bag; looked for tf {MAP_FRAME} -> <robot>/{BASE_FRAME}, /<robot>/"
            f"{AMCL_POSE}, /<robot>/{ODOM}, /<robot>/{GROUND_TRUTH}"
            + (f"; found only {'; '.join(have)}" if have else ""))


def _span(info: BagInfo, start_offset_s: float | None, duration_s: float | None
          ) -> tuple[float, float]:
    """[start, end] [s] of the analysed span, inside the bag (else a BagError)."""
    b0, b1 = info.start_s, info.end_s
    where = f"{info.path}: the bag spans {info.span_s:.2f} s"
    if start_offset_s is not None:
        if not (math.isfinite(start_offset_s) and 0 <= start_offset_s < info.span_s):
            raise BagError(f"{where}: --start {start_offset_s:g} s is outside it (give 0 <= "
                           f"start < {info.span_s:.2f})")
        start = b0 + start_offset_s
    elif info.fleet_start_s is not None and b0 - STAMP_MARGIN_S <= info.fleet_start_s < b1:
        start = max(info.fleet_start_s, b0)
    else:
        start = b0
    left = b1 - start
    if duration_s is not None:
        if not (math.isfinite(duration_s) and duration_s > 0):
            raise BagError(f"--duration must be a positive number of seconds, got "
                           f"{duration_s:g}")
        if duration_s > left + 1e-6:
            raise BagError(f"{where}: --duration {duration_s:g} s from t = {start - b0:.2f} s "
                           f"runs past its end ({left:.2f} s left)")
        return start, start + duration_s
    if info.fleet_duration_s and 0 < info.fleet_duration_s <= left:
        return start, start + info.fleet_duration_s
    return start, b1


def _in_span(info: BagInfo, t: float) -> bool:
    ok = info.start_s - STAMP_MARGIN_S <= t <= info.end_s + STAMP_MARGIN_S
    if not ok:
        info.out_of_span += 1
    return ok


def _report_connections(reader: Any, info: BagInfo, team: dict[str, str]) -> list:
    conns = []
    for conn in reader.connections:
        if info.events and conn.topic == EVENTS_TOPIC and _is_type(conn, "tpuaf_ros/AgentEvent"):
            conns.append(conn)
        elif conn.topic in team:
            conns.append(conn)
    return conns


class _Reports:
    """Agent events and team messages -> (robot, kind, vertex index, stamp), or None when out of
    range (unknown robot or vertex, stamp outside the bag). Without agent events, a robot's
    first Visit message is its START (the start vertex's first visit), later ones REACHED, as
    the agents send them; other team messages are signs of life (HEARTBEAT)."""

    def __init__(self, info: BagInfo, patrol_map: Any, n: int, team: dict[str, str]):
        self.info, self.map, self.n, self.team = info, patrol_map, n, team
        self.use_visits = not info.visit_events
        self.started = [False] * n

    def __call__(self, conn: Any, msg: Any) -> tuple[int, int | None, int, float] | None:
        r = int(msg.robot_index)
        t = _stamp(msg)
        if not 0 <= r < self.n or not _in_span(self.info, t):
            return None
        if conn.topic == EVENTS_TOPIC and not self.use_visits:
            kind, vertex = int(msg.event), self.map.lookup_index(int(msg.vertex))
        elif conn.topic == EVENTS_TOPIC:  # events without visits (heartbeats only)
            kind, vertex = HEARTBEAT, -1
        elif self.use_visits and self.team.get(conn.topic) == "Visit":
            kind = REACHED if self.started[r] else START
            vertex = self.map.lookup_index(int(msg.vertex))
            if vertex is not None:
                self.started[r] = True
        else:  # a sign of life, only where the bag has no heartbeats (as the live monitor)
            kind, vertex = (None if self.info.events else HEARTBEAT), -1
        if vertex is None:
            return None
        return r, kind, vertex, t


def is_visit(kind: int, vertex: int) -> bool:
    """START (the start vertex's first visit) and REACHED are the agents' visit reports."""
    return kind in (START, REACHED) and vertex >= 0


def _replay(path, reader, store, info, patrol_map, n, start, end, timeout, team, source,
            teammate_timeout_s):
    """Reports and poses, in bag order, through a FleetMonitor."""
    monitor = FleetMonitor(patrol_map, n, end - start, start_after=start,
                           death_timeout_s=timeout, teammate_timeout_s=teammate_timeout_s)
    conns = _report_connections(reader, info, team)
    robot_of: dict[int, int] = {}
    raw_poses: dict[int, bool] = {}  # connection id -> is Odometry (read raw)
    if source == "tf":
        conns += [c for c in reader.connections if c.topic in TF_TOPICS
                  and _is_type(c, "tf2_msgs/TFMessage")]
    else:
        topics = {t: r for r, t in info.pose_topics[source].items() if r < n}
        for c in reader.connections:
            if c.topic in topics:
                robot_of[c.id] = topics[c.topic]
                conns.append(c)
                if raw_pose_reader(c) is not None:
                    raw_poses[c.id] = raw_pose_reader(c)
    feed = MonitorFeed(monitor, grouped=source != "ground_truth")
    chains = robot_chains([info.names.get(r, f"{info.prefix}{r}") for r in range(n)],
                          MAP_FRAME, BASE_FRAME)
    reports: list[tuple[float, bool]] = []  # (stamp, is START) of the visit reports
    report_of = _Reports(info, patrol_map, n, team)

    raw_poses.update(raw_readers([c for c in conns if c.topic == EVENTS_TOPIC]))
    for conn, _t_rec, msg in _in_stamp_order(_stream(path, reader, store, conns, raw_poses)):
        if conn.topic in TF_TOPICS:
            for r in feed_chains(chains, msg.transforms):
                pose = chain_pose(chains[r])
                if pose is not None and _in_span(info, pose[2]):
                    feed.add(r, pose[2], pose[0], pose[1])
        elif conn.id in robot_of:
            if type(msg) is tuple:  # read raw: (stamp, x, y)
                t, x, y = msg
            else:
                t, p = _stamp(msg), msg.pose.pose.position
                x, y = p.x, p.y
            if not _in_span(info, t):
                continue
            feed.add(robot_of[conn.id], t, x, y)
        else:
            rep = report_of(conn, msg)
            if rep is None:
                continue
            r, kind, vertex, t = rep
            if is_visit(kind, vertex):
                reports.append((t, kind == START))
            if kind is not None:
                monitor.on_event(r, kind, vertex, t)
            if team.get(conn.topic) == "Intention":  # for the recovery metrics
                target = patrol_map.lookup_index(int(msg.vertex))
                if target is not None and target >= 0:
                    monitor.on_announcement(r, target, t)
        if monitor.finished:
            break
    feed.close()  # up to the bag's last poses
    if not monitor.started:
        raise BagError(f"{path}: no complete set of robot positions ({source}) between "
                       f"t = {start - info.start_s:.2f} s and the bag's end")
    if not monitor.finished:  # the bag ends within the span: metrics up to its last poses
        monitor.duration_s = max(0.0, min(monitor.now, end) - monitor.start_time)
        monitor.end(monitor.start_time + monitor.duration_s)
    return monitor, reports


def _replay_reports(path, reader, store, info, patrol_map, n, start, end, timeout, team,
                    liveness):
    """Reports only (no positions): visits and idleness straight into a RunRecorder."""
    from tpuaf.measure.metrics import RunRecorder

    recorder = RunRecorder(patrol_map, n, ground_truth=False)  # run time: 0 at `start`
    heard = [start] * n  # last sign of life [s]
    alive = [True] * n
    reports: list[tuple[float, bool]] = []  # (stamp, is START) of the visit reports
    report_of = _Reports(info, patrol_map, n, team)

    def deaths_until(t):
        for r in range(n):
            if alive[r] and t - heard[r] > timeout:
                alive[r] = False
                recorder.record_robot_death(r, round(heard[r] + timeout - start, 9))

    conns = _report_connections(reader, info, team)
    for conn, _t, msg in _in_stamp_order(
            _stream(path, reader, store, conns, raw_readers(conns))):
        rep = report_of(conn, msg)
        if rep is None:
            continue
        r, kind, vertex, t = rep
        if t > end:
            break
        if kind is None or (t < start and kind != START):
            continue  # no sign of life; before the run (a START is the first visit at the start)
        t = max(t, start)
        if liveness:
            deaths_until(t)
        heard[r] = max(heard[r], t)
        if is_visit(kind, vertex):  # as FleetMonitor: a robot's reports count even if silent
            recorder.record_visit(r, vertex, round(t - start, 9))
            reports.append((t, kind == START))
    if liveness:
        deaths_until(end)
    recorder.finish(end - start)
    return recorder, reports
