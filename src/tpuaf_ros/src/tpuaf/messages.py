"""Typed team messages, shared by the batch bus and the ROS adapters (tpuaf_ros/msg/*.msg).

Times are seconds of the run clock (simulated or wall). Vertices are graph indices inside the
core; the ROS adapters convert to and from the map's vertex ids.
"""

from __future__ import annotations

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
