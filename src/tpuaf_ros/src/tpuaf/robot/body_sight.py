"""A survivor's own laser on a vertex it closed: a closure it sees no blocking body at is undone.

A survivor closes the vertices a lost teammate's body stands on from the team messages
(robot/lanes.py, `body_vertices`). Under message loss it can misplace the body (a teammate that
drove off is read as standing) and close a vertex nobody blocks, which it would then never
visit. So while a closed vertex is in plain view, the laser checks it. A body keeps a robot
from the vertex when its centre is nearer than 2 radii + the controller's safety margin - the
visit radius (the recorder's truth, navigation/bodies.py), so when a point of its surface is
nearer than one radius more (`blocking_m`, with SIGHT_ROOM_M to spare). The vertex is seen
clear when the laser's rays toward that disc cover it with nothing in front and none of their
points the map does not explain lies in it (`seen_empty`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from tpuaf.navigation.bodies import keep_out_m
from tpuaf.navigation.give_way import map_points
from tpuaf.navigation.navigator import UNMAPPED_DISTANCE_M

SIGHT_M = 2.5  # [m] a closed vertex farther than this is not judged (laser points thin out)
MIN_RAYS = 5  # laser points toward the vertex's surroundings needed to judge it
SIGHT_ROOM_M = 0.05  # [m] room a robot is to have beside a seen body for the vertex to reopen


def blocking_m(radius_m: float, safety_margin_m: float, visit_radius_m: float) -> float:
    """[m] A body's surface this near a vertex may keep a robot of `radius_m` [m] from it: 3
    radii (the body's centre behind its surface, two robots side by side) + the controller's
    `safety_margin_m` [m] - the visit radius [m] + SIGHT_ROOM_M."""
    return keep_out_m(radius_m, radius_m, safety_margin_m) + radius_m - visit_radius_m + SIGHT_ROOM_M


def seen_empty(pose: tuple[float, float, float], points_xy: np.ndarray | None,
               unexplained: np.ndarray | None, vertex_xy, reach_m: float) -> bool:
    """Does the laser, from `pose` (x [m], y [m], heading [rad]), show no body near the vertex
    at `vertex_xy` [m]? `points_xy` (k, 2): the scan's points in the map frame [m];
    `unexplained` (k,): the points the map does not explain (other robots, bodies); `reach_m`
    [m]: how far from the vertex a body's surface may lie. Seen empty: the vertex within
    SIGHT_M, at least MIN_RAYS points toward the disc of `reach_m` round it, none of them
    nearer to the robot than that disc (nothing hides it) and none unexplained within it."""
    if points_xy is None or unexplained is None or len(points_xy) < MIN_RAYS:
        return False
    x, y = float(pose[0]), float(pose[1])
    vx, vy = float(vertex_xy[0]), float(vertex_xy[1])
    d = math.hypot(vx - x, vy - y)  # [m]
    if d > SIGHT_M or d <= reach_m:
        return False  # too far to judge, or standing in it (its own body hides the rays)
    half = math.asin(reach_m / d)  # [rad] the disc's half-width seen from the robot
    dx, dy = points_xy[:, 0] - x, points_xy[:, 1] - y
    off = np.angle(np.exp(1j * (np.arctan2(dy, dx) - math.atan2(vy - y, vx - x))))
    toward = np.abs(off) <= half
    if int(toward.sum()) < MIN_RAYS:
        return False
    ranges = np.hypot(dx[toward], dy[toward])
    if (ranges < d - reach_m).any():
        return False  # something between the robot and the vertex's surroundings
    near = np.hypot(points_xy[toward, 0] - vx, points_xy[toward, 1] - vy) <= reach_m
    return not bool((near & unexplained[toward]).any())


def sight(planner: Any, standing: dict, current: list, use: Callable[[Any], None],
          radius_m: float, safety_margin_m: float,
          ) -> Callable[[tuple[float, float, float], np.ndarray], None]:
    """`LaneAccess.look` of robot/lanes.py's `attach_lanes`: a teammate's closure with a
    vertex the robot's laser shows clear of a blocking body (`seen_empty`, `blocking_m`) is
    undone, as when the teammate is heard again. `standing`: teammate -> the lane layers before
    and after its closure; `current`: [the layer in use]; `use`: drive on another layer."""

    def look(pose: tuple[float, float, float], points: np.ndarray) -> None:
        for robot, (before, after) in list(standing.items()):
            if current[0] is not after:
                continue
            reach = max(blocking_m(radius_m, safety_margin_m,
                                   float(after.plan_map.visit_radius_m)), radius_m)  # [m]
            xy = np.asarray(after.plan_map.positions, dtype=float)
            shut = [v for v in sorted(after.plan_map.closed - before.plan_map.closed)
                    if math.dist(xy[v], pose[:2]) <= SIGHT_M]
            if not shut:
                continue
            seen = map_points(pose, points, SIGHT_M + reach)
            if seen is None:
                return
            unexplained = planner.distances_to_obstacle(seen) > UNMAPPED_DISTANCE_M
            if any(seen_empty(pose, seen, unexplained, xy[v], reach) for v in shut):
                standing.pop(robot)
                use(before)
                return

    return look
