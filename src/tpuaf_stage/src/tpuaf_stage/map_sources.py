"""Where a world file's grid comes from: a map_server YAML (`map:`) or a patrol map
(`patrol_map:`, also the robots' start poses when `robots` is a count).

The one module of tpuaf_stage that uses tpuaf: tpuaf.maps reads map_server YAMLs and patrol maps
(built-in names, map folders, the patrolling_sim importer, occupancy images or corridors from
the graph, start vertices), imported when a world file is parsed. package.xml declares it
(exec_depend tpuaf_ros: at run time only, so catkin's build order has no circle;
tests/test_layers.py checks both). The presets, the world model and resolved world files need
only tpuaf_core.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any


class MapSourceError(Exception):
    """A map named by a world file cannot be read (the message of tpuaf.maps' MapError)."""


def map_server_grid(map_path: Path) -> tuple[Any, str]:
    """(occupancy grid, description) of a map_server YAML."""
    from tpuaf.maps import MapError, load_occupancy

    try:
        grid = load_occupancy(map_path)
    except MapError as err:
        raise MapSourceError(str(err)) from None
    return grid, f"map_server {map_path}"


def patrol_map_grid(ref: str, base: Path, robots: int | None, radius_m: float
                    ) -> tuple[Any, str, list[tuple[float, float, float]] | None]:
    """(occupancy grid, description, start poses) of a patrol map: a built-in name or a path
    (relative to `base`). With a robot count, that many poses [m, m, rad] at its start vertices
    (footprints of radius `radius_m` never overlap), else None."""
    from tpuaf.maps import MapError, load_map, start_poses

    try:
        candidate = (base / ref).expanduser()
        pm = load_map(candidate if ("/" in ref or candidate.exists()) else ref)
        grid = pm.occupancy_grid()
        poses = None if robots is None else start_poses(pm, robots, radius_m)
    except MapError as err:
        raise MapSourceError(str(err)) from None
    return grid, f"patrol map {pm.name} ({pm.source or ref})", poses
