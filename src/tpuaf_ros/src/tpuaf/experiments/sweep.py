"""Experiment sweeps: the grid (map x strategy x N x scenario x seed) of runs, on Dask (ROS-free).

A scenario is the fault setting of a run (message loss, delay, robot deaths) and its runtime
(graph or physics): `nominal` is the fault-free graph run. One task = one run, executed on a
worker (`run_task`): it loads the map from its name or path (workers share the filesystem), runs
the runtime's engine and returns the summary plus the interval idleness samples. The client
writes each result as it arrives into

    DIR/runs/<map>/<strategy>/N<k>/seed<s>/              the nominal scenario
    DIR/runs/<map>/<strategy>/N<k>/<scenario>/seed<s>/   any other scenario, e.g. loss0.3
        config.json            the run's key and effective configuration
        idleness.txt.gz        interval idleness samples [s], one per line
        error.txt              only for a failed run (its traceback)
        summary.json           every metric; written last (temp file + rename)

so a finished run is one whose summary.json exists; a re-run skips those (resumption), and a
failed run (error.txt, no summary.json) is retried. The tidy tables are rebuilt from the run
folders after every sweep:

    DIR/results.csv            one row per run folder (finished or failed)
    DIR/samples.csv.gz         map, strategy, robots, seed, scenario, idleness_s: every interval
                               sample of the fault-free runs (nominal and other runtimes)
    DIR/reference.csv          reference tours (cyclic, partition) per (map, N), tours.py
    DIR/sweep.json             the last sweep's grid and wall time, plus `history`: every sweep
                               into this folder (its wall time, runs computed, git commit)
    DIR/plan.json              the runs the last sweep planned (their folders under runs/),
                               written before the first run and marked `ended` after the last:
                               `tpuaf report` tells a finished sweep from a running or an
                               interrupted one (finished, failed, missing runs)
"""

from __future__ import annotations

import contextlib
import csv
import functools
import gzip
import hashlib
import io
import json
import math
import os
import re
import socket
import sys
import tempfile
import time
import traceback
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from tpuaf.errors import TpuafError
from tpuaf.experiments.run_files import incomplete
from tpuaf.files import atomic_write
from tpuaf.params import LIVENESS_DEFAULTS
from tpuaf.plain import plain


class SweepError(TpuafError):
    """An invalid sweep (unknown map or strategy, inconsistent results folder)."""


# Columns of results.csv: the run key, its status, then the metrics of the summary.
KEY_COLUMNS = ["map", "strategy", "robots", "seed", "duration_s"]
# The scenario of a run: its name and what it sets (deaths = robots that die, at death_time_s).
SCENARIO_COLUMNS = ["scenario", "runtime", "loss", "delay_s", "deaths", "death_time_s"]
METRIC_COLUMNS = [
    "idleness_avg_s", "idleness_std_s", "idleness_min_s", "idleness_max_s", "idleness_samples",
    "idleness_ins_mean_s", "worst_idleness_s", "uncertainty_mean", "uncertainty_final_mean",
    "interferences", "interference_rate_per_min", "visits", "counted_visits",
    "complete_cycles", "unvisited_vertices",
]
# Recovery after deaths (summary "recovery", one entry per death; H-A's fault injection):
# the slowest recovery, the worst idleness after a death, the N - 1 survivors' ideal, the floor
# no strategy could avoid (metrics.death_floor) from the death and from its detection (the
# teammate timeout later), the dead robots' intentions still honoured (sum) and the deaths
# never recovered from.
RECOVERY_COLUMNS = ["recovery_time_s", "worst_idleness_after_s",
                    "ideal_worst_idleness_survivors_s", "floor_worst_idleness_after_s",
                    "detection_floor_worst_idleness_after_s", "intentions_honoured",
                    "unrecovered"]
RESULT_COLUMNS = KEY_COLUMNS + SCENARIO_COLUMNS + ["status", "error"] + METRIC_COLUMNS + \
    RECOVERY_COLUMNS + ["wall_time_s", "finished_at", "map_source"]
SAMPLE_COLUMNS = ["map", "strategy", "robots", "seed", "scenario", "idleness_s"]
REFERENCE_COLUMNS = [
    "map", "robots", "speed_mps",
    "cyclic_length_m", "cyclic_worst_idleness_s", "cyclic_avg_idleness_time_s",
    "cyclic_avg_idleness_visit_s",
    "partition_parts", "partition_worst_idleness_s", "partition_avg_idleness_time_s",
    "partition_avg_idleness_visit_s", "better",
]


