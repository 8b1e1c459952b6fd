"""Where the installed package keeps its data, found through the package, never the source tree.

- `builtin_maps_dir()`: the built-in maps. In the source tree (and the devel space, whose loader
  points at it) they are the repository's top-level `maps/`; an install space ships them as
  package data, `tpuaf/data/maps/` (installed by src/tpuaf_ros/CMakeLists.txt).
- `catkin_prefix()`: the catkin devel or install space holding this package (its `env.sh`
  runs ROS tools with the workspace's environment), or None when it is not in one.
"""

from __future__ import annotations

from pathlib import Path

import tpuaf

_PACKAGE_MAPS = Path(__file__).resolve().parent / "data" / "maps"  # install space
_SOURCE_MAPS = Path(__file__).resolve().parents[4] / "maps"  # repo/src/tpuaf_ros/src/tpuaf/..


def builtin_maps_dir() -> Path:
    return _PACKAGE_MAPS if _PACKAGE_MAPS.is_dir() else _SOURCE_MAPS


def catkin_prefix() -> Path | None:
    """The devel or install space whose lib/python3/dist-packages holds `tpuaf` (catkin's
    devel space keeps a loader there; an install space keeps the package itself)."""
    for entry in getattr(tpuaf, "__path__", []):
        for parent in Path(entry).resolve().parents:
            if (parent / ".catkin").is_file() and (parent / "env.sh").is_file():
                return parent
    return None
