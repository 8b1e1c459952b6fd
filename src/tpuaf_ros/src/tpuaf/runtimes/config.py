"""Run configuration shared by the graph and physics runtimes: `RunConfig` (and the physics
runtime's `PhysicsConfig`), their validation, the robot preset of a map (`choose_robot`, also
used by `tpuaf fleet`) and the `config.yaml` description of a run (`run_description`)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

from tpuaf import __version__
from tpuaf.errors import TpuafError
from tpuaf.params import LIVENESS_DEFAULTS
from tpuaf.policies import REGISTRY
from tpuaf.runtimes.faults import Fault, FaultError, resolve_faults

TRAVELS = ("declared", "planned")


def travel_map(config: RunConfig, patrol_map):
    """The map a run travels on: `patrol_map`, or with planned edge lengths (config.travel) for
    the robot the physics runtime would use (`choose_robot(config.robot or 'auto')`)."""
    if config.travel != "planned":
        return patrol_map
    from tpuaf.navigation.planner import with_planned_lengths

    robot = choose_robot(getattr(config, "robot", "auto"), patrol_map.settings)
    return with_planned_lengths(patrol_map, robot.radius_m)


class ConfigError(TpuafError):
    """An invalid run configuration; the message names the field and the valid choices."""


@dataclass
class RunConfig:
    map: str = "grid"
    strategy: str = "tpuaf"
    robots: int = 4
    duration_s: float = 3600.0
    seed: int = 0
    delay_s: float = 0.0  # team message delay [s]
    loss: float = 0.0  # probability that one recipient loses one message
    strategy_params: dict[str, Any] = field(default_factory=dict)
    sample_period_s: float = 1.0  # time series period [s]
    # Faults (runtimes/faults.py): deaths and stalls as [robot index, time s] pairs (or
    # "ROBOT@TIME" strings), and a number of robots dying at seeded random times.
    fail: list = field(default_factory=list)
    fail_random: int = 0
    stall: list = field(default_factory=list)
    # [s] a teammate silent this long is lost (the agent node's ~teammate_timeout): in runs with
    # faults, robots notice a death from the heartbeats and messages they stop hearing.
    teammate_timeout_s: float = LIVENESS_DEFAULTS.teammate_timeout_s
    # Edge travel of the graph runtime: "declared" (the map's edge lengths, as published
    # comparisons use them) or "planned" (path lengths on the occupancy grid for the robot's
    # footprint: what a robot can achieve; navigation/planner.py).
    travel: str = "declared"

    def validate(self) -> None:
        names = REGISTRY.names()
        if self.strategy.lower() not in names:
            raise ConfigError(f"unknown strategy '{self.strategy}' (valid: {', '.join(names)})")
        self.strategy = self.strategy.lower()
        if not (isinstance(self.robots, int) and self.robots >= 1):
            raise ConfigError(f"robots must be an integer >= 1, got {self.robots!r}")
        if not (self.duration_s > 0 and math.isfinite(self.duration_s)):
            raise ConfigError(
                f"duration must be a finite number of seconds > 0, got {self.duration_s}"
            )
        if not (self.delay_s >= 0 and math.isfinite(self.delay_s)):
            raise ConfigError(f"delay must be >= 0 s, got {self.delay_s}")
        if not 0.0 <= self.loss <= 1.0:
            raise ConfigError(f"loss must be a probability in [0, 1], got {self.loss}")
        if not self.sample_period_s > 0:
            raise ConfigError(f"sample period must be > 0 s, got {self.sample_period_s}")
        if not (self.teammate_timeout_s > 0 and math.isfinite(self.teammate_timeout_s)):
            raise ConfigError(f"teammate timeout must be > 0 s, got {self.teammate_timeout_s}")
        if self.travel not in TRAVELS:
            raise ConfigError(f"travel must be one of {', '.join(TRAVELS)}, got {self.travel!r}")
        self.faults()

    def faults(self) -> list[Fault]:
        """The resolved faults in time order (ConfigError when impossible)."""
        try:
            return resolve_faults(self.fail, self.fail_random, self.stall, self.robots,
                                  float(self.duration_s), int(self.seed))
        except FaultError as err:
            raise ConfigError(str(err)) from None

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def run_description(run, starts, strategy_params, faults, engine: str | None = None,
                    **extra) -> dict:
    """config.yaml of a graph or physics run: runtime, engine, version, config, map, starts,
    faults (Fault objects), then `extra`."""
    pm = run.patrol_map
    return {
        "runtime": run.runtime,
        **({"engine": engine} if engine is not None else {}),
        "tpuaf_version": __version__,
        **run.config.to_dict(),
        "strategy_params": dict(strategy_params),
        "map_name": pm.name,
        "map_source": str(pm.source) if pm.source else "built-in",
        "map_settings": asdict(pm.settings),
        "start_vertices": [int(pm.vertex_ids[v]) for v in starts],
        "faults": [f.to_dict() for f in faults],
        **extra,
    }


# Physics defaults (docs/RUNTIMES.md).
PHYSICS_STEP_S = 0.05  # [s] world step
CONTROL_PERIOD_S = 0.1  # [s] agents' control period (the fleet's 10 Hz odometry)


@dataclass
class PhysicsConfig(RunConfig):
    robot: str = "auto"  # robot preset (tpuaf_stage.presets) or auto (as `tpuaf fleet --robot`)
    physics_step_s: float = PHYSICS_STEP_S
    control_period_s: float = CONTROL_PERIOD_S
    planner: bool = True  # navigator on planned paths (False: straight edges, as before)

    def validate(self) -> None:
        super().validate()
        for name in ("physics_step_s", "control_period_s"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(f"{name} must be a finite number > 0 s, got {value!r}")
        ratio = self.control_period_s / self.physics_step_s
        if abs(ratio - round(ratio)) > 1e-6 or round(ratio) < 1:
            raise ConfigError(f"control_period_s ({self.control_period_s:g}) must be a whole "
                              f"multiple of physics_step_s ({self.physics_step_s:g})")


@dataclass
class RobotChoice:
    preset: str
    radius_m: float
    speed_mps: float  # what the agents are told and the simulator allows
    note: str  # '' or why the speed differs from the map's nominal speed


def choose_robot(name: str, settings) -> RobotChoice:
    """The robot preset for a map: never faster than the preset allows."""
    from tpuaf_stage.presets import ROBOT_PRESETS

    nominal = float(settings.nominal_speed)
    if name == "auto":  # a preset that drives the map's speed, of the closest radius
        able = [k for k, v in ROBOT_PRESETS.items() if v["max_linear_speed"] >= nominal - 1e-9]
        name = min(able or ["burger"], key=lambda k: abs(ROBOT_PRESETS[k]["radius"] -
                                                           settings.robot_radius))
    if name not in ROBOT_PRESETS:
        raise ConfigError(f"--robot: unknown robot preset '{name}' (known: auto, "
                       f"{', '.join(sorted(ROBOT_PRESETS))})")
    preset = ROBOT_PRESETS[name]
    limit = float(preset["max_linear_speed"])
    note = ""
    speed = nominal
    if nominal > limit + 1e-9:
        speed = limit
        note = (f"the map's nominal speed {nominal:g} m/s is above the {name} limit {limit:g} m/s: "
                f"robots drive at {limit:g} m/s (compare with a run at that speed)")
    return RobotChoice(name, float(preset["radius"]), speed, note)
