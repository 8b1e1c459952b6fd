"""The global planner binding (tpuaf_core.Costmap, GridPlanner): small numpy grids checked by
hand, and every edge of the reference maps when ../shared is there."""

from __future__ import annotations

import math

import numpy as np
import pytest
import tpuaf_core as tc

RES = 0.05  # [m per cell] of the small grids
INSCRIBED = 0.2  # [m], the CostmapSpec default


def wall_with_gap(h=80, w=80):
    """Wall x in [2.0, 2.05) m with a gap y in [3.0, 3.6) m."""
    g = np.zeros((h, w), dtype=bool)
    g[:, 40] = True
    g[60:72, 40] = False
    return g


def clearance(grid: np.ndarray, res: float, origin, points: np.ndarray, cap: float) -> np.ndarray:
    """Exact distance [m] from each point to the occupied squares and the outside of the grid,
    capped at cap (only cells within cap are looked at)."""
    h, w = grid.shape
    x = points[:, 0] - origin[0]
    y = points[:, 1] - origin[1]
    out = np.minimum.reduce([x, y, w * res - x, h * res - y, np.full(len(x), cap)])
    reach = int(math.ceil(cap / res)) + 2
    offsets = np.arange(-reach, reach + 1)
    col0 = np.floor(x / res).astype(int)
    row0 = np.floor(y / res).astype(int)
    for dr in offsets:
        for dc in offsets:
            r, c = row0 + dr, col0 + dc
            inside = (r >= 0) & (c >= 0) & (r < h) & (c < w)
            occ = np.zeros(len(x), dtype=bool)
            occ[inside] = grid[r[inside], c[inside]]
            gx = np.maximum.reduce([c * res - x, np.zeros(len(x)), x - (c + 1) * res])
            gy = np.maximum.reduce([r * res - y, np.zeros(len(x)), y - (r + 1) * res])
            out = np.where(occ, np.minimum(out, np.hypot(gx, gy)), out)
    return out


def samples(plan: tc.Plan, step: float) -> np.ndarray:
    """Points every `step` [m] along the plan, from its (snapped) start."""
    pts = plan.points[1:] if plan.start_snapped else plan.points
    out = [pts[:1]]
    for a, b in zip(pts[:-1], pts[1:], strict=True):
        n = max(1, int(math.ceil(np.linalg.norm(b - a) / step)))
        out.append(a + (b - a) * (np.arange(1, n + 1) / n)[:, None])
    return np.concatenate(out)


def test_costmap_arrays_and_queries():
    g = np.zeros((81, 81), dtype=bool)
    g[40, 40] = True
    cm = tc.Costmap(g, RES)
    assert (cm.width, cm.height, cm.downsample) == (81, 81, 1)
    assert cm.map_distances().shape == (81, 81) and cm.costs().shape == (81, 81)
    assert cm.lethal().dtype == bool
    x, y = 45.5 * RES, 40.5 * RES  # 4 cells (0.2 m) right of the occupied cell: cost 1
    assert cm.distance_to_obstacle(x, y) == pytest.approx(0.2, abs=1e-6)
    assert not cm.is_lethal(x, y) and cm.cost(x, y) == pytest.approx(1.0)
    assert cm.is_lethal(44.5 * RES, y)
    assert cm.cost(46.5 * RES, y) == pytest.approx(math.exp(-5 * 0.05), abs=1e-6)
    assert cm.cost(60.5 * RES, y) == 0.0
    coarse = tc.Costmap(g, RES, (0.0, 0.0), tc.CostmapSpec(), planning_resolution_m=0.1)
    assert (coarse.width, coarse.height, coarse.downsample, coarse.resolution) == (41, 41, 2, 0.1)
    assert coarse.lethal()[:, -1].all()  # the half-covered last column overhangs the map


def test_plan_through_a_gap_keeps_clearance():
    g = wall_with_gap()
    planner = tc.GridPlanner(tc.Costmap(g, RES))
    plan = planner.plan((1.0, 1.0), (3.05, 1.0))
    assert plan.ok and plan and plan.status == tc.PlanStatus.ok
    assert plan.points.shape[1] == 2
    np.testing.assert_allclose(plan.points[0], (1.0, 1.0))
    np.testing.assert_allclose(plan.points[-1], (3.05, 1.0))
    assert plan.points[:, 1].max() > 3.2  # over the wall end, through the gap
    steps = np.linalg.norm(np.diff(plan.points, axis=0), axis=1)
    assert plan.length_m == pytest.approx(steps.sum())
    assert 4.98 < plan.length_m < 5.4  # continuous optimum with 0.2 m clearance: 4.983 m
    assert clearance(g, RES, (0, 0), samples(plan, RES / 4), 0.5).min() >= INSCRIBED - 1e-9


def test_no_path_is_a_status():
    g = np.zeros((80, 80), dtype=bool)
    g[44, 44:77] = g[76, 44:77] = g[44:77, 44] = g[44:77, 76] = True  # box around (3, 3)
    planner = tc.GridPlanner(tc.Costmap(g, RES))
    plan = planner.plan((1.0, 1.0), (3.0, 3.0))
    assert plan.status == tc.PlanStatus.no_path and not plan
    assert plan.points.shape == (0, 2) and plan.length_m == 0.0
    assert math.isinf(planner.path_length((1.0, 1.0), (3.0, 3.0)))
    assert planner.plan((-1.0, 1.0), (1.0, 1.0)).status == tc.PlanStatus.start_blocked