# ------------------------------------------------------------------------------- the grid


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


# ------------------------------------------------------------------------------- one run


# RunConfig's field of robot deaths (H-A's fault injection, `tpuaf run --fail ROBOT@TIME`).
FAIL_FIELD = "fail"


def run_config(task: dict[str, Any]):
    """The RunConfig (PhysicsConfig for the physics runtime) of one task, scenario included;
    SweepError if this build lacks a field the scenario needs."""
    import dataclasses

    runtime = task.get("runtime") or "graph"
    if runtime == "physics":
        try:
            from tpuaf.runtimes.config import PhysicsConfig as Config
        except ImportError as err:
            raise SweepError(f"runtime 'physics' is not available in this build ({err})") from None
    elif runtime == "graph":
        from tpuaf.runtimes.config import RunConfig as Config
    else:
        raise SweepError(f"unknown runtime '{runtime}' (valid: {', '.join(RUNTIMES)})")
    fields = {f.name for f in dataclasses.fields(Config)}
    kwargs: dict[str, Any] = {
        "map": task["map_source"], "strategy": task["strategy"], "robots": int(task["robots"]),
        "duration_s": float(task["duration_s"]), "seed": int(task["seed"]),
        "strategy_params": dict(task.get("strategy_params") or {}),
        "delay_s": float(task.get("delay_s") or 0.0), "loss": float(task.get("loss") or 0.0),
        "teammate_timeout_s": float(task.get("teammate_timeout_s")
                                    or LIVENESS_DEFAULTS.teammate_timeout_s)}
    failures = task.get("failures") or []
    if failures:
        if FAIL_FIELD not in fields:
            raise SweepError(f"robot deaths need fault injection: RunConfig has no "
                             f"'{FAIL_FIELD}' field in this build")
        kwargs[FAIL_FIELD] = [f"{int(r)}@{float(t):g}" for r, t in failures]
    if task.get("robot"):
        kwargs["robot"] = task["robot"]
    if task.get("map_params"):
        kwargs["map_params"] = dict(task["map_params"])
    return Config(**kwargs)


def make_engine(config, patrol_map, runtime: str = "graph"):
    """The engine of a runtime: graph = runtimes/graph.py GraphRun (the C++ event loop);
    physics = runtimes/physics.py PhysicsRun."""
    if runtime == "graph":
        from tpuaf.runtimes.graph import make_run

        return make_run(config, patrol_map)
    if runtime == "physics":
        from tpuaf.runtimes.physics import PhysicsRun

        return PhysicsRun(config, patrol_map)
    raise SweepError(f"unknown runtime '{runtime}' (valid: {', '.join(RUNTIMES)})")


def run_task(task: dict[str, Any]) -> dict[str, Any]:
    """One run on a worker. Never raises: a failure comes back as `error` (traceback)."""
    start = time.perf_counter()
    result: dict[str, Any] = {"task": task, "host": socket.gethostname(), "pid": os.getpid()}
    try:
        from tpuaf.maps import load_map

        config = run_config(task)
        pm = load_map(task["map_source"], params=task.get("map_params"), params_origin="map_params")
        engine = make_engine(config, pm, task.get("runtime") or "graph")
        summary = engine.run()
        result["config"] = engine.effective_config()
        result["summary"] = summary
        result["samples"] = np.asarray(engine.recorder.interval_samples, dtype=float)
        result["error"] = None
    except Exception as err:  # recorded in the run folder; the sweep goes on
        result["error"] = f"{type(err).__name__}: {err}\n\n{traceback.format_exc()}"
    result["wall_time_s"] = time.perf_counter() - start
    return result


def _json_bytes(obj: Any) -> bytes:
    return (json.dumps(plain(obj), indent=1, allow_nan=False) + "\n").encode()


