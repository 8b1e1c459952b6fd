"""Routes along the patrol graph: the vertex waypoints of a shortest path (ROS-free)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

# ---------------------------------------------------------------------------------------------
# Route along the graph


def polyline_length(points: np.ndarray) -> float:
    """Length [m] of the polyline through `points` (k, 2) [m]; 0 for fewer than two."""
    return float(np.sum(np.hypot(*np.diff(points, axis=0).T))) if len(points) > 1 else 0.0


class GraphRoute:
    """Waypoints (vertex indices) of the shortest path from `start_vertex` to `goal_vertex`.

    The start vertex itself is not a waypoint (the robot is there), unless `from_position`
    [m] is given and lies farther than `snap_m` from it (the robot must first drive back to it).
    A goal equal to the start gives the single waypoint [goal]."""

    def __init__(self, graph: Any, positions: np.ndarray, start_vertex: int, goal_vertex: int,
                 *, from_position: tuple[float, float] | None = None, snap_m: float = 0.5):
        n = int(graph.num_vertices)
        for name, v in (("start", start_vertex), ("goal", goal_vertex)):
            if not 0 <= int(v) < n:
                raise IndexError(f"{name} vertex index {v} out of range (graph has {n})")
        self.start = int(start_vertex)
        self.goal = int(goal_vertex)
        self.positions = np.asarray(positions, dtype=float)
        if self.goal == self.start:
            path = [self.goal]
        else:
            path = [int(v) for v in graph.path(self.start, self.goal)[1:]]
        if from_position is not None and self.goal != self.start:
            p = self.positions[self.start]
            if math.hypot(from_position[0] - p[0], from_position[1] - p[1]) > snap_m:
                path.insert(0, self.start)
        self.waypoints: list[int] = path
        self._k = 0

    @property
    def done(self) -> bool:
        return self._k >= len(self.waypoints)

    @property
    def next_waypoint(self) -> int | None:
        return None if self.done else self.waypoints[self._k]

    @property
    def is_last(self) -> bool:
        """True when the next waypoint is the goal."""
        return self._k == len(self.waypoints) - 1

    def next_position(self) -> tuple[float, float]:
        p = self.positions[self.waypoints[self._k]]
        return (float(p[0]), float(p[1]))

    def advance(self) -> int:
        """Mark the next waypoint reached; returns it."""
        if self.done:
            raise IndexError("route already done")
        v = self.waypoints[self._k]
        self._k += 1
        return v

    def length(self) -> float:
        """Length [m] of the polyline start -> waypoints (straight segments)."""
        return polyline_length(self.positions[[self.start, *self.waypoints]])


# ---------------------------------------------------------------------------------------------
# Laser scan
