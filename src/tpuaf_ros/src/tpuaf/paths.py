"""Where the installed package keeps its data, found through the package, never the source tree.

- `builtin_maps_dir()`: the built-in maps, package data of `tpuaf` (`tpuaf/data/maps/`): in the
  source tree and the devel space (whose loader points at it) a link to the repository's
  top-level `maps/`, in an install space a copy (src/tpuaf_ros/CMakeLists.txt).
- `catkin_prefix()`: the catkin devel or install space holding this package (its `env.sh`
  runs ROS tools with the workspace's environment), or None when it is not in one.
"""

from __future__ import annotations

from pathlib import Path

import tpuaf

_PACKAGE_MAPS = Path(__file__).resolve().parent / "data" / "maps"


def builtin_maps_dir() -> Path:
    return _PACKAGE_MAPS


def catkin_prefix() -> Path | None:
    """The devel or install space whose lib/python3/dist-packages holds `tpuaf` (catkin's
    devel space keeps a loader there; an install space keeps the package itself)."""
    for entry in getattr(tpuaf, "__path__", []):
        for parent in Path(entry).resolve().parents:
            if (parent / ".catkin").is_file() and (parent / "env.sh").is_file():
                return parent
    return None
