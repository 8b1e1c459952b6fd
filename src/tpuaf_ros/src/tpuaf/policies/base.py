"""The strategy interface shared by all three runtimes, and the registry of strategies by name.

A runtime (batch engine, ROS agent node) owns one `Policy` per robot and calls it:

- `start(ctx)` once, with the robot at its start vertex;
- `decide(ctx)` each time the robot reaches its goal vertex, and again at a time the policy
  asked for with `ctx.wake_at(t)` while it has no goal. It returns the next goal vertex
  (the runtime drives the shortest path there; only the goal counts as a visit), or None to
  wait (the policy must then call `ctx.wake_at`);
- `on_message(msg, ctx)` for every team message delivered to this robot (never its own);
- `on_goal_failed(vertex, ctx)` when the navigator gives up on a goal; `decide` follows;
- `on_teammate_lost(robot, ctx)` when a teammate has gone silent (optional; default no-op).

Policies talk to the team only through `ctx.send(message)`, with the typed messages of
`tpuaf.team.messages`. They draw randomness only from `ctx.rng` (seeded per run and robot).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

import numpy as np

from tpuaf.errors import TpuafError


class RobotContext(Protocol):
    """What a runtime hands to a policy. Times in seconds, lengths in metres."""

    robot: int  # robot index 0..n_robots-1
    n_robots: int
    patrol_map: Any  # tpuaf.maps.PatrolMap: graph (tpuaf_core.PatrolGraph), importance, settings
    rng: np.random.Generator

    @property
    def now(self) -> float: ...

    @property
    def current_vertex(self) -> int: ...

    @property
    def start_vertex(self) -> int: ...

    @property
    def position(self) -> tuple[float, float]: ...

    @property
    def start_position(self) -> tuple[float, float]: ...

    @property
    def average_speed(self) -> float:
        """Average speed [m/s] measured online; the map's nominal speed until measured."""

    def send(self, message: Any) -> None:
        """Broadcast a team message (may be delayed or lost)."""

    def wake_at(self, time: float) -> None:
        """Ask for `decide` at `time` [s] (only honoured while the robot has no goal)."""

    def change_goal(self, vertex: int) -> None:
        """Redirect the robot while it drives: it finishes its current edge, then heads to
        `vertex` (only that goal counts as a visit). Optional for runtimes (DTAG uses it)."""


class RobotContextBase:
    """What every runtime's RobotContext shares: vertex bookkeeping and the measured speed.

    A runtime sets `patrol_map`, `_current`, `_start_vertex`, `_start_position`, and adds to
    `travelled_m` / `travel_time_s` while its robot drives; it provides `now`, `position`,
    `send` and `wake_at` itself."""

    travelled_m: float = 0.0  # [m] driven towards goals
    travel_time_s: float = 0.0  # [s] spent driving towards goals

    @property
    def current_vertex(self) -> int:
        return self._current

    @property
    def start_vertex(self) -> int:
        return self._start_vertex

    @property
    def start_position(self) -> tuple[float, float]:
        return self._start_position

    @property
    def average_speed(self) -> float:
        """Vel(i) of Eq. 6 [m/s]: measured once the robot has driven 1 s, nominal before."""
        if self.travel_time_s > 1.0 and self.travelled_m > 0:
            return self.travelled_m / self.travel_time_s
        return float(self.patrol_map.settings.nominal_speed)

    def checked_vertex(self, vertex) -> int:
        """`vertex` as an int index of the map; an unknown one is an IndexError."""
        v = int(vertex)
        if not 0 <= v < self.patrol_map.num_vertices:
            raise IndexError(
                f"unknown vertex index {v} (map '{self.patrol_map.name}' has "
                f"{self.patrol_map.num_vertices})"
            )
        return v

    def call_decide(self, policy: Policy) -> int | None:
        """`policy.decide(self)`; a strategy failure names the strategy, robot and time, and
        a goal outside the map is refused."""
        try:
            goal = policy.decide(self)
            return None if goal is None else self.checked_vertex(goal)
        except Exception as err:
            raise RuntimeError(
                f"strategy '{policy.name}' failed for robot {self.robot} at "
                f"t = {self.now:.2f} s: {type(err).__name__}: {err}"
            ) from err


class ParameterError(TpuafError):
    """A strategy parameter is unknown or invalid."""


@dataclass(frozen=True)
class Parameter:
    """One documented strategy parameter."""

    default: Any
    doc: str  # meaning, with unit
    check: Callable[[Any], bool] | None = None


