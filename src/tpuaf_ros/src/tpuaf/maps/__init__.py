"""Patrol maps: built-in maps, our map folders, patrolling_sim imports (SPEC section 7)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from tpuaf.errors import MapError
from tpuaf.maps.model import MapSettings, PatrolMap
from tpuaf.maps.occupancy import OccupancyGrid, corridors_from_graph, load_occupancy

__all__ = [
    "MapError",
    "MapSettings",
    "OccupancyGrid",
    "PatrolMap",
    "builtin_map_names",
    "corridors_from_graph",
    "load_map",
    "load_occupancy",
    "map_summary",
    "start_poses",
    "start_vertices",
]


def builtin_map_names() -> list[str]:
    from tpuaf.maps.builtin import GENERATORS

    return sorted(GENERATORS)


def load_map(name_or_path: str | Path, allow_occupied_vertices: bool = False,
             params: dict | None = None, params_origin: str = "map parameters") -> PatrolMap:
    """A built-in map by name (`grid`, `lab`), or a path: a folder of ours (with map.yaml), a
    patrolling_sim folder (with a .graph file) or a .graph file. Every map is checked
    (connected graph, valid lengths) and comes with an occupancy grid (from its image, or
    corridors generated from the graph when first asked for: `occupancy_grid()`), and its
    geometry is checked (tpuaf.maps.geometry: vertices on free cells, unless
    `allow_occupied_vertices`; doubts in `warnings`). `params` ({key: value},
    tpuaf.maps.params.USER_PARAMS) override the map's settings; errors name `params_origin`
    (e.g. '--map-param')."""
    from tpuaf.maps.builtin import BUILTIN_MAPS_DIR, GENERATORS
    from tpuaf.maps.mapfile import load_map_folder
    from tpuaf.maps.patrolling_sim import load_patrolling_sim

    text = str(name_or_path)
    if isinstance(name_or_path, str) and text in GENERATORS:
        folder = BUILTIN_MAPS_DIR / text
        pm = load_map_folder(folder) if (folder / "map.yaml").is_file() else GENERATORS[text]()
    else:
        path = Path(name_or_path).expanduser()
        if path.is_dir() and (path / "map.yaml").is_file():
            pm = load_map_folder(path)
        elif path.is_dir() and any(path.glob("*.graph")):
            pm = load_patrolling_sim(path)
        elif path.is_file() and path.suffix == ".graph":
            pm = load_patrolling_sim(path)
        elif path.is_file() and path.name == "map.yaml":
            pm = load_map_folder(path.parent)
        elif path.exists():
            raise MapError(
                f"{path}: not a map (expected a folder with map.yaml, a patrolling_sim folder "
                "with a .graph file, or a .graph file)"
            )
        elif "/" in text or text.startswith((".", "~")):  # meant as a path, not a name
            raise MapError(f"no such map folder {text}")
        else:
            raise MapError(
                f"unknown map '{text}': built-in maps are {', '.join(builtin_map_names())}; "
                "otherwise give the path of a map folder (map.yaml), a patrolling_sim folder "
                "or a .graph file"
            )
    from tpuaf.maps.geometry import check_coordinates, check_geometry
    from tpuaf.maps.params import apply_map_params

    apply_map_params(pm, params or {}, params_origin)
    pm.graph  # noqa: B018 - validate now
    check_coordinates(pm)  # before a grid is generated from them
    check_geometry(pm, allow_occupied_vertices)  # builds the grid only if a check needs it
    return pm


def start_vertices(patrol_map: PatrolMap, n_robots: int) -> list[int]:
    """Start vertex (graph index) of each robot.

    1. the map's `initial_vertices[n_robots]` (vertex ids);
    2. else its `initial_poses[n_robots]` [m], each snapped to the nearest vertex not yet taken
       (robots in order), so that start vertices stay distinct;
    3. else a deterministic spread: farthest-point sampling on shortest-path distances starting
       at vertex index 0 (ties to the lowest index).
    Vertices are distinct while n_robots <= number of vertices; beyond that the sequence wraps
    around (robot k gets the start of robot k - n_vertices), so some robots share a start.
    """
    if n_robots <= 0:
        raise MapError(f"need at least one robot, got {n_robots}")
    s = patrol_map.settings
    n = patrol_map.num_vertices
    if n_robots in s.initial_vertices:
        return [patrol_map.index_of(v) for v in s.initial_vertices[n_robots]]
    if n_robots in s.initial_poses:
        taken: list[int] = []
        for x, y in s.initial_poses[n_robots]:
            d = np.hypot(patrol_map.positions[:, 0] - x, patrol_map.positions[:, 1] - y)
            if len(taken) < n:
                d[taken] = np.inf
            taken.append(int(np.argmin(d)))
        return taken
    graph = patrol_map.graph  # one row of shortest paths per start: no all-pairs matrix
    chosen = [0]
    nearest = np.asarray(graph.distances_from(0), dtype=float)
    while len(chosen) < min(n_robots, n):
        nxt = int(np.argmax(nearest))
        chosen.append(nxt)
        nearest = np.minimum(nearest, graph.distances_from(nxt))
    return [chosen[k % n] for k in range(n_robots)]


def map_summary(patrol_map: PatrolMap) -> dict:
    from tpuaf.maps.analysis import map_summary as _summary

    return _summary(patrol_map)


START_CLEARANCE_M = 0.05  # [m] kept between two robots' discs, and between a disc and a wall
START_SEARCH_M = 3.0  # [m] farthest a robot is moved from its start vertex to find room


def start_poses(patrol_map: PatrolMap, n_robots: int, radius_m: float,
                starts: list[int] | None = None) -> list[tuple[float, float, float]]:
    """Start poses (x [m], y [m], yaw 0) of the robots: at their start vertices
    (`start_vertices`), except where a robot's disc would overlap an earlier robot's or a wall:
    it is moved to the nearest free spot on rings around its vertex (0.1 m apart), so that two
    footprints never start on top of each other. MapError when no room is found."""
    starts = start_vertices(patrol_map, n_robots) if starts is None else starts
    grid = patrol_map.occupancy_grid()
    res = float(grid.resolution)
    reach = radius_m + START_CLEARANCE_M
    k = int(math.ceil(reach / res))
    dr, dc = np.mgrid[-k:k + 1, -k:k + 1]
    disc = (np.hypot(dr, dc) * res <= reach + 0.5 * res)
    offsets = np.column_stack((dr[disc], dc[disc]))

    def wall_free(x: float, y: float) -> bool:
        row, col = grid.cell_of(x, y)
        rows, cols = offsets[:, 0] + row, offsets[:, 1] + col
        if rows.min() < 0 or cols.min() < 0 or rows.max() >= grid.height or \
                cols.max() >= grid.width:
            return False
        return not bool(grid.occupied[rows, cols].any())

    placed: list[tuple[float, float, float]] = []
    spacing = 2.0 * radius_m + START_CLEARANCE_M
    for v in starts:
        px, py = (float(c) for c in patrol_map.positions[v])
        found = None
        for ring in range(int(START_SEARCH_M / 0.1) + 1):
            d = 0.1 * ring
            count = 1 if ring == 0 else max(8, int(2 * math.pi * d / 0.1))
            for j in range(count):
                a = 2.0 * math.pi * j / count
                x, y = px + d * math.cos(a), py + d * math.sin(a)
                apart = all(math.hypot(x - q[0], y - q[1]) >= spacing for q in placed)
                # The vertex itself as the map gives it (the world checks its walls); a spot
                # beside it only with room for the disc.
                if apart and (ring == 0 or wall_free(x, y)):
                    found = (x, y, 0.0)
                    break
            if found:
                break
        if found is None:
            raise MapError(f"map '{patrol_map.name}': no room for robot {len(placed)} (radius "
                           f"{radius_m:g} m) within {START_SEARCH_M:g} m of vertex "
                           f"{patrol_map.vertex_ids[v]}")
        placed.append(found)
    return placed
