"""The grid of a sweep (map x strategy x N x scenario x seed): its maps (loaded once, content
hashed), strategies, scenarios (the fault setting and runtime of a run), run keys and the task
each run hands to a worker."""

from __future__ import annotations

import functools
import hashlib
import json
import math
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from tpuaf.errors import TpuafError
from tpuaf.params import LIVENESS_DEFAULTS
from tpuaf.plain import plain


class SweepError(TpuafError):
    """An invalid sweep (unknown map or strategy, inconsistent results folder)."""



@dataclass(frozen=True)
class MapSpec:
    label: str  # folder name and table label (the map's name)
    source: str  # built-in name or path, as given to load_map on the workers
    content_hash: str = ""  # map_hash of what `source` held when the sweep started


def _digest(*parts: Any) -> str:
    h = hashlib.sha256()
    for part in parts:
        data = part.tobytes() if isinstance(part, np.ndarray) else \
            json.dumps(plain(part), sort_keys=True, default=str).encode()
        h.update(len(data).to_bytes(8, "little"))
        h.update(data)
    return h.hexdigest()[:16]


def map_hash(pm: Any) -> str:
    """A digest of everything a run reads from a map: graph, lengths, settings, image."""
    import dataclasses

    occ = pm.occupancy
    grid = () if occ is None else (np.ascontiguousarray(occ.occupied), float(occ.resolution),
                                   list(occ.origin))
    return _digest(str(pm.name), [int(v) for v in pm.vertex_ids],
                   np.ascontiguousarray(pm.positions, dtype=float),
                   [[int(u), int(v), float(length)] for u, v, length in pm.edges],
                   np.ascontiguousarray(pm.importance, dtype=float),
                   np.ascontiguousarray(pm.initial_uncertainty, dtype=float),
                   dataclasses.asdict(pm.settings), pm.corridor_width, pm.bounds, *grid)


def params_hash(strategy: str, given: dict[str, Any]) -> str:
    """A digest of a strategy's effective parameters (defaults and the values given)."""
    return _params_hash(strategy, json.dumps(plain(given), sort_keys=True, default=str))


@functools.lru_cache(maxsize=256)
def _params_hash(strategy: str, given_json: str) -> str:
    from tpuaf.policies import REGISTRY

    given = json.loads(given_json)
    try:
        params = REGISTRY.get(strategy)(dict(given)).params
    except Exception:  # noqa: BLE001 - refused later, by the run itself
        params = given
    return _digest(strategy, params)


NOMINAL = "nominal"
RUNTIMES = ("graph", "physics")  # graph: runtimes/graph.py (GraphRun, the C++ loop); physics: runtimes/physics.py
_FRACTION = re.compile(r"^(\d+)/(\d+)$")


def _g(x: float) -> str:
    return f"{x:g}"