def write_run(root: Path, result: dict[str, Any]) -> Path:
    """Write one run's folder; summary.json last and atomically (it marks the run finished)."""
    task = result["task"]
    key = RunKey(task["map"], task["strategy"], int(task["robots"]), int(task["seed"]),
                 task.get("scenario") or NOMINAL)
    folder = key.folder(root)
    folder.mkdir(parents=True, exist_ok=True)
    summary_path = folder / "summary.json"
    if summary_path.exists():
        summary_path.unlink()  # recomputed: never leave an old summary beside new files
    meta = {"task": task, "host": result.get("host"), "pid": result.get("pid"),
            "wall_time_s": result.get("wall_time_s")}
    if result.get("error"):
        atomic_write(folder / "config.json", _json_bytes({**meta, "config": result.get("config")}))
        atomic_write(folder / "error.txt", result["error"].encode())
        return folder
    (folder / "error.txt").unlink(missing_ok=True)
    atomic_write(folder / "config.json", _json_bytes({**meta, "config": result["config"]}))
    buf = io.BytesIO()
    with gzip.GzipFile(fileobj=buf, mode="wb", mtime=0) as gz:
        np.savetxt(gz, np.asarray(result["samples"], dtype=float), fmt="%.3f")
    atomic_write(folder / "idleness.txt.gz", buf.getvalue())
    summary = dict(result["summary"])
    summary["run"] = {**task, "wall_time_s": result.get("wall_time_s"),
                      "finished_at": time.strftime("%Y-%m-%dT%H:%M:%S"),
                      "host": result.get("host")}
    atomic_write(summary_path, _json_bytes(summary))
    return folder


def read_samples(folder: Path) -> np.ndarray:
    path = Path(folder) / "idleness.txt.gz"
    if not path.exists():
        return np.zeros(0)
    with gzip.open(path, "rt") as f:
        text = f.read()
    return np.array(text.split(), dtype=float)


def finished(root: Path, key: RunKey) -> bool:
    return (key.folder(root) / "summary.json").is_file()


# ------------------------------------------------------------------------------- tables


def _run_folders(root: Path) -> list[Path]:
    runs = Path(root) / "runs"
    found = list(runs.glob("*/*/N*/seed*")) + list(runs.glob("*/*/N*/*/seed*"))
    return sorted(p for p in found if p.is_dir())


def _key_of(folder: Path) -> RunKey:
    seed = folder.name.removeprefix("seed")
    up = folder.parent
    scenario = NOMINAL
    if not (up.name.startswith("N") and up.name[1:].isdigit()):
        scenario, up = up.name, up.parent
    robots = up.name.removeprefix("N")
    return RunKey(up.parent.parent.name, up.parent.name, int(robots), int(seed), scenario)


def _load_json(path: Path) -> dict:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as err:
        raise SweepError(f"{path}: unreadable ({err}); delete the file to recompute the run") from None


def _scenario_fields(key: RunKey, task: dict[str, Any]) -> dict[str, Any]:
    """The scenario columns of a run (tasks of older sweeps have none: nominal graph runs)."""
    return {"scenario": key.scenario, "runtime": task.get("runtime") or "graph",
            "loss": task.get("loss") or 0.0, "delay_s": task.get("delay_s") or 0.0,
            "deaths": task.get("deaths") or 0, "death_time_s": task.get("death_time_s")}


def _recovery_fields(summary: dict[str, Any]) -> dict[str, Any]:
    entries = [e for e in (summary.get("recovery") or []) if isinstance(e, dict)]
    if not entries:
        return {}

    def values(name):
        return [float(e[name]) for e in entries if isinstance(e.get(name), (int, float))]

    rec, after = values("recovery_time_s"), values("worst_idleness_after_s")
    ideal, honoured = values("ideal_worst_idleness_survivors_s"), values("intentions_honoured")
    floor = values("floor_worst_idleness_after_s")
    detect = [v for v in values("detection_floor_worst_idleness_after_s") if v == v]
    return {"recovery_time_s": max(rec) if rec else None,
            "worst_idleness_after_s": max(after) if after else None,
            "ideal_worst_idleness_survivors_s": max(ideal) if ideal else None,
            "floor_worst_idleness_after_s": max(floor) if floor else None,
            "detection_floor_worst_idleness_after_s": max(detect) if detect else None,
            "intentions_honoured": sum(honoured) if honoured else None,
            "unrecovered": len(entries) - len(rec)}


