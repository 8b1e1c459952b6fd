"""Resolved world files: a world file with everything made explicit, for the C++ node.

World files are parsed once, here in Python (tpuaf_stage.config: presets, patrol maps,
map_server images, start vertices, strict checks naming file and line). The roscpp node
`tpuaf_stage` reads only the resolved form, strictly, with yaml-cpp:

    tpuaf_stage_resolved_world: 1
    source: /abs/world.yaml          # the world file it came from (messages)
    occupancy: world.occupancy.pgm   # binary PGM beside this file: 0 = occupied, 255 = free,
                                     # image row 0 = top of the map
    width: 200                       # [cells]
    height: 200                      # [cells]
    resolution: 0.05                 # [m]
    origin: [0.0, 0.0]               # [m] lower-left corner of cell (0, 0)
    seed: 0
    robot: {radius, max_linear_speed, ..., base_link_z}        # every RobotModel field
    laser: {beams, angle_min, angle_increment, range_min, range_max, noise_std, rate,
            no_return_range, x, y, z, yaw}                      # effective values
    robots: [[x, y, theta], ...]     # [m, m, rad] initial poses, map frame
    summary: "{...}"                 # the effective values, for the node's start-up log

`tpuaf fleet` resolves its world file before roslaunch; given a plain world file the node runs
`python3 -m tpuaf_stage.resolve WORLD FOLDER` once at start-up (never on its hot path).
Exit code 2 and a one-line error (file:line) on a bad world file.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

from .config import WorldConfig, WorldError, load_world

RESOLVED_KEY = "tpuaf_stage_resolved_world"
RESOLVED_VERSION = 1


def _float(value: float) -> float:
    return float(value)


def resolved_document(config: WorldConfig, occupancy_name: str) -> dict:
    """The resolved document of `config` (the PGM is written by write_resolved)."""
    r, la = config.robot, config.laser
    h, w = config.occupied.shape
    return {
        RESOLVED_KEY: RESOLVED_VERSION,
        "source": str(Path(config.source).resolve()) if config.source else "",
        "occupancy": occupancy_name,
        "width": int(w),
        "height": int(h),
        "resolution": _float(config.resolution),
        "origin": [_float(config.origin[0]), _float(config.origin[1])],
        "seed": int(config.seed),
        "robot": {"radius": r.radius, "max_linear_speed": r.max_linear_speed,
                  "max_angular_speed": r.max_angular_speed, "max_linear_accel": r.max_linear_accel,
                  "max_angular_accel": r.max_angular_accel, "odom_linear_noise": r.odom_linear_noise,
                  "odom_angular_noise": r.odom_angular_noise, "base_link_z": r.base_link_z},
        "laser": {"beams": int(la.beams), "angle_min": _float(la.first_angle),
                  "angle_increment": _float(la.angle_increment), "range_min": la.range_min,
                  "range_max": la.range_max, "noise_std": la.noise_std, "rate": la.rate,
                  "no_return_range": _float(la.no_return_range), "x": la.x, "y": la.y, "z": la.z,
                  "yaw": la.yaw},
        "robots": [[_float(x), _float(y), _float(th)] for x, y, th in config.poses],
        "summary": repr(config.summary()),
    }


def write_resolved(config: WorldConfig, folder: str | Path, stem: str = "world") -> Path:
    """Write <folder>/<stem>.resolved.yaml and <stem>.occupancy.pgm (atomically); the YAML path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    pgm = folder / f"{stem}.occupancy.pgm"
    h, w = config.occupied.shape
    pixels = np.where(config.occupied[::-1], 0, 255).astype(np.uint8)  # image row 0 = top
    _atomic_write(pgm, f"P5\n{w} {h}\n255\n".encode() + pixels.tobytes())
    doc = resolved_document(config, pgm.name)
    path = folder / f"{stem}.resolved.yaml"
    _atomic_write(path, yaml.safe_dump(doc, sort_keys=False, width=1 << 20).encode())
    return path


def _atomic_write(path: Path, data: bytes) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def is_resolved(path: str | Path) -> bool:
    try:
        doc = yaml.safe_load(Path(path).read_text())
    except (OSError, yaml.YAMLError):
        return False
    return isinstance(doc, dict) and RESOLVED_KEY in doc


def main(argv: list[str] | None = None) -> int:
    """python -m tpuaf_stage.resolve WORLD FOLDER: prints the resolved file's path."""
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 2:
        print("usage: python3 -m tpuaf_stage.resolve WORLD_FILE OUT_FOLDER", file=sys.stderr)
        return 2
    try:
        config = load_world(argv[0])
        path = write_resolved(config, argv[1])
    except WorldError as err:
        print(str(err), file=sys.stderr)
        return 2
    except OSError as err:
        print(f"{argv[1]}: cannot write the resolved world: {err.strerror}", file=sys.stderr)
        return 2
    print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
