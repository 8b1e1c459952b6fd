"""Strict private parameters of the tpuaf_ros nodes (ROS-free: the node passes a dict)."""

from __future__ import annotations

import inspect
import math
import re
from dataclasses import MISSING, dataclass, fields
from typing import Any, ClassVar

from tpuaf.errors import TpuafError


class NodeParamError(TpuafError):
    """An unknown or invalid node parameter; the message lists the valid ones."""


def parse(cls: type, values: dict[str, Any], node: str) -> Any:
    """A `cls` dataclass from {name: value}; unknown names, wrong types and missing required
    values (defaults of None marked `required` in the field metadata) raise NodeParamError."""
    known = {f.name: f for f in fields(cls)}
    unknown = sorted(set(values) - set(known))
    if unknown:
        raise NodeParamError(f"{node}: unknown parameter(s) {', '.join('~' + u for u in unknown)}"
                             f" (valid: {', '.join('~' + k for k in sorted(known))})")
    out = cls()
    for name, value in values.items():
        default = getattr(out, name)
        f = known[name]
        kind = f.metadata.get("type", type(default))
        if kind is float:
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise NodeParamError(f"{node}: ~{name} must be a finite number, got {value!r}")
            value = float(value)
        elif kind is int:
            if isinstance(value, bool) or not isinstance(value, int):
                raise NodeParamError(f"{node}: ~{name} must be an integer, got {value!r}")
        elif kind is bool:
            if not isinstance(value, bool):
                raise NodeParamError(f"{node}: ~{name} must be true or false, got {value!r}")
        elif kind is str:
            if not isinstance(value, str):
                raise NodeParamError(f"{node}: ~{name} must be a string, got {value!r}")
        elif kind is dict:
            if not isinstance(value, dict):
                raise NodeParamError(f"{node}: ~{name} must be a mapping, got {value!r}")
        elif kind is list:
            if not isinstance(value, list):
                raise NodeParamError(f"{node}: ~{name} must be a list, got {value!r}")
        _check_range(cls, node, name, value)
        setattr(out, name, value)
    for f in fields(cls):
        if f.metadata.get("required") and getattr(out, f.name) in (None, "", -1):
            raise NodeParamError(f"{node}: ~{f.name} is required ({f.metadata.get('doc', '')})")
    return out


def _check_range(cls: type, node: str, name: str, value: Any) -> None:
    """`cls.ranges[name]` = (">" or ">=", bound): a number on the wrong side is refused."""
    limit = getattr(cls, "ranges", {}).get(name)
    if limit is None or isinstance(value, bool) or not isinstance(value, (int, float)):
        return
    op, bound = limit
    if not (value > bound if op == ">" else value >= bound):
        raise NodeParamError(f"{node}: ~{name} must be {op} {bound:g}, got {value!r}")


def req(default: Any, doc: str, kind: type | None = None):
    from dataclasses import field

    meta = {"required": True, "doc": doc}
    if kind is not None:
        meta["type"] = kind
    return field(default=default, metadata=meta)


def opt(default: Any, kind: type):
    from dataclasses import field

    if isinstance(default, (dict, list)):
        return field(default_factory=lambda: type(default)(default), metadata={"type": kind})
    return field(default=default, metadata={"type": kind})


@dataclass(frozen=True)
class ControllerDefaults:
    """Defaults of the local controller, in one place: `tpuaf.navigation.ControllerConfig` and
    the agent node's parameters that set it (AgentParams) both read them."""

    max_angular_speed: float = 2.84  # [rad/s] (TurtleBot3 Burger)
    safety_margin: float = 0.08  # [m]
    plan_margin: float = 0.3  # [m]
    stuck_timeout_s: float = 6.0  # [s]
    backoff_s: float = 1.5  # [s]
    max_retries: int = 2
    scan_beams: int = 180  # laser beams the controller uses at most (the scan is subsampled)


CONTROLLER_DEFAULTS = ControllerDefaults()
_C = CONTROLLER_DEFAULTS


