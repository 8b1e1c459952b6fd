"""World files of the tpuaf_stage simulator: strict parsing, presets, building the C++ world.

A world file (documented key by key in src/tpuaf_stage/config/world_template.yaml):

    map: ../maps/lab/occupancy.yaml     # a map_server YAML (path relative to this file), or
    patrol_map: grid                    # a patrol map (built-in name or path): its occupancy image
                                        # or corridors generated from its graph
    seed: 0
    robot: {preset: burger, radius: 0.105, ...}
    laser: {preset: lds01, beams: 360, ...}
    robots: [[x, y, theta], ...]        # poses [m, m, rad], or a count with patrol_map

Unknown keys are refused; every error names the file and line (WorldError). The maps are read
by tpuaf_stage.map_sources (the one module that uses tpuaf).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
import tpuaf_core
from tpuaf_core import TpuafError, yamlfile

from .map_sources import MapSourceError, map_server_grid, patrol_map_grid
from .presets import LASER_PRESETS, ROBOT_PRESETS


class WorldError(TpuafError):
    """A world file is malformed; the message names the file and line."""


@dataclass
class RobotModel:
    """Body and drive of every robot. Units in the comments."""

    radius: float  # [m] disc radius
    max_linear_speed: float  # [m/s]
    max_angular_speed: float  # [rad/s]
    max_linear_accel: float  # [m/s^2] (.inf: none)
    max_angular_accel: float  # [rad/s^2] (.inf: none)
    odom_linear_noise: float = 0.0  # std of the relative error of odometry distance [-]
    odom_angular_noise: float = 0.0  # std of the relative error of odometry rotation [-]
    base_link_z: float = 0.010  # [m] base_footprint -> base_link height (tf only)

    def spec(self) -> tpuaf_core.RobotSpec:
        return tpuaf_core.RobotSpec(
            radius_m=self.radius, max_linear_speed=self.max_linear_speed,
            max_angular_speed=self.max_angular_speed, max_linear_accel=self.max_linear_accel,
            max_angular_accel=self.max_angular_accel, odom_linear_noise=self.odom_linear_noise,
            odom_angular_noise=self.odom_angular_noise)


@dataclass
class LaserModel:
    """The 2-D laser of every robot. Units in the comments."""

    beams: int  # number of beams
    fov: float  # [rad] field of view; 2 pi = full circle
    angle_min: float | None  # [rad] first beam; None: 0.0 on a full circle (LDS-01), else -fov/2
    range_min: float  # [m] closer returns read range_min
    range_max: float  # [m]
    noise_std: float  # [m] Gaussian noise on returns
    rate: float  # [Hz] scans per simulated second
    no_return: str | float  # 'inf', 'max' (range_max), 'zero' (0.0, as the real LDS-01) or [m]
    x: float  # [m] base_link -> base_scan
    y: float  # [m]
    z: float  # [m] (tf only)
    yaw: float  # [rad]

    @property
    def full_circle(self) -> bool:
        return self.fov >= 2 * math.pi - 1e-9

    @property
    def angle_increment(self) -> float:
        """[rad] between beams: fov / beams on a full circle, else fov / (beams - 1)."""
        if self.full_circle or self.beams == 1:
            return self.fov / self.beams
        return self.fov / (self.beams - 1)

    @property
    def first_angle(self) -> float:
        if self.angle_min is not None:
            return self.angle_min
        return 0.0 if self.full_circle else -self.fov / 2

    @property
    def no_return_range(self) -> float:
        if isinstance(self.no_return, str):
            return {"inf": math.inf, "max": self.range_max, "zero": 0.0}[self.no_return]
        return float(self.no_return)

    def spec(self) -> tpuaf_core.LaserSpec:
        return tpuaf_core.LaserSpec(
            beams=self.beams, angle_min_rad=self.first_angle,
            angle_increment_rad=self.angle_increment, range_min_m=self.range_min,
            range_max_m=self.range_max, noise_std_m=self.noise_std,
            no_return_range=self.no_return_range, x_offset_m=self.x, y_offset_m=self.y,
            yaw_offset_rad=self.yaw)


@dataclass
class WorldConfig:
    source: Path | None
    occupied: np.ndarray  # bool (h, w), row 0 at the bottom
    resolution: float  # [m]
    origin: tuple[float, float]  # [m]
    robot: RobotModel
    laser: LaserModel
    poses: list[tuple[float, float, float]]  # initial [m, m, rad], map frame
    seed: int = 0
    map_description: str = ""
    robot_preset: str = ""
    laser_preset: str = ""
    extra: dict = field(default_factory=dict)

    def build(self) -> tpuaf_core.World:
        """The C++ world with every robot placed; WorldError if a robot overlaps a wall/robot."""
        world = tpuaf_core.World(self.occupied, self.resolution, self.origin, seed=self.seed)
        robot, laser = self.robot.spec(), self.laser.spec()
        for i, pose in enumerate(self.poses):
            try:
                world.add_robot(pose, robot, laser)
            except ValueError as err:
                raise WorldError(f"{self.source or 'world'}: robots[{i}]: {err}") from None
        return world

    def summary(self) -> dict:
        """Effective values, for the start-up log."""
        return {
            "world_file": str(self.source) if self.source else None,
            "map": self.map_description,
            "grid": f"{self.occupied.shape[1]} x {self.occupied.shape[0]} cells at "
                    f"{self.resolution} m, origin {tuple(self.origin)} m",
            "seed": self.seed,
            "robots": len(self.poses),
            "robot": {"preset": self.robot_preset, **asdict(self.robot)},
            "laser": {"preset": self.laser_preset, **asdict(self.laser),
                      "angle_min_effective": self.laser.first_angle,
                      "angle_increment": self.laser.angle_increment},
        }


# ---------------------------------------------------------------------------------------------
# Parsing

WORLD_KEYS = {"map", "patrol_map", "seed", "robot", "laser", "robots"}
ROBOT_KEYS = {"preset"} | {f.name for f in fields(RobotModel)}
LASER_KEYS = {"preset"} | {f.name for f in fields(LaserModel)}


def _where(path: Path | None, node: Any = None) -> str:
    return yamlfile.where(path if path else "world", node)


def _check_keys(path: Path | None, node: Any, allowed: set[str], what: str) -> None:
    yamlfile.check_keys(node, allowed, what, _where(path, node), WorldError)


def _number(path, node, key, value, *, lo=None, positive=False, allow_inf=False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value) or (
            math.isinf(value) and not allow_inf):
        raise WorldError(f"{_where(path, node)}: '{key}' must be a {'' if allow_inf else 'finite '}"
                         f"number, got {value!r}")
    if positive and not value > 0:
        raise WorldError(f"{_where(path, node)}: '{key}' must be > 0, got {value}")
    if lo is not None and value < lo:
        raise WorldError(f"{_where(path, node)}: '{key}' must be >= {lo}, got {value}")
    return float(value)


def _with_preset(path, node, presets: dict, default: str, what: str) -> tuple[str, dict]:
    name = node.get("preset", default)
    if not isinstance(name, str) or name not in presets:
        raise WorldError(f"{_where(path, node)}: unknown {what} preset {name!r} "
                         f"(known: {', '.join(sorted(presets))})")
    values = dict(presets[name])
    values.update({k: v for k, v in node.items() if k != "preset"})
    return name, values


def parse_robot(path, node) -> tuple[str, RobotModel]:
    node = {} if node is None else node
    _check_keys(path, node, ROBOT_KEYS, "robot")
    name, v = _with_preset(path, node, ROBOT_PRESETS, "burger", "robot")
    model = RobotModel(
        radius=_number(path, node, "radius", v["radius"], positive=True),
        max_linear_speed=_number(path, node, "max_linear_speed", v["max_linear_speed"], positive=True),
        max_angular_speed=_number(path, node, "max_angular_speed", v["max_angular_speed"],
                                  positive=True),
        max_linear_accel=_number(path, node, "max_linear_accel", v["max_linear_accel"],
                                 positive=True, allow_inf=True),
        max_angular_accel=_number(path, node, "max_angular_accel", v["max_angular_accel"],
                                  positive=True, allow_inf=True),
        odom_linear_noise=_number(path, node, "odom_linear_noise", v["odom_linear_noise"], lo=0.0),
        odom_angular_noise=_number(path, node, "odom_angular_noise", v["odom_angular_noise"], lo=0.0),
        base_link_z=_number(path, node, "base_link_z", v["base_link_z"]),
    )
    return name, model


def parse_laser(path, node) -> tuple[str, LaserModel]:
    node = {} if node is None else node
    _check_keys(path, node, LASER_KEYS, "laser")
    name, v = _with_preset(path, node, LASER_PRESETS, "lds01", "laser")
    beams = v["beams"]
    if isinstance(beams, bool) or not isinstance(beams, int) or beams < 1:
        raise WorldError(f"{_where(path, node)}: 'beams' must be an integer >= 1, got {beams!r}")
    fov = _number(path, node, "fov", v["fov"], positive=True)
    if fov > 2 * math.pi + 1e-9:
        raise WorldError(f"{_where(path, node)}: 'fov' must be <= 2 pi rad, got {fov}")
    angle_min = v["angle_min"]
    if angle_min is not None:
        angle_min = _number(path, node, "angle_min", angle_min)
    range_min = _number(path, node, "range_min", v["range_min"], lo=0.0)
    range_max = _number(path, node, "range_max", v["range_max"], positive=True)
    if not range_max > range_min:
        raise WorldError(f"{_where(path, node)}: 'range_max' ({range_max}) must be > 'range_min' "
                         f"({range_min})")
    no_return = v["no_return"]
    if isinstance(no_return, str):
        if no_return not in ("inf", "max", "zero"):
            raise WorldError(f"{_where(path, node)}: 'no_return' must be inf, max, zero or a number "
                             f"[m], got {no_return!r}")
    else:
        no_return = _number(path, node, "no_return", no_return, allow_inf=True)
    model = LaserModel(
        beams=beams, fov=fov, angle_min=angle_min, range_min=range_min, range_max=range_max,
        noise_std=_number(path, node, "noise_std", v["noise_std"], lo=0.0),
        rate=_number(path, node, "rate", v["rate"], positive=True),
        no_return=no_return,
        x=_number(path, node, "x", v["x"]), y=_number(path, node, "y", v["y"]),
        z=_number(path, node, "z", v["z"]), yaw=_number(path, node, "yaw", v["yaw"]),
    )
    return name, model


def _poses(path, node, doc) -> list[tuple[float, float, float]] | int:
    value = doc.get("robots")
    if value is None:
        raise WorldError(f"{_where(path, node)}: missing key 'robots' (a list of [x, y, theta] "
                         "poses, or a count with patrol_map)")
    if isinstance(value, int) and not isinstance(value, bool):
        if value < 1:
            raise WorldError(f"{_where(path, node)}: 'robots' must be >= 1, got {value}")
        if "patrol_map" not in doc:
            raise WorldError(f"{_where(path, node)}: 'robots' as a count needs 'patrol_map' (start "
                             "vertices); with 'map' give a list of [x, y, theta] poses")
        return value
    if not isinstance(value, list) or not value:
        raise WorldError(f"{_where(path, value if yamlfile.line_of(value) else node)}: 'robots' must be a "
                         f"non-empty list of [x, y, theta] poses or a count, got {value!r}")
    poses = []
    for i, p in enumerate(value):
        at = p if yamlfile.line_of(p) else value
        if not isinstance(p, list) or len(p) not in (2, 3):
            raise WorldError(f"{_where(path, at)}: robots[{i}] must be [x, y] or [x, y, theta] "
                             f"[m, m, rad], got {p!r}")
        nums = [_number(path, at, f"robots[{i}]", float(q) if isinstance(q, int) and not
                        isinstance(q, bool) else q) for q in p]
        poses.append((nums[0], nums[1], nums[2] if len(nums) == 3 else 0.0))
    return poses


def parse_world(doc: Any, path: Path | None = None) -> WorldConfig:
    """A WorldConfig from a parsed world document; `path` for messages and relative paths. The
    grid (and start poses) of `map` and `patrol_map` come from tpuaf_stage.map_sources."""
    if not isinstance(doc, dict):
        raise WorldError(f"{_where(path, doc)}: a world file is a mapping, got "
                         f"{type(doc).__name__}")
    _check_keys(path, doc, WORLD_KEYS, "the world file")
    base = path.parent if path else Path.cwd()
    if ("map" in doc) == ("patrol_map" in doc):
        raise WorldError(f"{_where(path, doc)}: give exactly one of 'map' (a map_server YAML) and "
                         "'patrol_map' (a patrol map name or path)")
    seed = doc.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise WorldError(f"{_where(path, doc)}: 'seed' must be an integer >= 0, got {seed!r}")
    robot_preset, robot = parse_robot(path, doc.get("robot"))
    laser_preset, laser = parse_laser(path, doc.get("laser"))
    poses = _poses(path, doc, doc)
    try:
        if "map" in doc:
            if not isinstance(doc["map"], str):
                raise WorldError(f"{_where(path, doc)}: 'map' must be a path, got {doc['map']!r}")
            grid, description = map_server_grid((base / doc["map"]).expanduser())
        else:
            ref = doc["patrol_map"]
            if not isinstance(ref, str):
                raise WorldError(f"{_where(path, doc)}: 'patrol_map' must be a name or path, got "
                                 f"{ref!r}")
            grid, description, starts = patrol_map_grid(
                ref, base, poses if isinstance(poses, int) else None, robot.radius)
            if starts is not None:
                poses = starts  # footprints never overlap
    except MapSourceError as err:
        raise WorldError(f"{_where(path, doc)}: {err}") from None
    return WorldConfig(
        source=path, occupied=np.asarray(grid.occupied, dtype=bool), resolution=float(grid.resolution),
        origin=(float(grid.origin[0]), float(grid.origin[1])), robot=robot, laser=laser,
        poses=poses, seed=seed, map_description=description, robot_preset=robot_preset,
        laser_preset=laser_preset)


def load_world(path: str | Path) -> WorldConfig:
    """Parse and check a world file (WorldError naming file and line on any problem)."""
    path = Path(path).expanduser()
    if not path.is_file():
        raise WorldError(f"{path}: world file not found")
    return parse_world(yamlfile.read_yaml(path, WorldError), path)
