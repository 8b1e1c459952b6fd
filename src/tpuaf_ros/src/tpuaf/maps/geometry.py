"""Geometry checks of a loaded map: where its vertices lie, how long its edges are, its starts.

Refused (MapError naming the map file): a coordinate farther than MAX_COORDINATE_M from the
origin; two vertices closer than COINCIDENT_M (on the same spot: `PatrolMap.graph` checks it,
before the core sees the graph); a vertex outside the occupancy image or on an occupied (or unknown) cell, unless the
caller allows it (`--allow-occupied-vertices`: then a warning); the same start vertex twice for
one team size. Warned (PatrolMap.warnings): an edge shorter than the straight line between its
vertices; a graph whose declared size or bounds exceed its image.
"""

from __future__ import annotations

import math

import numpy as np

from tpuaf.errors import MapError

MAX_COORDINATE_M = 1.0e5  # [m] 100 km: beyond, a coordinate is a unit or typing mistake
SHORT_EDGE_TOLERANCE = 0.01  # relative: an edge this much shorter than the straight line warns
MAX_LISTED = 5  # vertices / edges named in one message
COINCIDENT_M = 1e-3  # [m] two vertices closer than this are on the same spot


def _where(patrol_map) -> str:
    return f"{patrol_map.source}" if patrol_map.source else f"map '{patrol_map.name}'"


def _listing(items: list[str], total: int) -> str:
    more = f" and {total - len(items)} more" if total > len(items) else ""
    return ", ".join(items) + more


def check_coordinates(patrol_map) -> None:
    """Every vertex within MAX_COORDINATE_M [m] of the origin (before any grid is built)."""
    pos = np.asarray(patrol_map.positions, dtype=float).reshape(-1, 2)
    far = np.flatnonzero(~(np.abs(pos) <= MAX_COORDINATE_M).all(axis=1))
    if far.size:
        i = int(far[0])
        raise MapError(
            f"{_where(patrol_map)}: vertex {patrol_map.vertex_ids[i]} at "
            f"({pos[i, 0]:g}, {pos[i, 1]:g}) m lies beyond {MAX_COORDINATE_M:g} m of the origin"
            + (f" ({far.size} vertices do)" if far.size > 1 else "")
        )


def coincident_pairs(positions, tol_m: float = COINCIDENT_M) -> list[tuple[int, int]]:
    """Index pairs (i < j) of vertices closer than `tol_m` [m] (sorted by x, neighbours in x
    compared: no all-pairs matrix)."""
    pos = np.asarray(positions, dtype=float)
    if pos.ndim != 2 or pos.shape[1] != 2:
        return []  # the core names a malformed position array
    order = np.argsort(pos[:, 0], kind="stable")
    p = pos[order]
    pairs = []
    for k in range(1, len(p)):
        near = p[k:, 0] - p[:-k, 0] < tol_m
        if not near.any():
            break
        close = near & (np.hypot(p[k:, 0] - p[:-k, 0], p[k:, 1] - p[:-k, 1]) < tol_m)
        for a in np.flatnonzero(close):
            i, j = int(order[a]), int(order[a + k])
            pairs.append((min(i, j), max(i, j)))
    return sorted(pairs)


def check_coincident(patrol_map) -> None:
    """Two vertices on the same spot (closer than COINCIDENT_M) are refused."""
    pairs = coincident_pairs(patrol_map.positions)
    if not pairs:
        return
    ids = patrol_map.vertex_ids
    pos = np.asarray(patrol_map.positions, dtype=float)
    listed = [f"{ids[i]} and {ids[j]} at ({pos[i, 0]:g}, {pos[i, 1]:g})" for i, j in pairs]
    raise MapError(f"{_where(patrol_map)}: vertices on the same spot (closer than "
                   f"{COINCIDENT_M:g} m): {_listing(listed[:MAX_LISTED], len(listed))}; "
                   "merge them or move one")


def grid_holds_every_vertex(patrol_map) -> bool:
    """True when the grid is still to be generated from the graph over the vertices' own
    bounding box: its corridors put a free disc of one corridor width (at least 4 cells) round
    every vertex, so no vertex can be outside it or occupied (and no grid need be built)."""
    return patrol_map.occupancy is None and patrol_map.bounds is None


