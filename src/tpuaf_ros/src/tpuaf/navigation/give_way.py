"""Giving way between robots in passages one robot wide (ROS-free, map frame [m]).

When two robots block each other and there is no reasonable way round, one of them (the one
whose yield timer fires first: staggered by robot index, navigator.py) gives way: it drives to
a *refuge*, the nearest free spot off the other robot's way (a side pocket, a junction, the
corridor it came from), waits there until the other has passed, then carries on. The navigator
looks behind the robot first (`behind_first`: back the way it came, away from the other
robot), where it backs into the refuge without turning round; only then anywhere near. A robot standing
still without a goal does the same when another comes right up to it. The other robot's way is
estimated from what one robot knows: it comes from where it stands, through our position, on
along the way we came (our trail) and straight on beyond us.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tpuaf.navigation.route import polyline_length

REFUGE_SEARCH_M = 2.5  # [m] refuges are looked for this far from the robot at most
REFUGE_STEP_M = 0.05  # [m] cells of the search for a refuge
REFUGE_PLANS = 3  # refuges planned to (nearest first) before giving up
REFUGE_PATH_FACTOR = 2.5  # a refuge's planned path may be this many times its wave distance
# (+ 1 m): the plan keeps from walls, the wave does not
WAY_EXTENSION_M = 1.5  # [m] the other robot's way goes on this far straight beyond us
WALL_MARGIN_M = 0.03  # [m] a refuge is this much farther from walls than the lethal radius


@dataclass
class GiveWay:
    """One give-way manoeuvre: drive the corners to the refuge, then wait."""

    refuge: tuple[float, float]
    corners: list[tuple[float, float]]  # still ahead, the refuge last
    blocker: tuple[float, float]  # [m] where the other robot stood
    started_s: float
    deadline_s: float  # [s] waiting ends at the latest here
    arrived_s: float | None = None  # [s] at the refuge since
    clear_since_s: float | None = None  # [s] nothing unmapped near since
    parked: bool = False  # a robot without a goal making room
    reverse: bool = False  # driven backward (the refuge lies behind the robot)
    other_at: np.ndarray | None = None  # [m] centre of the other robot's points near us
    other_since_s: float = 0.0  # [s] ... there (within HELD_M) since


def segment_distances(points: np.ndarray, polyline: np.ndarray) -> np.ndarray:
    """[m] from each point (k, 2) to the nearest point of the polyline (m, 2)."""
    if len(polyline) == 1:
        return np.hypot(points[:, 0] - polyline[0, 0], points[:, 1] - polyline[0, 1])
    a, b = polyline[:-1], polyline[1:]
    ab = b - a
    len2 = np.maximum((ab * ab).sum(axis=1), 1e-12)
    rel = points[:, None, :] - a[None, :, :]
    f = np.clip((rel * ab[None]).sum(axis=2) / len2[None], 0.0, 1.0)
    closest = a[None] + f[:, :, None] * ab[None]
    d = np.hypot(points[:, None, 0] - closest[:, :, 0], points[:, None, 1] - closest[:, :, 1])
    return d.min(axis=1)


def other_way(me: tuple[float, float], blocker: tuple[float, float],
              trail: list[tuple[float, float]],
              heading_to: tuple[float, float] | None = None) -> np.ndarray:
    """The polyline (k, 2) [m] the other robot is expected to drive: from where it stands,
    through us, back along our trail (newest first), straight on beyond us, and (when we were
    driving toward `heading_to`, the point we aimed at: along a corridor) straight back from
    us away from that point."""
    points = [blocker, me]
    for fx, fy in ((blocker[0], blocker[1]), heading_to):
        dx, dy = me[0] - fx, me[1] - fy
        norm = math.hypot(dx, dy)
        if norm > 1e-6:
            points += [(me[0] + WAY_EXTENSION_M * dx / norm,
                        me[1] + WAY_EXTENSION_M * dy / norm), me]
        if heading_to is None:
            break
    return np.array([*points, *reversed(trail)], dtype=float)


def find_refuge(planner, me: tuple[float, float], blocker: tuple[float, float],
                trail: list[tuple[float, float]], pass_clearance_m: float,
                obstacles: np.ndarray | None,
                heading_to: tuple[float, float] | None = None,
                allowed=None, behind_first: bool = False) -> np.ndarray | None:
    """The planned path (k, 2) [m] from `me` to the nearest refuge: a free spot at least
    `pass_clearance_m` from the other robot's expected way (`other_way`), reachable without
    crossing `obstacles` (discs (x, y, radius) [m]: the other robots), where `allowed`
    (points (k, 2) -> bool mask; None: anywhere) lets the robot stand, or None. With
    `behind_first` the refuges behind `me` (on the far side from the blocker) come first.

    Nearest by a wave over a square of cells round `me` (free: not lethal for the robot, not
    within a disc's lethal reach), then a plan to the first few refuges the wave met."""
    distances = getattr(planner, "distances_to_obstacle", None)
    inscribed = getattr(planner, "inscribed_radius_m", None)
    if distances is None or inscribed is None:
        return None
    step = REFUGE_STEP_M
    k = int(round(REFUGE_SEARCH_M / step))
    s = np.arange(-k, k + 1) * step
    gx, gy = np.meshgrid(me[0] + s, me[1] + s)  # [row = y, col = x]
    cells = np.column_stack((gx.ravel(), gy.ravel()))
    wall = distances(cells).reshape(gx.shape)
    free = wall >= inscribed
    if obstacles is not None and len(obstacles):
        for ox, oy, r in np.asarray(obstacles, dtype=float):
            free &= np.hypot(gx - ox, gy - oy) >= r + inscribed
    # The wave: cells reached from our own cell (free or not: we stand there) step by step.
    reached = np.zeros_like(free)
    reached[k, k] = True
    order = np.full(free.shape, -1, dtype=int)
    order[k, k] = 0
    front = reached.copy()
    for wave in range(1, 4 * k):
        grown = front.copy()
        grown[1:, :] |= front[:-1, :]
        grown[:-1, :] |= front[1:, :]
        grown[:, 1:] |= front[:, :-1]
        grown[:, :-1] |= front[:, 1:]
        front = grown & free & ~reached
        if not front.any():
            break
        reached |= front
        order[front] = wave
    refuge = reached & (wall >= inscribed + WALL_MARGIN_M)
    refuge[k, k] = False
    if not refuge.any():
        return None
    idx = np.flatnonzero(refuge.ravel())
    way = other_way(me, blocker, trail, heading_to)
    idx = idx[segment_distances(cells[idx], way) >= pass_clearance_m]
    if allowed is not None:  # e.g. not inside a lane the robot does not hold (lanes.py)
        idx = idx[allowed(cells[idx])]
    idx = idx[np.argsort(order.ravel()[idx], kind="stable")]
    groups = [idx]
    if behind_first:  # away from the blocker: (cell - me) . (me - blocker) > 0
        away = ((cells[idx, 0] - me[0]) * (me[0] - blocker[0])
                + (cells[idx, 1] - me[1]) * (me[1] - blocker[1])) > 0.0
        groups = [idx[away], idx[~away]]
    for group in groups:
        for j in group[:REFUGE_PLANS]:
            path = planner.plan(me, tuple(cells[j]), obstacles)
            if path is not None and polyline_length(path) <= (
                    REFUGE_PATH_FACTOR * order.ravel()[j] * step + 1.0):
                return path
    return None
