"""Lanes: the stretches of a map one robot wide, found on the costmap (ROS-free; docs/LANES.md).

A point of a planned path is *narrow* when two robots cannot pass there side by side: the
free band across the path through it (the points at least the inscribed radius, robot radius
+ planner safety margin, from walls: the planner's distance transform) is shorter than two
robot radii + `params.LANE_PASS_MARGIN_M` (`params.pass_band_m`). An edge is narrow when a point of its planned path is; a vertex
when it is narrow across every edge from it (a corner or junction of corridors is not).

A *lane* is a maximal set of narrow edges joined at *interior* vertices: narrow vertices of
degree 1 (a dead end) or 2 (a corridor stop). The other vertices of a lane's edges are its
*waiting spots*: wide vertices, where two robots fit, and junctions (degree >= 3), where
lanes meet. A robot enters a lane only from a waiting spot and only holding the lane
(team/lane_locks.py); a dead end lane has one waiting spot.

A *tight* spot is a corner or junction of one-robot corridors where a robot standing on the
vertex leaves no way round it from one edge to another (`tight_spots`): a robot waiting there
would shut the lane's holder in. Where every edge at a tight spot is narrow and a bridge (no
cycle through it, so the lanes there are locked, not one-way), the spot is interior: the lanes
meeting there are one lane, whose waiting spots lie beyond (the rooms at the corridors' ends).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tpuaf.navigation.one_way import bridges
from tpuaf.params import pass_band_m

SAMPLE_STEP_M = 0.05  # [m] between the checked points of a planned path
LATERAL_STEP_M = 0.025  # [m] between the checked points across it
LANE_REGION_M = 0.2  # [m] points this close to a lane's path are inside the lane ...
SPOT_CLEAR_M = 0.35  # [m] ... except near its waiting spots (a robot waits there)
TIGHT_WINDOW_M = 1.0  # [m] half-width of the square round a spot searched for a way round it


@dataclass(frozen=True)
class Lane:
    """One lane: its edges (u < v), interior vertices and waiting spots (vertex indices)."""

    index: int
    edges: tuple[tuple[int, int], ...]
    interior: tuple[int, ...]
    spots: tuple[int, ...]
    min_width_m: float  # [m] its narrowest band (free robot centres across the way)


@dataclass
class LaneMap:
    """The lanes of a map for one footprint; `lane_of` and `interior_of` answer per edge and
    vertex (-1: in no lane)."""

    lanes: list[Lane]
    edge_width_m: dict[tuple[int, int], float]  # [m] narrowest band along each edge
    narrow_vertices: frozenset[int]
    pass_band_m: float  # [m] a band narrower than this is one robot wide
    region: tuple | None = None  # (lane index per map cell, row 0 at the bottom; origin [m],
    # resolution [m]): where a robot is inside a lane (`lane_at`), None: nowhere
    tight_vertices: frozenset[int] = frozenset()  # spots made interior (module docstring)
    _edge_lane: dict[tuple[int, int], int] = field(default_factory=dict, init=False, repr=False)
    _vertex_lane: dict[int, int] = field(default_factory=dict, init=False, repr=False)

    def __post_init__(self) -> None:
        for lane in self.lanes:
            for e in lane.edges:
                self._edge_lane[e] = lane.index
            for v in lane.interior:
                self._vertex_lane[v] = lane.index

    def lane_of(self, u: int, v: int) -> int:
        """The lane of the edge u-v (either direction), -1 when wide or not an edge."""
        return self._edge_lane.get((min(u, v), max(u, v)), -1)

    def interior_of(self, v: int) -> int:
        """The lane `v` lies inside (not a waiting spot), -1 when none."""
        return self._vertex_lane.get(int(v), -1)

    def lane_at(self, points) -> np.ndarray:
        """The lane each map-frame point (k, 2) [m] lies inside, -1 where none."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        out = np.full(len(points), -1, dtype=int)
        if self.region is None:
            return out
        ids, (ox, oy), res = self.region
        cols = np.floor((points[:, 0] - ox) / res).astype(int)
        rows = np.floor((points[:, 1] - oy) / res).astype(int)
        inside = (rows >= 0) & (rows < ids.shape[0]) & (cols >= 0) & (cols < ids.shape[1])
        out[inside] = ids[rows[inside], cols[inside]]
        return out

    def __bool__(self) -> bool:
        return bool(self.lanes)

    def describe(self, ids) -> list[str]:
        """One line per lane, vertices by their map ids."""
        out = []
        for lane in self.lanes:
            edges = ", ".join(f"{ids[u]}-{ids[v]}" for u, v in lane.edges)
            spots = ", ".join(str(ids[s]) for s in lane.spots) or "none"
            tight = [str(ids[v]) for v in lane.interior if v in self.tight_vertices]
            out.append(f"lane {lane.index}: edges {edges}; waiting spots {spots}; "
                       f"narrowest band {lane.min_width_m:.2f} m"
                       + (f"; through tight junction {', '.join(tight)}" if tight else "")
                       + ("" if lane.spots else
                          " (no waiting spot: robots inside it cannot pass each other)"))
        return out


