"""Reading a ROS 1 bag with `rosbags` (no ROS installation needed): opening it, its message
types, the messages of chosen connections in record order (rosbags' index walked directly),
the poses and agent events read straight from their bytes, and the replay in stamp order.
Every problem caused by the bag is a BagError naming it (`guarded` entry points).

The analysis of what is read lives in tpuaf.measure.bag_info (what a bag holds) and
tpuaf.measure.bag (the metrics of its run).
"""

from __future__ import annotations

import bisect
import contextvars
import math
import struct
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from tpuaf.errors import TpuafError

NS = 1e-9


class BagError(TpuafError):
    """The bag is missing, unreadable or lacks what the analysis needs."""


# The message being handled (topic and type), named when its content does not fit its type.
_CURRENT = contextvars.ContextVar("tpuaf_bag_message", default="")
# What a message whose definition differs from ours (or holds impossible values) raises.
_UNFIT = (AttributeError, TypeError, ValueError, KeyError, IndexError, OverflowError,
          ZeroDivisionError, struct.error)


def guarded(function):
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


# ---------------------------------------------------------------------------------------------
# Opening and types


def typestore(reader: Any):
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
def open_bag(path: Path) -> Iterator[Any]:
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


# ---------------------------------------------------------------------------------------------
# Messages read from their bytes

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


def raw_pose(raw: bytes, odometry: bool) -> tuple[float, float, float]:
    """(stamp [s], x [m], y [m]) of a serialised Odometry (`odometry`) or
    PoseWithCovarianceStamped of the standard definition."""
    sec, nsec, frame_len = _STAMP.unpack_from(raw, 4)
    offset = 16 + frame_len
    if odometry:
        offset += 4 + _U32.unpack_from(raw, offset)[0]
    x, y = _XY.unpack_from(raw, offset)
    return sec + nsec * NS, x, y


class RawEvent:
    """A tpuaf_ros/AgentEvent (messages version 2 or 3) read from its bytes: the fields the
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
# The AgentEvent definitions read raw (md5 sums of version 2, 3: the DWELL constant, 4: STUCK
# and GIVE_WAY, 5: LANE_WAIT and LANE_ENTER, and 6: VERTEX_CLOSED; the same bytes).
_RAW_EVENTS = {("tpuaf_ros/msg/AgentEvent", "3ce9ce20732c9c9397c66ce50f7f6d89"),
               ("tpuaf_ros/msg/AgentEvent", "7a2f1a3c7ed3c48b38ec6c116f61048a"),
               ("tpuaf_ros/msg/AgentEvent", "28aa1b950cb64e1a91e842f53b0c3fb3"),
               ("tpuaf_ros/msg/AgentEvent", "5af9a73afa021543d084577e229fe081"),
               ("tpuaf_ros/msg/AgentEvent", "ec65188c2e58526c7238920de09dd12b")}


def raw_readers(connections: list) -> dict:
    """connection id -> how `read_messages` reads it raw: True / False (an Odometry or a
    PoseWithCovarianceStamped pose), RawEvent; connections of other definitions are absent."""
    out: dict = {}
    for conn in connections:
        if (conn.msgtype, conn.digest) in _RAW_EVENTS:
            out[conn.id] = RawEvent
        elif raw_pose_reader(conn) is not None:
            out[conn.id] = raw_pose_reader(conn)
    return out


def raw_pose_reader(conn: Any) -> bool | None:
    """For a pose connection of a standard definition: whether it is an Odometry (the raw
    reader applies), else None (rosbags deserialises it)."""
    return _RAW_POSES.get((conn.msgtype, conn.digest))


# ---------------------------------------------------------------------------------------------
# Messages in record order, then in stamp order

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


def index_messages(reader: Any, connections: list) -> Iterator[tuple[Any, int, bytes]]:
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


def read_messages(path: Path, reader: Any, store: Any, connections: list,
                  raw_poses: dict | None = None) -> Iterator[tuple]:
    """(connection, record time [s], message) in record order; a damaged chunk or message
    is a BagError naming the bag (never a traceback). Connections in `raw_poses` (id ->
    is Odometry) give (stamp, x, y) tuples instead of messages."""
    if not connections:
        return
    raw_poses = raw_poses or {}
    it = index_messages(reader, connections)
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
                yield conn, t_ns * NS, how(raw) if how is RawEvent else raw_pose(raw, how)
                continue
            msg = store.deserialize_ros1(raw, conn.msgtype)
        except Exception as err:  # noqa: BLE001
            raise BagError(f"{path}: message {t_ns * NS:.3f} s on {conn.topic} cannot be read "
                           f"as {conn.msgtype} ({type(err).__name__}: {err})") from None
        _CURRENT.set(f"{conn.topic} ({conn.msgtype}, t = {t_ns * NS:.3f} s)")
        yield conn, t_ns * NS, msg


def stamp_of(msg: Any) -> float:
    """[s] A message's header stamp (or its own `stamp`, as a TransformStamped's header)."""
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
            return stamp_of(msg.transforms[0]) if len(msg.transforms) else t_rec
        return stamp_of(msg)
    except AttributeError:
        return t_rec


def in_stamp_order(stream: Iterator[tuple], window_s: float = REORDER_WINDOW_S,
                   span: tuple[float, float] = (-math.inf, math.inf)) -> Iterator[tuple]:
    """(connection, record time, message) of `stream` in stamp order (ties: arrival order),
    given that no message is recorded more than `window_s` after one stamped later: a bounded
    reorder buffer, sorted in batches (Timsort on nearly sorted runs, instead of a heap
    operation per message); it holds at most about two windows of messages. A message stamped
    outside `span` [s] (off the bag's clock: refused by the reader) passes at once: it cannot
    hold the others back."""
    held: list[tuple] = []  # (key, seq, connection, record time, message)
    newest = -math.inf
    next_sort = -math.inf
    lo, hi = span
    for seq, (conn, t_rec, msg) in enumerate(stream):
        key = _order_key(msg, t_rec)
        if not lo <= key <= hi:
            yield conn, t_rec, msg
            continue
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


def is_type(conn: Any, short: str) -> bool:
    """Whether a connection's type is `short` (package/Type, without rosbags' /msg/)."""
    return conn.msgtype.replace("/msg/", "/") == short