@dataclass(frozen=True)
class LivenessDefaults:
    """Defaults of team liveness, in one place, read by every runtime (RunConfig, RobotMachine,
    TeammateLiveness, heartbeat_links, AgentRuntime), the nodes (AgentParams, MonitorParams),
    the monitor (FleetMonitor), the CLI (`--teammate-timeout`) and the docs; the launch files
    write the same values (tests/test_defaults.py checks them).

    One rule says when a robot is gone: silent (no heartbeat, no team message) for the teammate
    timeout. Its teammates then drop it; the monitor's death timeout is the same value (it
    defaults to the teammate timeout), so the monitor calls a robot dead when its teammates do."""

    teammate_timeout_s: float = 10.0  # [s] a teammate silent this long is lost
    heartbeat_period_s: float = 1.0  # [s] an agent's AgentEvent HEARTBEAT period

    @property
    def death_timeout_s(self) -> float:
        """[s] the monitor: an agent silent this long is dead (= the teammate timeout)."""
        return self.teammate_timeout_s

    @staticmethod
    def death_timeout_for(teammate_timeout_s: float, death_timeout_s: float | None) -> float:
        """[s] the monitor's death timeout: the one given, else the teammate timeout (the one
        rule, written here only: FleetMonitor and the monitor node's parameters use it)."""
        return float(teammate_timeout_s if death_timeout_s is None else death_timeout_s)


LIVENESS_DEFAULTS = LivenessDefaults()
_L = LIVENESS_DEFAULTS


@dataclass(frozen=True)
class HealthDefaults:
    """Defaults of the fleet's robot health (tpuaf.measure.health), read by FleetMonitor, the
    monitor node (MonitorParams) and `tpuaf analyze`."""

    stuck_after_s: float = 60.0  # [s] a robot that neither moves nor visits this long: reported


HEALTH_DEFAULTS = HealthDefaults()


# Map settings a run may override (`--map-param KEY=VALUE`, node parameter / launch arg
# map_params; tpuaf.maps.params): key -> (unit, meaning). Other settings come from the map.
MAP_PARAMS: dict[str, tuple[str, str]] = {
    "nominal_speed": ("m/s", "speed limit: robots drive and plan at most this fast"),
    "sensing_radius": ("m", "r of Eq. 1: a robot senses targets this close"),
    "sensing_peak": ("-", "G of Eq. 1: sensing at distance 0"),
    "interference_distance": ("m", "d_if: two robots this close (centre to centre) interfere"),
    "growth_coefficients": ("-", "uncertainty rates a_0, a_1, ... of g(X) = sum a_l X^l, Eq. 2"),
}


# The lane layer's modes (docs/LANES.md; `tpuaf run`/`compare`/`fleet --lanes`, the agent's
# ~lanes): auto (the default: one_way for a strategy that drives one-way lanes, else off; off
# too for a body-less run, the graph runtime without a robot);
# off; locks (every lane one robot wide entered holding its lock); one_way (the lanes on
# cycles driven one way, the others locked). On a map without lanes for the robot every mode
# runs as off.
LANE_MODES = ("auto", "off", "locks", "one_way")
LANE_DEFAULT = "auto"
# Strategies that auto runs without lanes, as measured (lab, 4 Burgers, physics, 900 s, 3 seeds,
# I_ins off / one-way 28.4 / 84.5, 15.2 / 17.9, 16.2 / 17.4 s; lanes_strategies_seeds.md): their robots rarely meet (msp's keep to their
# parts, of which one-way arcs leave fewer; sebs's spread) or their goals are several hops away
# and one-way makes them loops away (dtap). Every other strategy gains from one-way lanes there.
AUTO_LANES_OFF_STRATEGIES = ("dtap", "msp", "sebs")
LANE_PASS_MARGIN_M = 0.05  # [m] beyond two footprints side by side (the navigator's pass margin)


def pass_band_m(robot_radius_m: float) -> float:
    """[m] the free band across a robot's way in which two robot centres fit side by side (the
    lane map's test of a narrow point, navigation/lanes.py; the graph generator's doorways)."""
    return 2.0 * robot_radius_m + LANE_PASS_MARGIN_M


def resolve_lane_mode(mode: str, strategy: str) -> str:
    """The lane mode a run of `strategy` uses for `mode` (auto: one_way, or off for the
    strategies of AUTO_LANES_OFF_STRATEGIES); ValueError naming the modes."""
    if mode not in LANE_MODES:
        raise ValueError(f"lane mode must be one of {', '.join(LANE_MODES)}, got {mode!r}")
    if mode != "auto":
        return mode
    return "off" if strategy.lower() in AUTO_LANES_OFF_STRATEGIES else "one_way"