@dataclass(frozen=True)
class Scenario:
    """What a run's conditions are, beyond map, strategy, N and seed.

    deaths: "K" (K robots die) or "A/B" (floor(N A / B) robots die, e.g. "1/4" = a quarter of
    the team); they die at death_time_s (None: half the run). The dying robots are spread over
    the team: indices floor(i N / K), i = 0 .. K - 1 (the same for every seed)."""

    loss: float = 0.0  # probability that one recipient loses one team message
    delay_s: float = 0.0  # [s] team message delay
    deaths: str = "0"
    death_time_s: float | None = None
    runtime: str = "graph"
    duration_s: float | None = None  # None: the sweep's duration
    robot: str | None = None  # robot preset (None: the runtime's default; tpuaf run --robot)

    @property
    def name(self) -> str:
        """Folder name and table label: 'nominal', or e.g. 'loss0.3', 'deaths1of4', 'physics'."""
        parts = [] if self.runtime == "graph" else [self.runtime]
        if self.robot:
            parts.append(self.robot)
        if self.loss:
            parts.append(f"loss{_g(self.loss)}")
        if self.delay_s:
            parts.append(f"delay{_g(self.delay_s)}")
        if self.deaths != "0":
            parts.append("deaths" + self.deaths.replace("/", "of")
                         + ("" if self.death_time_s is None else f"@{_g(self.death_time_s)}"))
        return "-".join(parts) or NOMINAL

    @property
    def faulty(self) -> bool:
        return bool(self.loss or self.delay_s or self.deaths != "0")

    def death_count(self, robots: int) -> int:
        m = _FRACTION.match(self.deaths)
        if m:
            return robots * int(m.group(1)) // int(m.group(2))
        return int(self.deaths)

    def applies(self, robots: int) -> bool:
        """A death scenario needs at least one death and one survivor at this N."""
        if self.deaths == "0":
            return True
        return 1 <= self.death_count(robots) <= robots - 1

    def failures(self, robots: int, duration_s: float) -> list[tuple[int, float]]:
        """(robot index, time [s]) of each death at this N."""
        k = self.death_count(robots)
        t = duration_s / 2.0 if self.death_time_s is None else float(self.death_time_s)
        return [(i * robots // k, t) for i in range(k)] if k else []


def parse_deaths(text: str) -> str:
    """'K' or 'A/B' (normalised), else SweepError."""
    text = str(text).strip()
    m = _FRACTION.match(text)
    if m:
        a, b = int(m.group(1)), int(m.group(2))
        if b == 0 or a > b:
            raise SweepError(f"deaths '{text}': a fraction A/B of the team needs 0 <= A <= B, B > 0")
        g = math.gcd(a, b)  # 2/8 = 1/4: the same scenario, the same folder
        return "0" if a == 0 else f"{a // g}/{b // g}"
    if text.isdigit():
        return str(int(text))
    raise SweepError(f"deaths '{text}': expected a number of robots (e.g. 2) or a fraction of "
                     "the team (e.g. 1/4)")


def make_scenarios(loss: Iterable[float] = (), delay_s: Iterable[float] = (),
                   deaths: Iterable[str] = (), death_time_s: float | None = None,
                   runtime: str = "graph", with_base: bool = True,
                   robot: str | None = None) -> list[Scenario]:
    """The base scenario (no fault) and one scenario per value of each factor, the others at
    their base value (one factor at a time: the degradation curves)."""
    if runtime not in RUNTIMES:
        raise SweepError(f"unknown runtime '{runtime}' (valid: {', '.join(RUNTIMES)})")
    for p in loss:
        if not 0.0 <= p <= 1.0:
            raise SweepError(f"loss must be a probability in [0, 1], got {p}")
    for d in delay_s:
        if not (d >= 0 and math.isfinite(d)):
            raise SweepError(f"delay must be a finite number of seconds >= 0, got {d}")
    if death_time_s is not None and not (death_time_s >= 0 and math.isfinite(death_time_s)):
        raise SweepError(f"death time must be a finite number of seconds >= 0, got {death_time_s}")
    base = Scenario(runtime=runtime, robot=robot)
    out = [base] if with_base else []
    out += [Scenario(loss=float(p), runtime=runtime, robot=robot) for p in loss]
    out += [Scenario(delay_s=float(d), runtime=runtime, robot=robot) for d in delay_s]
    out += [Scenario(deaths=parse_deaths(k), death_time_s=death_time_s, runtime=runtime,
                     robot=robot) for k in deaths]
    unique: list[Scenario] = []
    for s in out:
        if not s.faulty and s != base:
            s = base
        if s not in unique and (with_base or s.faulty):
            unique.append(s)
    if not unique:
        raise SweepError("no scenario left: give a fault value other than 0, or keep the base")
    return unique


@dataclass(frozen=True)
class RunKey:
    map: str  # map label
    strategy: str  # lower case registry name
    robots: int
    seed: int
    scenario: str = NOMINAL  # Scenario.name

    def folder(self, root: Path) -> Path:
        base = Path(root) / "runs" / self.map / self.strategy / f"N{self.robots}"
        if self.scenario != NOMINAL:
            base = base / self.scenario
        return base / f"seed{self.seed}"

    def label(self) -> str:
        extra = "" if self.scenario == NOMINAL else f"/{self.scenario}"
        return f"{self.map}/{self.strategy}/N{self.robots}{extra}/seed{self.seed}"


@dataclass
class SweepSpec:
    maps: list[MapSpec]
    strategies: list[str]
    robots: list[int]
    seeds: list[int]
    duration_s: float = 3600.0
    strategy_params: dict[str, dict[str, Any]] = field(default_factory=dict)  # per strategy
    scenarios: list[Scenario] = field(default_factory=lambda: [Scenario()])
    # [s] every run's RunConfig.teammate_timeout_s (`tpuaf compare --teammate-timeout`)
    teammate_timeout_s: float = LIVENESS_DEFAULTS.teammate_timeout_s
    # every map's setting overrides (`tpuaf compare --map-param`; tpuaf.maps.params)
    map_params: dict[str, Any] = field(default_factory=dict)

    def keys(self) -> list[RunKey]:
        return [RunKey(m.label, s, n, seed, sc.name) for m in self.maps for s in self.strategies
                for n in self.robots for sc in self.scenarios if sc.applies(n)
                for seed in self.seeds]

    def source_of(self, label: str) -> str:
        return next(m.source for m in self.maps if m.label == label)

    def scenario(self, name: str) -> Scenario:
        return next(s for s in self.scenarios if s.name == name)

    def duration_of(self, key: RunKey) -> float:
        d = self.scenario(key.scenario).duration_s
        return self.duration_s if d is None else float(d)

    def task(self, key: RunKey) -> dict[str, Any]:
        """Everything a worker needs for one run (plain data, picklable)."""
        sc = self.scenario(key.scenario)
        duration = self.duration_of(key)
        failures = sc.failures(key.robots, duration)
        spec_of = next(m for m in self.maps if m.label == key.map)
        return {"map": key.map, "map_source": spec_of.source, "map_hash": spec_of.content_hash,
                "params_hash": params_hash(key.strategy,
                                           self.strategy_params.get(key.strategy, {})),
                "strategy": key.strategy,
                "robots": key.robots, "seed": key.seed, "duration_s": duration,
                "strategy_params": dict(self.strategy_params.get(key.strategy, {})),
                "scenario": sc.name, "runtime": sc.runtime, "robot": sc.robot, "loss": sc.loss,
                "delay_s": sc.delay_s, "deaths": len(failures),
                "death_time_s": failures[0][1] if failures else None,
                "failures": [list(f) for f in failures],
                "teammate_timeout_s": float(self.teammate_timeout_s),
                "map_params": dict(self.map_params)}


_LABEL_OK = re.compile(r"^[A-Za-z0-9_.+-]+$")


def resolve_maps(names: Iterable[str], map_params: dict[str, Any] | None = None
                 ) -> list[MapSpec]:
    """Load every map once (validating it, with the `map_params` overrides) and give each a
    unique label (its name)."""
    from tpuaf.maps import MapError, builtin_map_names, load_map

    specs: list[MapSpec] = []
    for name in names:
        text = str(name)
        builtin = text in builtin_map_names()
        if not builtin and not Path(text).expanduser().exists():
            raise SweepError(
                f"unknown map '{text}': built-in maps are {', '.join(builtin_map_names())}; "
                "otherwise give the path of a map folder or .graph file")
        try:
            pm = load_map(text, params=map_params, params_origin="--map-param")
        except MapError as err:
            raise SweepError(f"map '{text}': {err}") from None
        source = text if builtin else str(Path(text).expanduser().resolve())
        label = pm.name if _LABEL_OK.match(str(pm.name) or "") else Path(text).stem
        if any(s.label == label for s in specs):
            other = next(s.source for s in specs if s.label == label)
            if other == source:
                continue  # the same map twice
            raise SweepError(f"maps '{other}' and '{text}' have the same name '{label}'")
        specs.append(MapSpec(label, source, map_hash(pm)))
    if not specs:
        raise SweepError("no maps given")
    return specs


def resolve_strategies(names: Iterable[str]) -> list[str]:
    from tpuaf.policies import REGISTRY

    valid = REGISTRY.names()
    out: list[str] = []
    for name in names:
        s = str(name).lower()
        if s not in valid:
            raise SweepError(f"unknown strategy '{name}' (valid: {', '.join(valid)})")
        if s not in out:
            out.append(s)
    if not out:
        raise SweepError("no strategies given")
    return out


def make_spec(maps: Iterable[str], strategies: Iterable[str], robots: Iterable[int],
              seeds: int | Iterable[int], duration_s: float = 3600.0,
              first_seed: int = 0, scenarios: Iterable[Scenario] | None = None,
              teammate_timeout_s: float = LIVENESS_DEFAULTS.teammate_timeout_s,
              map_params: dict[str, Any] | None = None) -> SweepSpec:
    """A validated sweep; `seeds` is a count (seeds first_seed .. first_seed + count - 1) or a list.
    `scenarios` (default: nominal only) come from `make_scenarios`; teammate_timeout_s [s]:
    every run's (RunConfig.teammate_timeout_s); map_params: every map's setting overrides."""
    robots = list(robots)
    for n in robots:
        if not (isinstance(n, int) and n >= 1):
            raise SweepError(f"team sizes must be integers >= 1, got {n!r}")
    if not robots:
        raise SweepError("no team sizes given")
    if isinstance(seeds, int):
        if seeds < 1:
            raise SweepError(f"the number of seeds must be >= 1, got {seeds}")
        seed_list = list(range(first_seed, first_seed + seeds))
    else:
        seed_list = [int(s) for s in seeds]
        if not seed_list:
            raise SweepError("no seeds given")
    if not (duration_s > 0 and math.isfinite(duration_s)):
        raise SweepError(f"duration must be a finite number of seconds > 0, got {duration_s}")
    if not (teammate_timeout_s > 0 and math.isfinite(teammate_timeout_s)):
        raise SweepError(f"teammate timeout must be a finite number of seconds > 0, got "
                         f"{teammate_timeout_s}")
    scenarios = list(scenarios) if scenarios is not None else [Scenario()]
    for sc in scenarios:
        if sc.death_time_s is not None and sc.deaths != "0" and sc.death_time_s >= duration_s:
            raise SweepError(f"scenario {sc.name}: robots die at {sc.death_time_s:g} s, not before "
                             f"the end of the run ({duration_s:g} s)")
    robots = sorted(set(robots))
    for sc in scenarios:
        if sc.deaths != "0" and not any(sc.applies(n) for n in robots):
            raise SweepError(f"scenario {sc.name}: no team size in {robots} keeps a survivor "
                             "with at least one death")
    spec = SweepSpec(resolve_maps(maps, map_params), resolve_strategies(strategies),
                     robots, sorted(set(seed_list)), float(duration_s), scenarios=scenarios,
                     teammate_timeout_s=float(teammate_timeout_s),
                     map_params=dict(map_params or {}))
    if not spec.keys():
        raise SweepError("the sweep has no runs")
    return spec
