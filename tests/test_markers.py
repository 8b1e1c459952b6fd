"""tpuaf.measure.markers (ROS-free): what the RViz markers show of a patrol."""

from __future__ import annotations

import numpy as np
import pytest
from tpuaf.maps import load_map
from tpuaf.measure.markers import ROBOT_COLOURS, PatrolView, scale_colour

LAB = load_map("lab")


def by_ns(markers):
    return {(m.ns, m.id): m for m in markers}


def test_graph_vertices_and_robots_are_drawn():
    view = PatrolView(LAB, 2, idleness_scale_s=40.0)
    view.on_pose(0, 0.0, 0.3, 0.3, 0.0)
    view.on_goal(0, 1)
    view.on_intention(1, 2, 3)  # robot 1 announced 2 -> 3, no pose yet: nothing of it drawn
    m = by_ns(view.markers(10.0))
    edges = m[("graph_edges", 0)]
    assert edges.kind == "line_list" and len(edges.points) == 2 * len(view.edges) > 0
    vertices = m[("vertices_idleness", 0)]
    assert len(vertices.points) == len(vertices.colors) == LAB.num_vertices
    assert m[("footprints", 0)].color == ROBOT_COLOURS[0]
    goal = m[("goals", 0)]
    assert goal.points[-1][:2] == pytest.approx(tuple(LAB.positions[1]))
    assert ("footprints", 1) not in m and ("intentions", 1) not in m
    view.on_pose(1, 0.0, 1.0, 1.0, 0.5)
    m = by_ns(view.markers(11.0))
    arrow = m[("intentions", 1)]
    assert arrow.points[0][:2] == pytest.approx(tuple(LAB.positions[2]))
    assert arrow.points[1][:2] == pytest.approx(tuple(LAB.positions[3]))


def test_vertex_colours_follow_idleness():
    view = PatrolView(LAB, 1, idleness_scale_s=40.0, start_time=0.0)
    view.on_visit(0, 4, 38.0)
    colours = by_ns(view.markers(40.0))[("vertices_idleness", 0)].colors
    assert colours[4] == scale_colour(2.0, 40.0)  # just visited: green
    assert colours[4][1] > colours[4][0]
    assert colours[0] == (1.0, 0.0, 0.0, 1.0)  # never visited for 40 s: red
    assert scale_colour(float("nan"), 40.0)[:3] == (0.6, 0.6, 0.6)


def test_uncertainty_grows_away_from_the_robots_and_falls_under_them():
    view = PatrolView(LAB, 1, mode="uncertainty", idleness_scale_s=40.0)
    x0 = view.vertex_values(0.0).copy()
    far = view.vertex_values(30.0)
    assert (far >= x0).all() and far.max() > x0.max()
    target = 7
    view.on_pose(0, 30.0, *LAB.positions[target], 0.0)
    after = view.vertex_values(60.0)
    others = np.delete(after, target)
    assert after[target] < others.max()
    with pytest.raises(ValueError, match="mode"):
        PatrolView(LAB, 1, mode="colourful")


def test_bad_inputs_are_ignored():
    view = PatrolView(LAB, 2)
    view.on_visit(5, 999, 1.0)
    view.on_goal(-1, 2)
    view.on_intention(0, 1, 10_000)
    view.on_pose(0, 0.0, float("nan"), 0.0)
    m = by_ns(view.markers(1.0))
    assert not any(ns in ("footprints", "goals", "intentions") for ns, _ in m)
