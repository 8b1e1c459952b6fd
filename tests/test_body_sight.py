"""A survivor's laser undoes a closure it sees no body at (robot/body_sight.py): under message
loss a survivor can misplace a lost teammate's body and close a vertex nobody blocks."""

from __future__ import annotations

import math

import numpy as np
from tpuaf.navigation.planner import PathPlanner
from tpuaf.robot.body_sight import MIN_RAYS, SIGHT_M, blocking_m, seen_empty, sight
from tpuaf.robot.lanes import closed_layer

from tests.test_body_on_vertex import layer_without_lanes, ring_map

POSE = (0.0, 0.0, 0.0)  # [m, m, rad]
VERTEX = (1.5, 0.0)  # [m]
REACH = 0.7  # [m]


def scan(*extra: tuple[float, float], wall_m: float = 3.0, step_deg: float = 1.0):
    """A 360-degree scan from POSE: a round wall at `wall_m` [m] (explained by the map) and
    `extra` points (unexplained: another robot, a body). Returns (points, unexplained)."""
    angles = np.radians(np.arange(0.0, 360.0, step_deg))
    wall = wall_m * np.column_stack((np.cos(angles), np.sin(angles)))
    points = np.vstack([wall, np.asarray(extra, dtype=float).reshape(-1, 2)])
    unexplained = np.r_[np.zeros(len(wall), bool), np.ones(len(extra), bool)]
    return points, unexplained


def test_a_vertex_in_plain_view_with_nothing_near_it_is_seen_empty():
    points, unexplained = scan()
    assert seen_empty(POSE, points, unexplained, VERTEX, REACH)


def test_a_body_near_the_vertex_or_anything_in_front_keeps_it_closed():
    # a body's surface 0.3 m short of the vertex: an unexplained return inside the disc
    assert not seen_empty(POSE, *scan((1.2, 0.0), (1.2, 0.05)), VERTEX, REACH)
    # a robot between us and the vertex hides it: rays end short of the disc
    assert not seen_empty(POSE, *scan((0.5, 0.0)), VERTEX, REACH)
    # a mapped wall inside the disc is no body: still empty (a vertex at a corridor's end)
    points, unexplained = scan(wall_m=1.8)
    assert seen_empty(POSE, points, unexplained, VERTEX, REACH)


def test_no_judgement_far_off_standing_in_it_or_on_too_few_rays():
    points, unexplained = scan(wall_m=4.0)
    assert not seen_empty(POSE, points, unexplained, (SIGHT_M + 0.1, 0.0), REACH)
    assert not seen_empty(POSE, points, unexplained, (0.5, 0.0), REACH)  # inside the disc
    # a scan that covers the disc with fewer than MIN_RAYS points (a sparse or narrow laser)
    sparse = scan(step_deg=360.0 / (MIN_RAYS + 2))
    assert not seen_empty(POSE, *sparse, VERTEX, REACH)
    assert not seen_empty(POSE, None, None, VERTEX, REACH)


def test_a_closure_seen_empty_is_undone_once_and_only_while_nothing_changed_since():
    before = layer_without_lanes(ring_map())
    after = closed_layer(before, (1,))  # vertex 1 at (2, 0) closed for teammate 2
    planner = PathPlanner(ring_map(), 0.1)
    standing = {2: (before, after)}
    current = [after]
    used = []

    def use(layer):
        used.append(layer)
        current[0] = layer

    look = sight(planner, standing, current, use, 0.1, 0.08)
    pose = (0.4, 0.0, 0.0)  # on the edge 0-1, 1.6 m from vertex 1, looking at it
    angles = np.radians(np.arange(0.0, 360.0, 1.0))
    # what the laser returns, robot frame: a body 0.1 m past vertex 1 (unmapped), else far
    body = np.array([[1.6 + 0.1 * math.cos(a), 0.1 * math.sin(a)] for a in angles[::10]])
    look(pose, body)
    assert used == [] and standing  # the body is there: kept closed
    # nothing there: rays 2.4 m long ahead, ending in the ring's walls (the map explains them)
    rays = np.column_stack((2.4 * np.cos(angles), 2.4 * np.sin(angles)))
    ahead = rays[np.abs(np.degrees(np.angle(np.exp(1j * angles)))) < 30]
    assert (planner.distances_to_obstacle(ahead + pose[:2]) <= 0.1).all()
    look(pose, ahead)
    assert used == [before] and not standing
    look(pose, rays)  # once only
    assert used == [before]


def test_a_body_seen_off_the_vertex_with_room_beside_it_reopens_it():
    """ctcv N = 12 under 30 % loss (recovery_physics_loss.md): a survivor closed vertex 13 for
    a body it read as standing 0.6 m off; the body lay 0.85 m off, and the laser sees it there.
    A body's surface nearer than 3 radii + the safety margin - the visit radius (+ room) may
    keep a robot off the vertex; farther, the vertex is reachable beside it."""
    assert math.isclose(blocking_m(0.1, 0.08, 0.15), 0.28)
    before = layer_without_lanes(ring_map())
    after = closed_layer(before, (1,))
    planner = PathPlanner(ring_map(), 0.1)
    for body_x, reopened in ((1.6 + 0.25, False), (1.6 + 0.45, True)):
        standing, current, used = {2: (before, after)}, [after], []
        look = sight(planner, standing, current, used.append, 0.1, 0.08)
        # robot frame: the body's near surface at body_x - 0.1 m straight ahead, the map's
        # walls (explained) beyond and around it
        angles = np.radians(np.arange(-30.0, 30.0, 1.0))
        rays = np.column_stack((2.4 * np.cos(angles), 2.4 * np.sin(angles)))
        hit = np.abs(rays[:, 1] / 2.4 * body_x) < 0.1  # rays that meet the body
        rays[hit] = rays[hit] * ((body_x - 0.1) / 2.4)
        look((0.4, 0.0, 0.0), rays)
        assert bool(used) == reopened, body_x


def test_tpuaf_run_names_the_vertices_bodies_cut_off_and_the_wrong_closures():
    from tpuaf.cli.run import format_summary

    text = format_summary({"vertices_under_bodies": [12], "closed_but_reachable": [4, 7]})
    assert "bodies cut off (left out of the reachable recovery): 12" in text
    assert "could still reach (counted in every figure): 4, 7" in text
    assert "cut off" not in format_summary({})
    rec = {"robot": 1, "time_s": 150.0, "survivors": 3, "recovery_time_s": None,
           "worst_idleness_after_s": 153.3, "worst_idleness_after_reachable_s": 41.0,
           "ideal_worst_idleness_survivors_s": 43.1, "floor_worst_idleness_after_s": 42.7,
           "detection_floor_worst_idleness_after_s": 42.2, "intentions": [3],
           "intentions_honoured": 1}
    assert "153.3 s, 41.0 s over the vertices still reachable" in format_summary(
        {"recovery": [rec]})