def collect(root: Path) -> list[dict[str, Any]]:
    """One row per run folder: finished (summary.json), incomplete (its "complete": false) or
    failed (error.txt)."""
    rows = []
    for folder in _run_folders(root):
        key = _key_of(folder)
        base = {"map": key.map, "strategy": key.strategy, "robots": key.robots, "seed": key.seed}
        summary_path = folder / "summary.json"
        if summary_path.is_file():
            s = _load_json(summary_path)
            run = s.get("run", {})
            # "complete": false (interrupted, a full disk): listed with the failed runs
            why = incomplete(folder) if s.get("complete") is False else None
            row = {**base, "duration_s": run.get("duration_s", s.get("duration_s")),
                   **_scenario_fields(key, run), "status": "incomplete" if why else "ok",
                   "error": why or ""}
            row.update({c: s.get(c) for c in METRIC_COLUMNS})
            row.update(_recovery_fields(s))
            row.update({"wall_time_s": run.get("wall_time_s"), "finished_at": run.get("finished_at"),
                        "map_source": run.get("map_source")})
        elif (folder / "error.txt").is_file():
            meta = _load_json(folder / "config.json") if (folder / "config.json").is_file() else {}
            task = meta.get("task", {})
            first = (folder / "error.txt").read_text().strip().splitlines()
            row = {**base, "duration_s": task.get("duration_s"), **_scenario_fields(key, task),
                   "status": "error", "error": first[0] if first else "error",
                   "wall_time_s": meta.get("wall_time_s"), "map_source": task.get("map_source")}
        else:
            continue  # interrupted before anything was written
        rows.append(row)
    return rows


def _csv_text(rows: list[dict], columns: list[str]) -> str:
    out = io.StringIO()
    w = csv.DictWriter(out, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for row in rows:
        w.writerow({c: ("" if row.get(c) is None else row.get(c)) for c in columns})
    return out.getvalue()


def write_tables(root: Path) -> tuple[Path, Path]:
    """Rebuild results.csv and samples.csv.gz from the run folders (atomically)."""
    root = Path(root)
    rows = collect(root)
    results = root / "results.csv"
    atomic_write(results, _csv_text(rows, RESULT_COLUMNS).encode())
    out = io.StringIO()
    out.write(",".join(SAMPLE_COLUMNS) + "\n")
    for row in rows:
        if row["status"] != "ok" or row["loss"] or row["delay_s"] or row["deaths"]:
            continue  # the box plots show fault-free runs only
        samples = read_samples(RunKey(row["map"], row["strategy"], row["robots"],
                                      row["seed"], row["scenario"]).folder(root))
        prefix = f"{row['map']},{row['strategy']},{row['robots']},{row['seed']},{row['scenario']},"
        out.writelines(f"{prefix}{v:.3f}\n" for v in samples)
    buf = io.BytesIO()
    with gzip.GzipFile(fileobj=buf, mode="wb", mtime=0) as gz:
        gz.write(out.getvalue().encode())
    samples_path = root / "samples.csv.gz"
    atomic_write(samples_path, buf.getvalue())
    return results, samples_path


def reference_rows(maps: list[MapSpec], robots: Iterable[int],
                   map_params: dict[str, Any] | None = None) -> list[dict[str, Any]]:
    """Reference tours (tours.py) per (map, N) at the map's nominal speed (after the
    `map_params` overrides)."""
    from tpuaf.maps import load_map
    from tpuaf.maps.tours import reference_tours

    rows = []
    for spec in maps:
        pm = load_map(spec.source, params=map_params, params_origin="--map-param")
        speed = float(pm.settings.nominal_speed)
        for n in sorted(set(robots)):
            r = reference_tours(pm, n, speed)
            c, p = r["cyclic"], r["partition"]
            rows.append({
                "map": spec.label, "robots": n, "speed_mps": speed,
                "cyclic_length_m": c["length_m"], "cyclic_worst_idleness_s": c["worst_idleness_s"],
                "cyclic_avg_idleness_time_s": c["avg_idleness_time_s"],
                "cyclic_avg_idleness_visit_s": c["avg_idleness_visit_s"],
                "partition_parts": len(p["parts"]),
                "partition_worst_idleness_s": p["worst_idleness_s"],
                "partition_avg_idleness_time_s": p["avg_idleness_time_s"],
                "partition_avg_idleness_visit_s": p["avg_idleness_visit_s"],
                "better": r["better"],
            })
    return rows


def write_reference(root: Path, maps: list[MapSpec], robots: Iterable[int],
                    map_params: dict[str, Any] | None = None) -> Path:
    """Merge the reference tours of these (map, N) into DIR/reference.csv."""
    path = Path(root) / "reference.csv"
    old = []
    if path.is_file():
        with open(path, newline="") as f:
            old = list(csv.DictReader(f))
    new = reference_rows(maps, robots, map_params)
    fresh = {(r["map"], int(r["robots"])) for r in new}
    keep = [r for r in old if (r["map"], int(r["robots"])) not in fresh]
    rows = sorted(keep + new, key=lambda r: (r["map"], int(r["robots"])))
    atomic_write(path, _csv_text(rows, REFERENCE_COLUMNS).encode())
    return path


# ------------------------------------------------------------------------------- the sweep


@dataclass
class SweepOutcome:
    total: int
    skipped: int
    ran: int
    failed: int
    wall_time_s: float
    interrupted: bool = False
    computed: list[RunKey] = field(default_factory=list)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["computed"] = [asdict(k) for k in self.computed]
        return d


def check_existing(root: Path, spec: SweepSpec) -> list[RunKey]:
    """Keys still to run; finished runs must match this sweep (duration, map source)."""
    todo = []
    for key in spec.keys():
        path = key.folder(root) / "summary.json"
        if not path.is_file():
            todo.append(key)
            continue
        run = _load_json(path).get("run", {})
        duration = spec.duration_of(key)
        if not math.isclose(float(run.get("duration_s", math.nan)), duration):
            raise SweepError(
                f"{path.parent}: finished with duration {run.get('duration_s')} s, but this sweep "
                f"asks for {duration:g} s; use another --out folder (or delete that run)")
        # runs of older sweeps name no teammate timeout: theirs was the default
        mate = float(run.get("teammate_timeout_s") or LIVENESS_DEFAULTS.teammate_timeout_s)
        if not math.isclose(mate, spec.teammate_timeout_s):
            raise SweepError(
                f"{path.parent}: finished with teammate timeout {mate:g} s, but this sweep asks "
                f"for {spec.teammate_timeout_s:g} s; use another --out folder (or delete that "
                "run)")
        source = run.get("map_source")
        if source is not None and source != spec.source_of(key.map):
            raise SweepError(
                f"{path.parent}: map '{key.map}' came from {source}, this sweep gives "
                f"{spec.source_of(key.map)}; use another --out folder")
        task = spec.task(key)
        for field_name, what in (("map_hash", f"map '{key.map}' ({task['map_source']})"),
                                 ("params_hash", f"the parameters of {key.strategy}")):
            old = run.get(field_name)
            if old is not None and old != task[field_name]:
                raise SweepError(
                    f"{path.parent}: {what} changed since this run was computed (content "
                    f"{old}, now {task[field_name]}): results would mix; use another --out "
                    "folder (or delete the runs of the old content)")
    return todo


def default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
               else (os.cpu_count() or 1))


