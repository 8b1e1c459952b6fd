"""Where the installed package keeps its data, found through the package, never the source tree.

- `data_path(...)`: files shipped inside the Python package (`tpuaf/data/`: built-in maps).
- `catkin_prefix()`: the catkin devel or install space holding this package (its `env.sh`
  runs ROS tools with the workspace's environment), or None when it is not in one.
"""

from __future__ import annotations

from pathlib import Path

import tpuaf

DATA_DIR = Path(__file__).resolve().parent / "data"


def data_path(*parts: str) -> Path:
    return DATA_DIR.joinpath(*parts)


def catkin_prefix() -> Path | None:
    """The devel or install space whose lib/python3/dist-packages holds `tpuaf` (catkin's
    devel space keeps a loader there; an install space keeps the package itself)."""
    for entry in getattr(tpuaf, "__path__", []):
        for parent in Path(entry).resolve().parents:
            if (parent / ".catkin").is_file() and (parent / "env.sh").is_file():
                return parent
    return None
