"""The vertices dead robots' bodies cut off, in truth: what the recovery figures leave out.

After a death in a world with bodies (physics, fleets, robots), the figures "over reachable
vertices" leave out the vertices no survivor can reach any more. The robots' own closures
(VERTEX_CLOSED events, robot/lanes.py) are their estimate from the team messages; they may be
wrong (a lost message, a teammate read as standing) and a hostile teammate could send them, so
the figures never use them. The recorder applies `vertices_cut_off` to the dead robots' last
positions and the survivors', with the planner the robots drive with. (The same test on a
survivor's estimate of a body in a lane, in place of the survivors' distance rule, was tried
and not kept: docs/LANES.md.)

A vertex is cut off when no survivor can reach it with the bodies as obstacles while one could
without them (a vertex the map itself keeps out of reach, near a wall, is not the bodies'
doing). Reaching it takes a spot within the visit radius of it that the robot's centre may
occupy (`approach`: the vertex itself, or the nearest point a body lets a robot's centre come
to, two radii plus the controller's safety margin from the body's centre, exactly) and a
planned path from the survivor to that spot round the bodies, ending within two planning cells
of it (the planner snaps a spot on the edge of an obstacle to the nearest free cell; the far
side of a body that blocks a passage is at least two keep-out radii away).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from tpuaf.params import CONTROLLER_DEFAULTS


def body_discs(bodies_xy: np.ndarray, radius_m: float, planner: Any,
               safety_margin_m: float = CONTROLLER_DEFAULTS.safety_margin) -> np.ndarray:
    """(k, 3) obstacle discs (x, y, radius [m]) of the bodies at `bodies_xy` (k, 2) [m],
    widened by what the controller keeps from obstacles (`safety_margin_m` [m]) beyond the
    planner's own margin."""
    widen = max(0.0, float(safety_margin_m) - float(planner.config.safety_margin_m))  # [m]
    xy = np.asarray(bodies_xy, dtype=float).reshape(-1, 2)
    return np.column_stack((xy, np.full(len(xy), float(radius_m) + widen)))


def keep_out_m(body_radius_m: float, robot_radius_m: float, safety_margin_m: float) -> float:
    """[m] How near a robot's centre comes to a body's centre: both radii + the controller's
    safety margin."""
    return float(body_radius_m) + float(robot_radius_m) + float(safety_margin_m)


def approach(vertex_xy, bodies_xy: np.ndarray, keep_m: float, visit_radius_m: float):
    """The spot [m] nearest `vertex_xy` that a robot's centre may occupy, at least `keep_m`
    [m] from every body's centre, when it is within the visit radius of the vertex; else
    None. The spot is the vertex, or its projection out of the nearest body's keep-out circle
    (one body decides: bodies pressing on one vertex from two sides are rare, and then the
    spot is checked against all of them)."""
    v = np.asarray(vertex_xy, dtype=float)
    gaps = np.hypot(*(bodies_xy - v).T)
    if (gaps >= keep_m).all():
        return v
    nearest = int(np.argmin(gaps))
    if keep_m - gaps[nearest] > visit_radius_m:
        return None
    away = v - bodies_xy[nearest]
    norm = float(np.hypot(*away))
    direction = away / norm if norm > 1e-9 else np.array([1.0, 0.0])
    spot = bodies_xy[nearest] + direction * keep_m
    if (np.hypot(*(bodies_xy - spot).T) < keep_m - 1e-9).any():
        return None
    return spot


def _ends_near(planner: Any, source, goal, tolerance_m: float, discs) -> bool:
    path = planner.plan(source, goal, discs)
    return path is not None and math.dist(path[-1], goal) <= tolerance_m + 1e-9


def vertices_cut_off(planner: Any, positions, visit_radius_m: float, bodies_xy,
                     body_radius_m: float, survivors_xy,
                     safety_margin_m: float = CONTROLLER_DEFAULTS.safety_margin) -> set[int]:
    """Indices of the vertices (`positions` (n, 2) [m]) that the bodies at `bodies_xy` (k, 2)
    [m] cut off from every survivor at `survivors_xy` (m, 2) [m] (see the module docstring),
    for robots whose controller keeps `safety_margin_m` [m] from obstacles. Rows with NaN are
    ignored; no body or no survivor: none."""
    bodies = np.asarray(bodies_xy, dtype=float).reshape(-1, 2)
    bodies = bodies[np.isfinite(bodies).all(axis=1)]
    sources = np.asarray(survivors_xy, dtype=float).reshape(-1, 2)
    sources = sources[np.isfinite(sources).all(axis=1)]
    if not len(bodies) or not len(sources):
        return set()
    discs = body_discs(bodies, body_radius_m, planner, safety_margin_m)
    keep = keep_out_m(body_radius_m, planner.robot_radius_m, safety_margin_m)
    # [m] two planning cells' diagonals: the planner's grid rounds the keep-out circle outward
    cell = 2.0 * math.sqrt(2.0) * float(planner.costmap.resolution)
    out: set[int] = set()
    for v, goal in enumerate(np.asarray(positions, dtype=float)):
        spot = approach(goal, bodies, keep, float(visit_radius_m))
        if spot is not None and any(_ends_near(planner, s, spot, cell, discs) for s in sources):
            continue
        if any(_ends_near(planner, s, goal, visit_radius_m + cell, None) for s in sources):
            out.add(v)
    return out
