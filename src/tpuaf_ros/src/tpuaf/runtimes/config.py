"""Run configuration shared by the graph and physics runtimes: `RunConfig` (and the physics
runtime's `PhysicsConfig`), their validation, the plan's map of a run (`travel_map`: the robot's
speed and travel times) and the `config.yaml` description of a run (`run_description`)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from typing import Any

from tpuaf import __version__
from tpuaf.errors import MapError, TpuafError
from tpuaf.maps.params import check_map_params, effective_params
from tpuaf.navigation.controller import CONTROL_PERIOD_S, PHYSICS_STEP_S
from tpuaf.params import (
    LANE_DEFAULT,
    LANE_MODES,
    LIVENESS_DEFAULTS,
    resolve_lane_mode,
)
from tpuaf.policies import REGISTRY
from tpuaf.robot.model import AUTO, TRAVELS, RobotChoiceError, RobotModel, choose_robot
from tpuaf.runtimes.faults import Fault, FaultError, resolve_faults


def run_robot(config: RunConfig, patrol_map) -> RobotModel | None:
    """The run's robot model (chosen once: config.robot, or TURTLEBOT3_MODEL for 'auto'); None
    for a graph run without a robot (the map's nominal figures)."""
    name = getattr(config, "robot", None)
    if name is None:
        return None
    try:
        return choose_robot(name, patrol_map.settings)
    except RobotChoiceError as err:
        raise ConfigError(str(err)) from None


def travel_map(config: RunConfig, patrol_map, robot: RobotModel | None = None):
    """The map the run's strategies, motion and metrics plan on: `patrol_map` with the robot's
    cruise speed as its nominal speed and, by `config.travel`, its edge lengths: declared,
    planned for the robot's footprint, or timed (speed x the modelled travel time, so that
    length / speed is the robot's travel time)."""
    travel = config.resolved_travel()
    if travel == "declared":
        if robot is None or robot.speed_mps == patrol_map.settings.nominal_speed:
            return patrol_map
        return replace(patrol_map, settings=replace(patrol_map.settings,
                                                    nominal_speed=robot.speed_mps))
    body = robot or choose_robot(AUTO, patrol_map.settings)
    if travel == "planned":
        from tpuaf.navigation.planner import with_planned_lengths

        planned = with_planned_lengths(patrol_map, body.radius_m)
        return replace(planned, settings=replace(planned.settings, nominal_speed=body.speed_mps))
    from tpuaf.navigation.planner import shared_planner
    from tpuaf.navigation.travel_time import timed_map

    return timed_map(patrol_map, body, shared_planner(patrol_map, body.radius_m))


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
    # Robot preset (tpuaf.robot.model; "auto": TURTLEBOT3_MODEL or the map's). None: the graph
    # runtime's point robot at the map's nominal speed.
    robot: str | None = None
    travel: str | None = None  # TRAVELS; None: declared without a robot, timed with one
    # Overrides of the map's settings (tpuaf.maps.params.USER_PARAMS; `--map-param`), e.g.
    # {"sensing_radius": 2.0} [m]; {} = the map's own.
    map_params: dict[str, Any] = field(default_factory=dict)
    # The lane layer in aisles one robot wide for the run's robot (params.LANE_MODES,
    # docs/LANES.md). one_way: the lanes on cycles driven one way; routes, strategies and travel
    # times follow their arcs. locks: physics only (the graph runtime models no widths).
    lanes: str = LANE_DEFAULT
    lanes_share_widths = False  # class: whether this runtime can lock lanes (physics can)

    def lane_mode(self) -> str:
        """The lane mode this run uses: auto resolved for the strategy (params.resolve_lane_mode),
        and off for the graph runtime's point robot (no `robot`: no width, no lane)."""
        if self.lanes == "auto" and self.robot is None:
            return "off"
        return resolve_lane_mode(self.lanes, self.strategy)

    @property
    def one_way(self) -> bool:
        """Whether the lanes on cycles are driven one way."""
        return self.lane_mode() == "one_way"

    def resolved_travel(self) -> str:
        return self.travel or ("timed" if self.robot is not None else "declared")

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
        try:
            self.map_params = check_map_params(self.map_params, "map_params")
        except MapError as err:
            raise ConfigError(str(err)) from None
        if self.travel is not None and self.travel not in TRAVELS:
            raise ConfigError(f"travel must be one of {', '.join(TRAVELS)}, got {self.travel!r}")
        if self.lanes not in LANE_MODES:
            raise ConfigError(f"lanes must be one of {', '.join(LANE_MODES)}, got {self.lanes!r}")
        if self.lanes == "locks" and not self.lanes_share_widths:
            raise ConfigError("lane locks need the physics runtime (--runtime physics): the "
                              "graph runtime drives edges without widths, so no lane is shared "
                              "there (one_way runs in both)")
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
        "map_setting_sources": {k: p["source"] for k, p in effective_params(pm).items()},
        "start_vertices": [int(pm.vertex_ids[v]) for v in starts],
        "faults": [f.to_dict() for f in faults],
        **extra,
    }



@dataclass
class PhysicsConfig(RunConfig):
    robot: str | None = AUTO  # a physical run always has a body (None: auto)
    physics_step_s: float = PHYSICS_STEP_S
    control_period_s: float = CONTROL_PERIOD_S
    planner: bool = True  # navigator on planned paths (False: straight edges, as before)
    lanes_share_widths = True  # lane locks too (the lanes that stay two-way under one_way)

    def validate(self) -> None:
        if self.robot is None:
            self.robot = AUTO
        super().validate()
        for name in ("physics_step_s", "control_period_s"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(f"{name} must be a finite number > 0 s, got {value!r}")
        ratio = self.control_period_s / self.physics_step_s
        if abs(ratio - round(ratio)) > 1e-6 or round(ratio) < 1:
            raise ConfigError(f"control_period_s ({self.control_period_s:g}) must be a whole "
                              f"multiple of physics_step_s ({self.physics_step_s:g})")