class Policy(ABC):
    """Base class of every strategy. Subclasses set `name`, `description` and `parameters`."""

    name: ClassVar[str] = ""
    description: ClassVar[str] = ""
    parameters: ClassVar[Mapping[str, Parameter]] = {}
    # Checks across parameters: (predicate on the resolved values, what it requires).
    parameter_relations: ClassVar[tuple[tuple[Callable[[dict], bool], str], ...]] = ()

    def __init__(self, params: Mapping[str, Any] | None = None):
        self.params: dict[str, Any] = resolve_parameters(self.name, self.parameters, params or {})
        for holds, requirement in self.parameter_relations:
            if not holds(self.params):
                raise ParameterError(f"parameters of strategy '{self.name}': {requirement}, got "
                                     + ", ".join(f"{k} = {v!r}" for k, v in self.params.items()
                                                 if k in requirement))

    def start(self, ctx: RobotContext) -> None:  # noqa: B027 - optional hook
        """Called once before the first decision."""

    @abstractmethod
    def decide(self, ctx: RobotContext) -> int | None:
        """Next goal vertex (graph index), or None to wait for a `ctx.wake_at` time."""

    def on_message(self, message: Any, ctx: RobotContext) -> None:  # noqa: B027 - optional hook
        """A team message from another robot arrived."""

    def on_goal_failed(self, vertex: int, ctx: RobotContext) -> None:  # noqa: B027
        """The navigator gave up on `vertex`; `decide` is called next."""

    def retime(self, ctx: RobotContext) -> None:  # noqa: B027 - optional hook
        """`ctx.patrol_map` now holds learned edge travel times (robot/learning.py); a
        strategy that cached distances updates them here."""

    def replan(self, ctx: RobotContext) -> None:
        """`ctx.patrol_map`'s graph lost edges (a lane blocked by a dead robot's body,
        robot/lanes.py): plan on it from now on. By default as a re-timing."""
        self.retime(ctx)

    def on_teammate_lost(self, robot: int, ctx: RobotContext) -> None:  # noqa: B027
        """Teammate `robot` has gone silent (the runtime's liveness timeout): forget what it
        announced (its intentions). It counts as heard again at its next message."""


def resolve_parameters(
    strategy: str, spec: Mapping[str, Parameter], given: Mapping[str, Any]
) -> dict[str, Any]:
    """Defaults overlaid with `given`; unknown names and failed checks raise ParameterError."""
    unknown = sorted(set(given) - set(spec))
    if unknown:
        valid = ", ".join(sorted(spec)) or "none"
        raise ParameterError(
            f"unknown parameter(s) {', '.join(unknown)} for strategy '{strategy}' (valid: {valid})"
        )
    values = {key: p.default for key, p in spec.items()}
    for key, value in given.items():
        if not _value_fits(spec[key], value):
            raise ParameterError(
                f"invalid value {value!r} for parameter '{key}' of strategy '{strategy}': "
                f"{spec[key].doc}"
            )
        values[key] = value
    return values


def _value_fits(parameter: Parameter, value: Any) -> bool:
    """The value has the default's kind (a boolean for a boolean, a number for a number; NaN and
    infinities only where the default is one) and passes the check; a check that raises (e.g.
    TypeError on a string) means 'no'."""
    default = parameter.default
    if value is None:
        return default is None  # null keeps an automatic default ("None = derived")
    if isinstance(default, bool) != isinstance(value, bool):
        return False
    if isinstance(value, float) and not math.isfinite(value):
        return isinstance(default, float) and not math.isfinite(default)
    if isinstance(default, (int, float)) and not isinstance(default, bool) and \
            not isinstance(value, (int, float)):
        return False
    if parameter.check is None:
        return True
    try:
        return bool(parameter.check(value))
    except Exception:  # noqa: BLE001 - any failure of a check is a refused value
        return False


@dataclass
class Registry:
    """Strategies by lowercase name; refuses duplicates."""

    _classes: dict[str, type[Policy]] = field(default_factory=dict)

    def register(self, cls: type[Policy]) -> type[Policy]:
        key = cls.name.lower()
        if not key:
            raise ValueError(f"{cls.__qualname__} has no strategy name")
        if key in self._classes:
            raise ValueError(f"strategy name '{key}' is already registered")
        self._classes[key] = cls
        return cls

    def names(self) -> list[str]:
        return sorted(self._classes)

    def get(self, name: str) -> type[Policy]:
        key = name.lower()
        if key not in self._classes:
            raise KeyError(f"unknown strategy '{name}' (valid: {', '.join(self.names())})")
        return self._classes[key]

    def create(self, name: str, params: Mapping[str, Any] | None = None) -> Policy:
        return self.get(name)(params)


REGISTRY = Registry()
register = REGISTRY.register