def _sampled(path: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points along a polyline (k, 2), every SAMPLE_STEP_M at most, and unit normals."""
    points, normals = [path[:1]], []
    for a, b in zip(path[:-1], path[1:], strict=True):
        length = math.hypot(*(b - a))
        k = max(1, int(math.ceil(length / SAMPLE_STEP_M)))
        f = np.arange(1, k + 1)[:, None] / k
        points.append(a + f * (b - a))
        n = np.array([-(b - a)[1], (b - a)[0]]) / max(length, 1e-9)
        normals.append(np.repeat(n[None], k + (0 if normals else 1), axis=0))
    return np.vstack(points), np.vstack(normals) if normals else np.zeros((1, 2))


def band_widths_m(planner, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """[m] per point (k, 2): the length of the free stretch (robot centres at least the
    inscribed radius from walls) across the way (along its normal) through the point; 0 when
    the point itself is not free. Looked at up to twice the pass band either side."""
    half = 2.0 * pass_band_m(planner.robot_radius_m)
    offsets = np.arange(-half, half + 1e-9, LATERAL_STEP_M)
    grid = points[:, None, :] + offsets[None, :, None] * normals[:, None, :]
    free = (planner.distances_to_obstacle(grid.reshape(-1, 2)).reshape(grid.shape[:2])
            >= planner.inscribed_radius_m)
    c = len(offsets) // 2
    # the run of free offsets through the centre: first blocked offset either side
    right = np.where(~free[:, c:], np.arange(len(offsets) - c)[None], len(offsets) - c).min(1)
    left = np.where(~free[:, c::-1], np.arange(c + 1)[None], c + 1).min(1)
    width = (right + left - 1) * LATERAL_STEP_M
    return np.where(free[:, c], np.maximum(width, 0.0), 0.0)


def find_lanes(planner, patrol_map) -> LaneMap:
    """The lanes of `patrol_map` for the footprint of `planner` (navigation.PathPlanner: its
    cached edge paths and distance transform). An edge is narrow where the band across its
    planned path is below `pass_band_m`; a vertex when it is so across every edge from it."""
    need = pass_band_m(planner.robot_radius_m)
    positions = np.asarray(patrol_map.positions, dtype=float)
    planner.check_edges()  # every edge path, planned at once and cached
    widths: dict[tuple[int, int], float] = {}
    at_vertex: dict[int, list[float]] = {}
    for i, j, _ in patrol_map.edges:
        e = (min(int(i), int(j)), max(int(i), int(j)))
        path = planner.edge_path(*e)
        points, normals = _sampled(positions[list(e)] if path is None else np.asarray(path))
        bands = band_widths_m(planner, points, normals)
        widths[e] = float(bands.min())
        at_vertex.setdefault(e[0], []).append(float(bands[0]))
        at_vertex.setdefault(e[1], []).append(float(bands[-1]))
    narrow_v = frozenset(v for v, bands in at_vertex.items() if max(bands) < need)
    cut = bridges(len(positions), list(widths))
    candidates = {v for v in at_vertex if v not in narrow_v and len(at_vertex[v]) >= 2}
    for e, w in widths.items():  # a spot whose every edge is a narrow bridge
        if w >= need or e not in cut:
            candidates.difference_update(e)
    tight = tight_spots(planner, patrol_map, sorted(candidates))
    lane_map = group_lanes(widths, narrow_v, need, len(positions), tight)
    if lane_map:
        lane_map.region = _region(planner, patrol_map, lane_map, positions)
    return lane_map


def tight_spots(planner, patrol_map, vertices) -> frozenset[int]:
    """The vertices among `vertices` where a robot standing on the vertex cuts every edge's
    way out from every other's: with its disc and the pass band round it (`pass_band_m`)
    taken out of the free robot centres within TIGHT_WINDOW_M, no two edges' first path points
    beyond that disc are joined."""
    from scipy.ndimage import label

    positions = np.asarray(patrol_map.positions, dtype=float)
    block = pass_band_m(planner.robot_radius_m)  # [m] a second robot centre is nearer: contact
    offsets = np.arange(-TIGHT_WINDOW_M, TIGHT_WINDOW_M + 1e-9, LATERAL_STEP_M)
    size = len(offsets)
    dx, dy = np.meshgrid(offsets, offsets, indexing="xy")
    away = np.hypot(dx, dy) > block
    out = set()
    for v in vertices:
        centre = positions[v]
        grid = np.stack([centre[0] + dx, centre[1] + dy], axis=-1)
        free = (planner.distances_to_obstacle(grid.reshape(-1, 2)).reshape(size, size)
                >= planner.inscribed_radius_m) & away
        parts, _ = label(free)
        seen = []
        for w in patrol_map.graph.neighbours(int(v)):
            path = planner.edge_path(min(v, w), max(v, w))
            points = np.asarray(positions[[v, w]] if path is None else path, dtype=float)
            if np.hypot(*(points[0] - centre)) > 1e-6:  # the path as planned from w
                points = points[::-1]
            sampled = _sampled(points)[0]
            d = np.hypot(sampled[:, 0] - centre[0], sampled[:, 1] - centre[1])
            beyond = np.nonzero((d > block + LATERAL_STEP_M) & (d < TIGHT_WINDOW_M))[0]
            if len(beyond) == 0:
                seen.append(0)
                continue
            x, y = sampled[beyond[0]] - centre
            col = int(round((x + TIGHT_WINDOW_M) / LATERAL_STEP_M))
            row = int(round((y + TIGHT_WINDOW_M) / LATERAL_STEP_M))
            seen.append(int(parts[min(max(row, 0), size - 1), min(max(col, 0), size - 1)]))
        joined = [p for p in seen if p > 0]
        if len(set(joined)) == len(joined):
            out.add(int(v))
    return frozenset(out)


def _region(planner, patrol_map, lane_map: LaneMap, positions: np.ndarray) -> tuple:
    """Map cells within LANE_REGION_M of a lane's planned paths, away from its waiting spots
    (SPOT_CLEAR_M), marked with the lane's index (see LaneMap.region)."""
    grid = patrol_map.occupancy_grid()
    res = float(grid.resolution)
    ox, oy = float(grid.origin[0]), float(grid.origin[1])
    ids = np.full(np.asarray(grid.occupied).shape, -1, dtype=np.int32)
    reach = int(math.ceil(LANE_REGION_M / res))
    offsets = np.arange(-reach, reach + 1)
    dr, dc = np.meshgrid(offsets, offsets, indexing="ij")
    disc = np.hypot(dr, dc) * res <= LANE_REGION_M
    for lane in lane_map.lanes:
        paths = [planner.edge_path(*e) for e in lane.edges]
        points = np.vstack([_sampled(positions[list(e)] if p is None else np.asarray(p))[0]
                            for e, p in zip(lane.edges, paths, strict=True)])
        spots = positions[list(lane.spots)]
        if len(spots):
            near = np.hypot(points[:, None, 0] - spots[None, :, 0],
                            points[:, None, 1] - spots[None, :, 1]).min(axis=1)
            points = points[near > SPOT_CLEAR_M]
        rows = np.floor((points[:, 1] - oy) / res).astype(int)[:, None] + dr[disc][None]
        cols = np.floor((points[:, 0] - ox) / res).astype(int)[:, None] + dc[disc][None]
        ok = (rows >= 0) & (rows < ids.shape[0]) & (cols >= 0) & (cols < ids.shape[1])
        ids[rows[ok], cols[ok]] = lane.index
    return ids, (ox, oy), res


def group_lanes(edge_width_m: dict[tuple[int, int], float], narrow_vertices: frozenset[int],
                narrow_width_m: float, n_vertices: int,
                tight_vertices: frozenset[int] = frozenset()) -> LaneMap:
    """Lanes from each edge's narrowest free width [m] (edges u < v) and the narrow vertices:
    narrow edges (width below `narrow_width_m`) joined at interior vertices (narrow, degree
    1 or 2, and `tight_vertices`: the tight spots whose every edge is a narrow bridge, as
    find_lanes picks them); the lanes numbered by their smallest edge."""
    degree = [0] * n_vertices
    for u, v in edge_width_m:
        degree[u] += 1
        degree[v] += 1
    interior = {v for v in narrow_vertices if degree[v] <= 2} | set(tight_vertices)
    narrow = sorted(e for e, w in edge_width_m.items() if w < narrow_width_m)
    parent = {e: e for e in narrow}

    def root(e):
        while parent[e] != e:
            parent[e] = parent[parent[e]]
            e = parent[e]
        return e

    by_vertex: dict[int, list] = {}
    for e in narrow:
        for v in e:
            if v in interior:
                by_vertex.setdefault(v, []).append(e)
    for es in by_vertex.values():
        for e in es[1:]:
            parent[root(e)] = root(es[0])
    groups: dict = {}
    for e in narrow:
        groups.setdefault(root(e), []).append(e)
    lanes = []
    for k, es in enumerate(sorted(groups.values())):
        vs = {v for e in es for v in e}
        lanes.append(Lane(k, tuple(es), tuple(sorted(vs & interior)),
                          tuple(sorted(vs - interior)), min(edge_width_m[e] for e in es)))
    return LaneMap(lanes, dict(edge_width_m), frozenset(narrow_vertices), narrow_width_m,
                   tight_vertices=frozenset(tight_vertices))