def test_snapping_and_options():
    g = np.zeros((80, 80), dtype=bool)
    g[:, 40] = True
    planner = tc.GridPlanner(tc.Costmap(g, RES))
    plan = planner.plan((1.9, 2.01), (1.0, 2.0))
    assert plan.ok and plan.start_snapped and not plan.goal_snapped
    np.testing.assert_allclose(plan.points[0], (1.9, 2.01))
    np.testing.assert_allclose(plan.points[1], plan.start)
    assert plan.start == pytest.approx((1.775, 2.025))
    planner.options = tc.PlannerOptions(snap_radius_m=0.05)
    assert planner.plan((1.9, 2.01), (1.0, 2.0)).status == tc.PlanStatus.start_blocked
    planner.options = tc.PlannerOptions(smooth=False)
    raw = planner.plan((0.5, 0.5), (1.5, 3.5))
    assert raw.ok and len(raw.points) > 20  # the cell path, every cell


def test_temporary_obstacles():
    g = np.zeros((80, 80), dtype=bool)
    g[:30] = True  # y < 1.5 m
    g[50:] = True  # y >= 2.5 m: a corridor 1 m wide
    planner = tc.GridPlanner(tc.Costmap(g, RES))
    free = planner.plan((0.5, 2.0), (3.5, 2.0))
    assert free.ok
    for obstacles in ([(2.0, 2.0, 0.3)], np.array([[2.0, 2.0, 0.3]]), ((2.0, 2.0, 0.3),)):
        assert planner.plan((0.5, 2.0), (3.5, 2.0), obstacles).status == tc.PlanStatus.no_path
    assert planner.plan((0.5, 2.0), (3.5, 2.0), []).ok
    assert planner.plan((0.5, 2.0), (3.5, 2.0), None).ok
    np.testing.assert_array_equal(planner.plan((0.5, 2.0), (3.5, 2.0)).points, free.points)
    with pytest.raises(ValueError):
        planner.plan((0.5, 2.0), (3.5, 2.0), [(2.0, 2.0, 0.0)])
    with pytest.raises(ValueError):
        planner.plan((0.5, 2.0), (3.5, 2.0), [(2.0, 2.0)])


def test_plan_edges_and_invalid_arguments():
    g = wall_with_gap()
    planner = tc.GridPlanner(tc.Costmap(g, RES))
    vertices = np.array([[1.0, 1.0], [3.05, 1.0], [1.0, 3.5], [3.05, 3.5]])
    edges = [(0, 1), (0, 2), (3, 1), (2, 3)]
    plans = planner.plan_edges(vertices, edges)
    assert [p.status for p in plans] == [tc.PlanStatus.ok] * 4
    for (u, v), p in zip(edges, plans, strict=True):
        np.testing.assert_allclose(p.points[0], vertices[u])
        np.testing.assert_allclose(p.points[-1], vertices[v])
        assert p.length_m == pytest.approx(planner.path_length(vertices[u], vertices[v]), abs=0.1)
    again = planner.plan_edges(vertices, np.array(edges))
    for a, b in zip(plans, again, strict=True):
        np.testing.assert_array_equal(a.points, b.points)  # deterministic
    assert planner.plan_edges(vertices, []) == []
    with pytest.raises(ValueError, match="unknown vertex 7"):
        planner.plan_edges(vertices, [(0, 7)])
    with pytest.raises(ValueError):
        planner.plan((math.nan, 1.0), (2.0, 2.0))
    with pytest.raises(ValueError):
        tc.Costmap(g, 0.0)
    with pytest.raises(ValueError):
        tc.Costmap(g, RES, spec=tc.CostmapSpec(inscribed_radius_m=0.5, inflation_radius_m=0.3))


@pytest.mark.parametrize("name", ["DIAG_labs", "cumberland"])
def test_every_edge_of_a_reference_map(shared_maps, name):
    from tpuaf.maps import load_map

    pm = load_map(shared_maps / name)
    grid = pm.occupancy_grid()
    cm = tc.Costmap(grid.occupied, grid.resolution, grid.origin, tc.CostmapSpec(), 0.1)
    planner = tc.GridPlanner(cm)
    edges = np.array([(u, v) for u, v, *_ in pm.edges])
    plans = planner.plan_edges(pm.positions, edges)
    failed = [(tuple(e), str(p.status)) for e, p in zip(edges, plans, strict=True) if not p.ok]
    assert not failed
    for (u, v), p in zip(edges, plans, strict=True):
        straight = np.linalg.norm(pm.positions[v] - pm.positions[u])
        assert p.length_m >= straight - 1e-9
        assert p.length_m < 3 * straight + 2.0  # an edge is a local connection
        pts = samples(p, grid.resolution / 4)
        gap = clearance(grid.occupied, grid.resolution, grid.origin, pts, 0.4)
        assert gap.min() >= INSCRIBED - 1e-9, (u, v)
    # Across the whole map: the farthest pair of vertices along the graph.
    d = pm.graph.distances
    i, j = np.unravel_index(np.argmax(d), d.shape)
    plan = planner.plan(pm.positions[i], pm.positions[j])
    assert plan.ok
    assert plan.length_m <= d[i, j] + 1.0  # not longer than the graph's own route, give or take