@dataclass
class AgentParams:
    """Private parameters of patrol_agent (units in the comments)."""

    map: str = req("", "patrol map name or path")
    map_params: dict = opt({}, dict)  # overrides of the map's settings {key: value}, e.g. {sensing_radius: 2.0} (tpuaf.maps.params; {} = the map's)
    robot_index: int = req(-1, "this robot's index 0..robots-1")
    robots: int = req(-1, "team size N")
    strategy: str = "tpuaf"  # strategy name from the registry
    strategy_params: dict = opt({}, dict)  # the strategy's parameters (checked by the strategy)
    seed: int = 0  # run seed (the robot's generator is seeded with [seed, 2, robot_index])
    localization: str = "tf"  # tf (map -> base, any localiser) | odom | ground_truth (sim) | amcl
    initial_pose: list = opt([], list)  # [x m, y m, yaw rad] odom origin / initialpose
    map_frame: str = "map"  # global frame of the patrol map (tf localisation)
    base_frame: str = ""  # robot frame for tf localisation; '' = <namespace>/base_footprint
    robot_name: str = ""  # name in team messages; default: this node's namespace
    team_ns: str = "/team"  # namespace of the team topics
    navigation: str = "builtin"  # builtin (laser local controller) | move_base (actionlib client)
    move_base_action: str = "move_base"  # MoveBaseAction server name (relative to the namespace)
    move_base_timeout: float = 60.0  # [s] without progress toward a move_base goal: goal failed
    robot: str = "auto"  # robot preset (tpuaf.robot.model); auto: TURTLEBOT3_MODEL, else the map's
    max_linear_speed: float = 0.0  # [m/s]; 0 = the robot's cruise speed
    max_angular_speed: float = 0.0  # [rad/s]; 0 = the robot's
    robot_radius: float = 0.0  # [m]; 0 = the robot's
    safety_margin: float = _C.safety_margin  # [m]
    plan_margin: float = _C.plan_margin  # [m]
    stuck_timeout: float = _C.stuck_timeout_s  # [s] without progress before a recovery
    backoff_time: float = _C.backoff_s  # [s] reversing in a recovery
    max_retries: int = _C.max_retries  # recoveries before the goal is reported failed
    waypoint_tolerance: float = 0.6  # [m] pass-through vertices
    global_planner: bool = True  # builtin navigation: follow paths planned on the map's grid
    lanes: str = LANE_DEFAULT  # lane layer: auto | off | locks | one_way (params.LANE_MODES; not off only with builtin navigation and the global planner, where auto is off; docs/LANES.md)
    scan_beams: int = _C.scan_beams  # laser beams used by the controller at most (the scan is subsampled)
    heartbeat_period: float = _L.heartbeat_period_s  # [s] AgentEvent HEARTBEAT period
    lockstep: bool = False  # answer every pose tick with TwistStamped on cmd_vel_stamped
    input_timeout: float = 2.0  # [s wall] pose, scan or clock not advancing this long: stop
    teammate_timeout: float = _L.teammate_timeout_s  # [s] a teammate silent this long is lost (intentions dropped)
    skew_warn: float = 1.0  # [s] warn when a teammate's clock is off by more than this
    max_skew: float = 30.0  # [s] team messages farther than this from our clock are ignored
    clock_offset: float = 0.0  # [s] added to this robot's wall clock (tests: injected skew)
    wait_for_start: bool = False  # wait for the run start on /fleet/start (monitor-led runs)
    start_wait: float = 2.0  # [s wall] wall clock: wait this long for /fleet/start, then announce it
    epoch: float = -1.0  # [s] ROS time of run time 0; -1: 0 with sim time, else /fleet/start

    # Numeric limits checked by `parse` (not fields): name -> (">" or ">=", bound).
    ranges: ClassVar[dict[str, tuple[str, float]]] = {
        "robot_index": (">=", 0), "robots": (">=", 1), "seed": (">=", 0),
        "move_base_timeout": (">", 0), "max_linear_speed": (">=", 0),
        "max_angular_speed": (">=", 0), "robot_radius": (">=", 0), "safety_margin": (">=", 0),
        "plan_margin": (">=", 0), "stuck_timeout": (">", 0), "backoff_time": (">", 0),
        "max_retries": (">=", 0), "waypoint_tolerance": (">", 0), "scan_beams": (">=", 8),
        "heartbeat_period": (">", 0), "input_timeout": (">", 0), "teammate_timeout": (">", 0),
        "skew_warn": (">", 0), "max_skew": (">", 0), "start_wait": (">=", 0),
    }