def check_vertices_free(patrol_map, allow_occupied: bool = False) -> list[str]:
    """Vertices outside the occupancy grid or on an occupied cell: MapError, or warnings when
    `allow_occupied`. Returns the warnings."""
    if grid_holds_every_vertex(patrol_map):
        return []
    grid = patrol_map.occupancy_grid()
    outside, occupied = [], []
    for i, (x, y) in enumerate(np.asarray(patrol_map.positions, dtype=float)):
        row, col = grid.cell_of(x, y)
        label = f"{patrol_map.vertex_ids[i]} ({x:g}, {y:g})"
        if row < 0 or col < 0 or row >= grid.height or col >= grid.width:
            outside.append(label)
        elif grid.occupied[row, col]:
            occupied.append(label)
    problems = []
    if outside:
        x0, y0, x1, y1 = grid.extent
        problems.append(
            f"{len(outside)} vertices outside the occupancy image (x {x0:g} .. {x1:g} m, "
            f"y {y0:g} .. {y1:g} m): {_listing(outside[:MAX_LISTED], len(outside))}")
    if occupied:
        problems.append(
            f"{len(occupied)} vertices on occupied or unknown cells: "
            f"{_listing(occupied[:MAX_LISTED], len(occupied))}")
    if not problems:
        return []
    if not allow_occupied:
        raise MapError(f"{_where(patrol_map)}: {'; '.join(problems)} "
                       "(--allow-occupied-vertices accepts them)")
    return [f"{p} (accepted: --allow-occupied-vertices)" for p in problems]


def check_edges(patrol_map) -> list[str]:
    """Warnings for edges shorter than the straight line between their vertices."""
    pos = np.asarray(patrol_map.positions, dtype=float)
    short = []
    for u, v, length in patrol_map.edges:
        if length is None or not math.isfinite(length):
            continue  # NaN = the straight line itself
        straight = float(np.hypot(*(pos[u] - pos[v])))
        if length < straight * (1.0 - SHORT_EDGE_TOLERANCE) - 1e-9:
            short.append(f"{patrol_map.vertex_ids[u]}-{patrol_map.vertex_ids[v]} "
                         f"({length:g} m < {straight:.3g} m)")
    if not short:
        return []
    return [f"{len(short)} edges shorter than the straight line between their vertices: "
            f"{_listing(short[:MAX_LISTED], len(short))}"]


def check_starts(patrol_map) -> None:
    """The same start vertex (or pose) twice for one team size is refused."""
    s = patrol_map.settings
    for team, ids in sorted(s.initial_vertices.items()):
        dup = sorted({v for v in ids if list(ids).count(v) > 1})
        if dup:
            raise MapError(f"{_where(patrol_map)}: initial_vertices[{team}] starts several robots "
                           f"at vertex {', '.join(map(str, dup))}")
    for team, poses in sorted(s.initial_poses.items()):
        seen = {}
        for k, (x, y) in enumerate(poses):
            key = (float(x), float(y))
            if key in seen:
                raise MapError(f"{_where(patrol_map)}: initial poses for {team} robots start "
                               f"robots {seen[key]} and {k} at the same pose ({x:g}, {y:g}) m")
            seen[key] = k


def check_geometry(patrol_map, allow_occupied_vertices: bool = False) -> list[str]:
    """All checks above; returns the warnings (also appended to `patrol_map.warnings`)."""
    check_coordinates(patrol_map)
    check_starts(patrol_map)
    warnings = check_vertices_free(patrol_map, allow_occupied_vertices)
    warnings += check_edges(patrol_map)
    if patrol_map.bounds is not None and patrol_map.occupancy is not None and \
            getattr(patrol_map.occupancy, "source", None) is not None:
        x0, y0, x1, y1 = patrol_map.occupancy.extent
        bx0, by0, bx1, by1 = patrol_map.bounds
        if bx0 < x0 or by0 < y0 or bx1 > x1 or by1 > y1:
            warnings.append(f"bounds {list(patrol_map.bounds)} m exceed the image "
                            f"({x0:g}, {y0:g}, {x1:g}, {y1:g}) m")
    for w in warnings:
        if w not in patrol_map.warnings:
            patrol_map.warnings.append(w)
    return warnings
