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


TeamMessage = Visit | Intention | IdlenessEstimate | TaskRequest | TaskBid


TEAM_MESSAGES = (Visit, Intention, IdlenessEstimate, TaskRequest, TaskBid)


def well_formed(message: object, n_robots: int, n_vertices: int) -> bool:
    """True for a team message a policy can use: a known type, a sender 0..n_robots-1, vertices
    0..n_vertices-1 (next_vertex may be -1: 'not decided'), finite times and
    bids, an estimate per vertex. Transports drop the others (a garbled or foreign message)."""
    if not isinstance(message, TEAM_MESSAGES):
        return False

    def index(value: object, lo: int, hi: int) -> bool:
        return isinstance(value, int) and not isinstance(value, bool) and lo <= value < hi

    def finite(value: object) -> bool:
        return isinstance(value, (int, float)) and not isinstance(value, bool) and \
            math.isfinite(value)

    if not index(message.robot, 0, n_robots):
        return False
    for name in ("vertex", "next_vertex", "from_vertex"):
        if hasattr(message, name) and not index(getattr(message, name),
                                                -1 if name == "next_vertex" else 0, n_vertices):
            return False
    for name in ("time", "expected_arrival", "travel_time", "bid"):
        if hasattr(message, name) and not finite(getattr(message, name)):
            return False
    if isinstance(message, IdlenessEstimate):
        estimate = message.estimate
        if not isinstance(estimate, tuple) or len(estimate) != n_vertices or \
                not all(finite(x) for x in estimate):
            return False
    return True