@contextlib.contextmanager
def _spawn_safely():
    """Start worker processes (multiprocessing spawn) that work from any entry point.

    - Spawned workers inherit sys.path; catkin's package shims put source folders in front of
      the devel space once imported, which would hide compiled modules (tpuaf_core._core) from
      the workers: start them with the devel python folders first.
    - Spawn re-runs the main script in each worker unless it was run with -m; a console script
      without a `__name__ == "__main__"` guard would then start a sweep in every worker. The
      workers need nothing from the main script, so it is hidden from them."""
    saved = list(sys.path)
    devel = [p for p in saved if p.rstrip("/").endswith("lib/python3/dist-packages")
             and Path(p).parent.parent.parent.name == "devel"]
    sys.path[:] = devel + [p for p in saved if p not in devel]
    main = sys.modules.get("__main__")
    main_file = getattr(main, "__file__", None)
    hide = main is not None and main_file is not None and getattr(main, "__spec__", None) is None
    if hide:
        del main.__file__
    try:
        yield
    finally:
        sys.path[:] = saved
        if hide:
            main.__file__ = main_file


def run_sweep(spec: SweepSpec, root: Path, *, scheduler: str | None = None,
              workers: int | None = None, progress: bool = True,
              on_result: Callable[[RunKey, dict], None] | None = None) -> SweepOutcome:
    """Run every unfinished run of `spec` on Dask, writing each as it completes.

    Without `scheduler` a LocalCluster on loopback (one single-threaded process per worker);
    with it, the existing cluster at that address. Tables are rebuilt at the end, also after an
    interruption (KeyboardInterrupt is re-raised after that)."""
    from tqdm import tqdm

    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    todo = check_existing(root, spec)
    total = len(spec.keys())
    outcome = SweepOutcome(total=total, skipped=total - len(todo), ran=0, failed=0,
                           wall_time_s=0.0)
    write_reference(root, spec.maps, spec.robots, spec.map_params)
    write_plan(root, spec, ended=False)
    start = time.perf_counter()
    if todo:
        # The longest runs first (more robots), so the end of the sweep is not one long tail.
        todo.sort(key=lambda k: (-k.robots, k.map, k.strategy, k.scenario, k.seed))
        cluster = client = None
        futures: dict = {}
        try:
            from dask.distributed import Client, LocalCluster, as_completed

            if scheduler:
                try:
                    client = Client(scheduler, timeout="15s")
                except OSError as err:
                    raise SweepError(f"cannot connect to the Dask scheduler at {scheduler}: {err}") from None
            else:
                n = workers or default_workers()
                with _spawn_safely():
                    # no dashboard; the scheduler's own HTTP server (health routes) on a free
                    # loopback port, not the default 8787 that another cluster may hold
                    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                           dashboard_address=None, host="127.0.0.1",
                                           scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                                           local_directory=tempfile.gettempdir())
                client = Client(cluster)
            futures = {client.submit(run_task, spec.task(k), pure=False,
                                     key=f"run-{k.map}-{k.strategy}-N{k.robots}-{k.scenario}-"
                                         f"s{k.seed}-{time.time_ns()}"): k
                       for k in todo}
            bar = tqdm(total=len(todo), desc="compare", unit="run", disable=not progress,
                       file=sys.stderr)
            try:
                for future in as_completed(futures):
                    key = futures[future]
                    try:
                        result = future.result()
                    except Exception as err:  # the worker died, not the run
                        result = {"task": spec.task(key), "error":
                                  f"{type(err).__name__}: {err} (worker failure)"}
                    write_run(root, result)
                    outcome.computed.append(key)
                    if result.get("error"):
                        outcome.failed += 1
                        bar.write(f"run {key.label()} failed: {result['error'].splitlines()[0]}")
                    else:
                        outcome.ran += 1
                    if on_result is not None:
                        on_result(key, result)
                    bar.set_postfix_str(key.label(), refresh=False)
                    bar.update(1)
            finally:
                bar.close()
        except KeyboardInterrupt:
            outcome.interrupted = True
            raise
        finally:
            outcome.wall_time_s = time.perf_counter() - start
            if client is not None:
                try:
                    if futures:
                        client.cancel(list(futures))
                finally:
                    client.close()
            if cluster is not None:
                cluster.close()
            _finish(root, spec, outcome)
    else:
        outcome.wall_time_s = time.perf_counter() - start
        _finish(root, spec, outcome)
    return outcome


