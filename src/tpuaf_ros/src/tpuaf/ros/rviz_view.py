"""rviz_view node: RViz framed on the patrol map in use. With `--config auto` it writes the
shipped config (`--template`) with its top-down view centred on the map and zoomed to show all
of it (tpuaf.measure.rviz_view) into $ROS_HOME/tpuaf_rviz/, then runs RViz on it (exec: this
process becomes RViz); with a config file, RViz runs on that file as it is. ROS arguments
(__name:=..., remappings) are passed on to RViz. rviz.launch starts it."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="rviz_view", description=__doc__.splitlines()[0])
    p.add_argument("--map", required=True, help="patrol map: built-in name or map folder path")
    p.add_argument("--config", default="auto",
                   help="RViz config file, or auto: the template framed on the map")
    p.add_argument("--template", required=True, help="RViz config to frame (rviz/tpuaf.rviz)")
    p.add_argument("--rviz", default="rviz", help="the RViz program")
    return p


def framed_file(map_ref: str, template: Path) -> Path:
    """The template framed on map `map_ref`, written under $ROS_HOME/tpuaf_rviz (or ~/.ros)."""
    from tpuaf.files import atomic_write_text
    from tpuaf.maps import load_map
    from tpuaf.measure.rviz_view import framed_config, map_extent

    pm = load_map(map_ref, allow_occupied_vertices=True)  # a view: the nodes check the map
    text = framed_config(template.read_text(), map_extent(pm), pm.name)
    home = Path(os.environ.get("ROS_HOME") or Path.home() / ".ros")
    out = home / "tpuaf_rviz" / f"{pm.name}.rviz"
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out, text)
    return out


def entry(argv: list[str] | None = None) -> int:
    from tpuaf.errors import TpuafError

    argv = sys.argv[1:] if argv is None else argv
    ros_args = [a for a in argv if a.startswith("__") or ":=" in a]
    args = _parser().parse_args([a for a in argv if a not in ros_args])
    config = Path(args.config)
    if args.config == "auto":
        try:
            config = framed_file(args.map, Path(args.template))
        except (TpuafError, OSError, ValueError) as err:
            print(f"rviz_view: error: {' '.join(str(err).split())}", file=sys.stderr)
            return 2
    elif not config.is_file():
        print(f"rviz_view: error: RViz config {config} not found", file=sys.stderr)
        return 2
    try:
        os.execvp(args.rviz, [args.rviz, "-d", str(config), *ros_args])
    except OSError as err:
        print(f"rviz_view: error: cannot run {args.rviz}: {err.strerror or err}",
              file=sys.stderr)
        return 2
    return 0  # not reached: exec replaced this process