@dataclass
class MonitorParams:
    """Private parameters of the monitor node (units in the comments)."""

    map: str = req("", "patrol map name or path")
    map_params: dict = opt({}, dict)  # overrides of the map's settings {key: value}, e.g. {sensing_radius: 2.0} (tpuaf.maps.params; {} = the map's)
    robots: int = req(-1, "team size N")
    duration: float = 3600.0  # [s] run length after the start
    robot_prefix: str = "robot_"  # robot i's ground truth on /<robot_prefix><i>/base_pose_ground_truth
    out: str = ""  # results folder ('' = none written)
    death_timeout: float = _L.death_timeout_s  # [s] an agent silent this long is dead (not set: ~teammate_timeout, one rule)
    teammate_timeout: float = _L.teammate_timeout_s  # [s] the agents' ~teammate_timeout: when survivors can know of a death (recovery's floor at detection)
    start_delay: float = 1.0  # [s] between all agents ready and the announced start
    start_not_before: float = 0.0  # [s of ROS time] the start is announced start_delay after this at the earliest (lock-step: the simulator's ~start_hold, one start in every run)
    start_wall_delay: float = 0.0  # [s of wall time] to wait once all are ready (connections)
    recorder_node: str = ""  # start only once the rosbag node of this name records the agent events ('' = no wait)
    # [s of wall time] at most this long once all are ready, wait until every agent (a node in
    # /<robot_prefix><i>/) is connected to our /fleet/start; then announce anyway, with a warning
    start_connect_timeout: float = 20.0
    config_file: str = ""  # YAML merged into the results' config.yaml (written by tpuaf fleet)
    strategy: str = ""  # for config.yaml
    seed: int = 0  # for config.yaml
    pose_source: str = "ground_truth"  # positions for X: ground_truth | tf | odom | amcl
    robot: str = AgentParams.robot  # the agents' robot preset (its radius: a dead robot's body, recovery)
    safety_margin: float = AgentParams.safety_margin  # [m] the agents' controller margin (how near a robot comes to a dead robot's body, recovery)
    map_frame: str = "map"  # tf: the global frame
    base_frame: str = "base_footprint"  # tf: robot i's frame is <robot_prefix><i>/<base_frame>
    announce_start: bool = True  # announce /fleet/start when all agents are ready; false: follow
    #   the start the agents announce (hardware)
    team_ns: str = "/team"  # namespace of the team topics (intentions: recovery metrics)
    stuck_after: float = HEALTH_DEFAULTS.stuck_after_s  # [s] no progress this long: reported
    # [s of wall time] after the run finished and its results are written, the node exits (the
    # subscribers and the recorder get the last metrics first)
    exit_delay: float = 2.0

    # Numeric limits checked by `parse` (not fields): name -> (">" or ">=", bound).
    ranges: ClassVar[dict[str, tuple[str, float]]] = {
        "robots": (">=", 1), "duration": (">", 0), "death_timeout": (">", 0),
        "stuck_after": (">", 0), "exit_delay": (">=", 0),
        "teammate_timeout": (">", 0), "start_delay": (">=", 0), "start_wall_delay": (">=", 0), "seed": (">=", 0), "start_not_before": (">=", 0),
        "start_connect_timeout": (">=", 0), "safety_margin": (">=", 0),
    }


def parse_monitor(values: dict[str, Any], node: str) -> MonitorParams:
    """MonitorParams from {name: value}; ~death_timeout, when not given, is ~teammate_timeout
    (one liveness rule: the monitor calls a robot dead when its teammates lose it)."""
    p = parse(MonitorParams, values, node)
    given = p.death_timeout if "death_timeout" in values else None
    p.death_timeout = LIVENESS_DEFAULTS.death_timeout_for(p.teammate_timeout, given)
    return p


def params_help(cls: type) -> str:
    """One line per parameter of a params dataclass: name, type, default, the comment (or `req`
    doc) written beside it in the source and its limit from `cls.ranges`, so the docs cannot
    drift from the code."""
    comments = {}
    for line in inspect.getsource(cls).splitlines():
        match = re.match(r"\s+(\w+): [^=]+=.*?#\s*(.*)$", line)
        if match:
            comments[match.group(1)] = match.group(2)
    rows = []
    for f in fields(cls):
        default = f.default if f.default is not MISSING else f.default_factory()
        kind = f.metadata.get("type", type(default)).__name__
        doc = f.metadata.get("doc") or comments.get(f.name, "")
        limit = getattr(cls, "ranges", {}).get(f.name)
        if limit is not None:
            doc += f"; must be {limit[0]} {limit[1]:g}"
        required = " (required)" if f.metadata.get("required") else ""
        rows.append(f"  ~{f.name:<20} {kind:<6} {default!r:<14} {doc}{required}")
    return "\n".join(rows)
