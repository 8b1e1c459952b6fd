"""The robot model: one object, chosen once per run or node, passed to every consumer.

`choose_robot` picks a body from the simulator's presets (tpuaf_stage.presets: their one
declaration) by name: `--robot`, the launch arg `robot`, or, when that is `auto`, the
`TURTLEBOT3_MODEL` environment variable of a TurtleBot3 install (burger, waffle, waffle_pi).
Without either, `auto` takes the preset that drives the map's nominal speed, of the radius
closest to the map's robot radius. The cruise speed is the map's nominal speed capped at the
preset's limit: a robot is never made faster than its body allows.

Consumers: the controller (`controller_config`), the simulated world (`world_robot`), the plan
every strategy and metric reads (`runtimes.config.travel_map`: the map's speed becomes the
robot's, and its edge lengths the robot's travel times at that speed), the recorder and
config.yaml (`describe`).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass

from tpuaf.errors import TpuafError

AUTO = "auto"
ENV_VAR = "TURTLEBOT3_MODEL"  # set by TurtleBot3 installs: burger | waffle | waffle_pi

# Edge travel: "declared" (the map's edge lengths, as published comparisons use them),
# "planned" (path lengths on the occupancy grid for the robot's footprint) or "timed" (each
# edge's travel time for the robot model: planned path, accelerations, turns and slow zones;
# navigation/travel_time.py). Without a robot a run is declared; with one, timed.
TRAVELS = ("declared", "planned", "timed")


class RobotChoiceError(TpuafError):
    """An unknown robot preset (the message names where it came from and the known ones)."""


@dataclass(frozen=True)
class RobotModel:
    """A robot's body and limits. The footprint is a disc of `radius_m` (the simulator's)."""

    preset: str  # tpuaf_stage.presets.ROBOT_PRESETS key
    radius_m: float  # [m] footprint disc
    speed_mps: float  # [m/s] cruise speed: the map's nominal speed capped at the preset's limit
    max_speed_mps: float  # [m/s] the preset's linear limit
    max_angular_speed: float  # [rad/s]
    linear_accel: float  # [m/s^2] (inf: instantaneous)
    angular_accel: float  # [rad/s^2]
    sensor_range_m: float  # [m] the laser's (LDS-01) maximum range
    source: str  # where the choice came from: --robot | TURTLEBOT3_MODEL | auto
    note: str = ""  # '' or why the speed differs from the map's nominal speed

    def describe(self) -> dict:
        """config.yaml's `robot` entry."""
        return {"preset": self.preset, "source": self.source, "radius_m": self.radius_m,
                "speed_mps": self.speed_mps, "max_speed_mps": self.max_speed_mps,
                "max_angular_speed_rad_s": self.max_angular_speed,
                "linear_accel_mps2": self.linear_accel, "sensor_range_m": self.sensor_range_m,
                "note": self.note}


def preset_names() -> list[str]:
    from tpuaf_stage.presets import ROBOT_PRESETS

    return sorted(ROBOT_PRESETS)


def choose_robot(name: str | None, settings, env: Mapping[str, str] | None = None,
                 option: str = "--robot") -> RobotModel:
    """The robot of a run on a map with `settings` (its nominal speed and robot radius):
    preset `name`, or for None/'auto' the `TURTLEBOT3_MODEL` of `env` (os.environ by
    default), else the map's own preset. `option` names the setting in errors."""
    from tpuaf_stage.presets import LASER_PRESETS, ROBOT_PRESETS

    env = os.environ if env is None else env
    source = option
    if name is None or name == AUTO:
        name, source = env.get(ENV_VAR, "").strip(), ENV_VAR
        option = f"environment variable {ENV_VAR}"
        if not name:
            name, source = _preset_for(settings, ROBOT_PRESETS), AUTO
    if name not in ROBOT_PRESETS:
        raise RobotChoiceError(f"{option}: unknown robot preset '{name}' (known: auto, "
                               f"{', '.join(sorted(ROBOT_PRESETS))})")
    preset = ROBOT_PRESETS[name]
    nominal = float(settings.nominal_speed)
    limit = float(preset["max_linear_speed"])
    speed, note = nominal, ""
    if nominal > limit + 1e-9:
        speed = limit
        note = (f"the map's nominal speed {nominal:g} m/s is above the {name} limit {limit:g} m/s: "
                f"robots drive and plan at {limit:g} m/s")
    return RobotModel(
        preset=name, radius_m=float(preset["radius"]), speed_mps=speed, max_speed_mps=limit,
        max_angular_speed=float(preset["max_angular_speed"]),
        linear_accel=float(preset["max_linear_accel"]),
        angular_accel=float(preset["max_angular_accel"]),
        sensor_range_m=float(LASER_PRESETS["lds01"]["range_max"]), source=source, note=note)


def _preset_for(settings, presets: Mapping[str, dict]) -> str:
    """A preset that drives the map's nominal speed, of the radius closest to the map's."""
    nominal = float(settings.nominal_speed)
    able = [k for k, v in presets.items() if v["max_linear_speed"] >= nominal - 1e-9]
    return min(able or ["burger"],
               key=lambda k: abs(presets[k]["radius"] - settings.robot_radius))


def world_robot(robot: RobotModel) -> dict:
    """The simulator's `robot` entry of a world file for this robot (the preset, at the cruise
    speed)."""
    return {"preset": robot.preset, "max_linear_speed": robot.speed_mps}
