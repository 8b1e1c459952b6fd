"""Typed team messages, shared by the batch bus and the ROS adapters (tpuaf_ros/msg/*.msg).

Times are seconds of the run clock (simulated or wall). Vertices are graph indices inside the
core; the ROS adapters convert to and from the map's vertex ids.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Visit:
    """Robot `robot` reached its goal vertex `vertex` at `time` (SPEC section 4 step 6)."""

    robot: int
    vertex: int
    time: float
    next_vertex: int = -1  # the vertex it heads to next, -1 when not yet decided


@dataclass(frozen=True)
class Intention:
    """Robot `robot` heads from `from_vertex` to `vertex`, expected there at `expected_arrival`."""

    robot: int
    from_vertex: int
    vertex: int
    expected_arrival: float
    travel_time: float  # dt' [s]
    time: float


@dataclass(frozen=True)
class IdlenessEstimate:
    """DTAG/DTAP shared estimate E[v] [s] of every vertex, E[next_vertex] sent as 0."""

    robot: int
    time: float
    estimate: tuple[float, ...]
    next_vertex: int


@dataclass(frozen=True)
class TaskRequest:
    """DTAP auction: `robot` bids `bid` [m] for `vertex` (lower wins)."""

    robot: int
    vertex: int
    bid: float
    time: float


@dataclass(frozen=True)
class TaskBid:
    """DTAP auction: reply with my lower bid [m] for `vertex`."""

    robot: int
    vertex: int
    bid: float
    time: float


@dataclass(frozen=True)
class LaneClaim:
    """Robot `robot`'s lane lock (docs/LANES.md): it asks for `lane` since `stamp` [s], or
    holds it (`held`); `lane` -1: none. A robot inside a one-way lane announces it as held too
    (no lock: it tells where a robot that dies lies). `leg`: the edge (u, v) the robot drives
    in the held lane (vertex indices; (-1, -1): none) and `position` where the robot was when
    the claim was sent ([m] map frame; NaN: not known). Sent on every change and re-announced
    periodically; the lane layer's own message, not handed to policies."""

    robot: int
    lane: int
    stamp: float  # [s] run time of the request (the queue's order)
    held: bool
    time: float
    leg: tuple[int, int] = (-1, -1)
    position: tuple[float, float] = (math.nan, math.nan)


TeamMessage = Visit | Intention | IdlenessEstimate | TaskRequest | TaskBid


TEAM_MESSAGES = (Visit, Intention, IdlenessEstimate, TaskRequest, TaskBid)


def _index_problem(value: object, name: str, n: int, allow_none: bool = False) -> str | None:
    if isinstance(value, bool) or not isinstance(value, int):
        return f"{name} {value!r} is not an integer"
    if allow_none and value == -1:
        return None
    if not 0 <= value < n:
        return f"{name} {value} is outside the map (0..{n - 1})"
    return None


def _finite(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def problem(message: object, n_robots: int, n_vertices: int, n_lanes: int = 0) -> str | None:
    """Why a team message cannot be used by a policy (None: it can): an unknown type, a sender
    outside 0..n_robots-1, a vertex outside the map (next_vertex and from_vertex may be -1:
    'none'), a non-finite time, a negative travel time, bid or estimate, or an estimate of
    the wrong length; a lane claim: `lane_claim_problem` on the team's `n_lanes` lanes (0: the
    robot runs no lane layer). The one structural check of every transport (agent runtime, ROS
    inbox)."""
    if isinstance(message, LaneClaim):
        return lane_claim_problem(message, n_robots, n_lanes, n_vertices)
    if not isinstance(message, TEAM_MESSAGES):
        return f"not a team message: {type(message).__name__}"
    r = message.robot
    if isinstance(r, bool) or not isinstance(r, int) or not 0 <= r < n_robots:
        return f"unknown robot index {r!r} (team of {n_robots})"
    if not _finite(message.time):
        return f"time {message.time!r} is not finite"
    for name in ("vertex", "next_vertex", "from_vertex"):
        if hasattr(message, name):
            why = _index_problem(getattr(message, name), name.replace("_", " "), n_vertices,
                                 allow_none=name != "vertex")
            if why:
                return why
    for name in ("expected_arrival", "travel_time"):
        if hasattr(message, name) and not _finite(getattr(message, name)):
            return f"{name} {getattr(message, name)!r} is not finite"
    if hasattr(message, "travel_time") and message.travel_time < 0:
        return f"travel time {message.travel_time} s < 0"
    if hasattr(message, "bid") and not (_finite(message.bid) and message.bid >= 0):
        return f"bid {message.bid!r} is negative or not finite"
    if isinstance(message, IdlenessEstimate):
        estimate = message.estimate
        if not isinstance(estimate, tuple) or len(estimate) != n_vertices:
            size = len(estimate) if isinstance(estimate, (tuple, list)) else estimate
            return f"estimate of {size} vertices (map has {n_vertices})"
        if not all(_finite(x) and x >= 0 for x in estimate):
            return "estimate has a negative or non-finite idleness"
    return None


def lane_claim_problem(message: LaneClaim, n_robots: int, n_lanes: int,
                       n_vertices: int) -> str | None:
    """Why a lane claim cannot be used (None: it can): the check of `problem` for LaneClaim."""
    r = message.robot
    if isinstance(r, bool) or not isinstance(r, int) or not 0 <= r < n_robots:
        return f"unknown robot index {r!r} (team of {n_robots})"
    # a robot that starts inside a lane holds it from -inf (first in every queue)
    held_from_start = message.held and message.stamp == -math.inf
    if not (_finite(message.time) and (_finite(message.stamp) or held_from_start)):
        return "lane claim time or stamp is not finite"
    if n_lanes <= 0 and message.lane != -1:
        return f"lane {message.lane!r} claimed, but we run no lane layer"
    why = _index_problem(message.lane, "lane", n_lanes, allow_none=True)
    if why:
        return why
    leg = message.leg
    if not isinstance(leg, tuple) or len(leg) != 2:
        return f"lane claim leg {leg!r} is not a pair of vertices"
    for v in leg:
        why = _index_problem(v, "leg vertex", n_vertices, allow_none=True)
        if why:
            return why
    position = message.position
    if (not isinstance(position, tuple) or len(position) != 2
            or not all(isinstance(c, (int, float)) and not isinstance(c, bool) for c in position)
            or any(math.isinf(c) for c in position)):
        return f"lane claim position {position!r} is not a point (x, y) [m] or (nan, nan)"
    return None


def well_formed(message: object, n_robots: int, n_vertices: int, n_lanes: int = 0) -> bool:
    """True when `problem` finds nothing: the message is safe to hand to a robot."""
    return problem(message, n_robots, n_vertices, n_lanes) is None