def _git_commit() -> str | None:
    """The commit of the code that ran (with '+dirty' when files differ), None outside git."""
    import subprocess

    here = Path(__file__).resolve().parent
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=here, text=True,
                              capture_output=True, timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "."],
                               cwd=here, text=True, capture_output=True, timeout=10).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    return head + ("+dirty" if dirty.strip() else "")


PLAN_FILE = "plan.json"


def write_plan(root: Path, spec: SweepSpec, ended: bool, interrupted: bool = False) -> None:
    """DIR/plan.json: the run folders (relative to DIR) this sweep planned; `ended` once it
    returns (`interrupted` when stopped early)."""
    record = {"planned": [k.folder(Path(".")).as_posix() for k in spec.keys()],
              "ended": ended, "interrupted": interrupted,
              "updated_at": time.strftime("%Y-%m-%dT%H:%M:%S")}
    atomic_write(Path(root) / PLAN_FILE, _json_bytes(record))


def _finish(root: Path, spec: SweepSpec, outcome: SweepOutcome) -> None:
    write_plan(root, spec, ended=True, interrupted=outcome.interrupted)
    write_tables(root)
    path = Path(root) / "sweep.json"
    history: list = []
    if path.is_file():
        try:
            old = json.loads(path.read_text())
            history = list(old.get("history") or [])
        except (OSError, ValueError):
            history = []
    record = {"maps": [asdict(m) for m in spec.maps], "strategies": spec.strategies,
              "robots": spec.robots, "seeds": spec.seeds, "duration_s": spec.duration_s,
              "teammate_timeout_s": spec.teammate_timeout_s, "map_params": spec.map_params,
              "scenarios": [s.name for s in spec.scenarios],
              **{k: v for k, v in outcome.to_dict().items() if k != "computed"}}
    entry = {k: record[k] for k in ("strategies", "robots", "scenarios", "total", "ran",
                                    "skipped", "failed", "wall_time_s", "interrupted")}
    entry.update(maps=[m.label for m in spec.maps], seeds=len(spec.seeds),
                 finished_at=time.strftime("%Y-%m-%dT%H:%M:%S"), commit=_git_commit())
    if outcome.ran or outcome.failed:
        history.append(entry)
    record["history"] = history
    atomic_write(path, _json_bytes(record))
