"""Experiment sweeps: the grid (map x strategy x N x seed) of batch runs, on Dask (ROS-free).

One task = one batch run, executed on a worker (`run_task`): it loads the map from its name or
path (workers share the filesystem), runs `BatchRun` and returns the summary plus the interval
idleness samples. The client writes each result as it arrives into

    DIR/runs/<map>/<strategy>/N<k>/seed<s>/
        config.json            the run's key and effective configuration
        idleness.txt.gz        interval idleness samples [s], one per line
        error.txt              only for a failed run (its traceback)
        summary.json           every metric; written last (temp file + rename)

so a finished run is one whose summary.json exists; a re-run skips those (resumption), and a
failed run (error.txt, no summary.json) is retried. The tidy tables are rebuilt from the run
folders after every sweep:

    DIR/results.csv            one row per run folder (finished or failed)
    DIR/samples.csv.gz         map, strategy, robots, seed, idleness_s: every interval sample
    DIR/reference.csv          reference tours (cyclic, partition) per (map, N), tours.py
"""

from __future__ import annotations

import contextlib
import csv
import gzip
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

from .errors import TpuafError


class SweepError(TpuafError):
    """An invalid sweep (unknown map or strategy, inconsistent results folder)."""


# Columns of results.csv: the run key, its status, then the metrics of the summary.
KEY_COLUMNS = ["map", "strategy", "robots", "seed", "duration_s"]
METRIC_COLUMNS = [
    "idleness_avg_s", "idleness_std_s", "idleness_min_s", "idleness_max_s", "idleness_samples",
    "idleness_ins_mean_s", "worst_idleness_s", "uncertainty_mean", "uncertainty_final_mean",
    "interferences", "interference_rate_per_min", "visits", "counted_visits",
    "complete_cycles", "unvisited_vertices",
]
RESULT_COLUMNS = KEY_COLUMNS + ["status", "error"] + METRIC_COLUMNS + [
    "wall_time_s", "finished_at", "map_source"]
SAMPLE_COLUMNS = ["map", "strategy", "robots", "seed", "idleness_s"]
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


@dataclass(frozen=True)
class RunKey:
    map: str  # map label
    strategy: str  # lower case registry name
    robots: int
    seed: int

    def folder(self, root: Path) -> Path:
        return Path(root) / "runs" / self.map / self.strategy / f"N{self.robots}" / f"seed{self.seed}"


@dataclass
class SweepSpec:
    maps: list[MapSpec]
    strategies: list[str]
    robots: list[int]
    seeds: list[int]
    duration_s: float = 3600.0
    strategy_params: dict[str, dict[str, Any]] = field(default_factory=dict)  # per strategy

    def keys(self) -> list[RunKey]:
        return [RunKey(m.label, s, n, seed) for m in self.maps for s in self.strategies
                for n in self.robots for seed in self.seeds]

    def source_of(self, label: str) -> str:
        return next(m.source for m in self.maps if m.label == label)

    def task(self, key: RunKey) -> dict[str, Any]:
        """Everything a worker needs for one run (plain data, picklable)."""
        return {"map": key.map, "map_source": self.source_of(key.map), "strategy": key.strategy,
                "robots": key.robots, "seed": key.seed, "duration_s": self.duration_s,
                "strategy_params": dict(self.strategy_params.get(key.strategy, {}))}


_LABEL_OK = re.compile(r"^[A-Za-z0-9_.+-]+$")


def resolve_maps(names: Iterable[str]) -> list[MapSpec]:
    """Load every map once (validating it) and give each a unique label (its name)."""
    from .maps import MapError, builtin_map_names, load_map

    specs: list[MapSpec] = []
    for name in names:
        text = str(name)
        builtin = text in builtin_map_names()
        if not builtin and not Path(text).expanduser().exists():
            raise SweepError(
                f"unknown map '{text}': built-in maps are {', '.join(builtin_map_names())}; "
                "otherwise give the path of a map folder or .graph file")
        try:
            pm = load_map(text)
        except MapError as err:
            raise SweepError(f"map '{text}': {err}") from None
        source = text if builtin else str(Path(text).expanduser().resolve())
        label = pm.name if _LABEL_OK.match(str(pm.name) or "") else Path(text).stem
        if any(s.label == label for s in specs):
            other = next(s.source for s in specs if s.label == label)
            if other == source:
                continue  # the same map twice
            raise SweepError(f"maps '{other}' and '{text}' have the same name '{label}'")
        specs.append(MapSpec(label, source))
    if not specs:
        raise SweepError("no maps given")
    return specs


def resolve_strategies(names: Iterable[str]) -> list[str]:
    from .policies import REGISTRY

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
              first_seed: int = 0) -> SweepSpec:
    """A validated sweep; `seeds` is a count (seeds first_seed .. first_seed + count - 1) or a list."""
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
    return SweepSpec(resolve_maps(maps), resolve_strategies(strategies),
                     sorted(set(robots)), sorted(set(seed_list)), float(duration_s))


# ------------------------------------------------------------------------------- one run


def run_task(task: dict[str, Any]) -> dict[str, Any]:
    """One batch run on a worker. Never raises: a failure comes back as `error` (traceback)."""
    start = time.perf_counter()
    result: dict[str, Any] = {"task": task, "host": socket.gethostname(), "pid": os.getpid()}
    try:
        from .maps import load_map
        from .runtimes.graph import BatchRun, RunConfig

        config = RunConfig(map=task["map_source"], strategy=task["strategy"],
                           robots=int(task["robots"]), duration_s=float(task["duration_s"]),
                           seed=int(task["seed"]),
                           strategy_params=dict(task.get("strategy_params") or {}))
        engine = BatchRun(config, load_map(task["map_source"]))
        summary = engine.run()
        result["config"] = engine.effective_config()
        result["summary"] = summary
        result["samples"] = np.asarray(engine.recorder.interval_samples, dtype=float)
        result["error"] = None
    except Exception as err:  # recorded in the run folder; the sweep goes on
        result["error"] = f"{type(err).__name__}: {err}\n\n{traceback.format_exc()}"
    result["wall_time_s"] = time.perf_counter() - start
    return result


def _atomic_write(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def _plain(value: Any) -> Any:
    """JSON-safe plain Python: numpy converted, NaN/inf -> None, anything else -> str."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    return str(value)


def _json_bytes(obj: Any) -> bytes:
    return (json.dumps(_plain(obj), indent=1, allow_nan=False) + "\n").encode()


def write_run(root: Path, result: dict[str, Any]) -> Path:
    """Write one run's folder; summary.json last and atomically (it marks the run finished)."""
    task = result["task"]
    key = RunKey(task["map"], task["strategy"], int(task["robots"]), int(task["seed"]))
    folder = key.folder(root)
    folder.mkdir(parents=True, exist_ok=True)
    summary_path = folder / "summary.json"
    if summary_path.exists():
        summary_path.unlink()  # recomputed: never leave an old summary beside new files
    meta = {"task": task, "host": result.get("host"), "pid": result.get("pid"),
            "wall_time_s": result.get("wall_time_s")}
    if result.get("error"):
        _atomic_write(folder / "config.json", _json_bytes({**meta, "config": result.get("config")}))
        _atomic_write(folder / "error.txt", result["error"].encode())
        return folder
    (folder / "error.txt").unlink(missing_ok=True)
    _atomic_write(folder / "config.json", _json_bytes({**meta, "config": result["config"]}))
    buf = io.BytesIO()
    with gzip.GzipFile(fileobj=buf, mode="wb", mtime=0) as gz:
        np.savetxt(gz, np.asarray(result["samples"], dtype=float), fmt="%.3f")
    _atomic_write(folder / "idleness.txt.gz", buf.getvalue())
    summary = dict(result["summary"])
    summary["run"] = {**task, "wall_time_s": result.get("wall_time_s"),
                      "finished_at": time.strftime("%Y-%m-%dT%H:%M:%S"),
                      "host": result.get("host")}
    _atomic_write(summary_path, _json_bytes(summary))
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
    return sorted(p for p in (Path(root) / "runs").glob("*/*/N*/seed*") if p.is_dir())


def _key_of(folder: Path) -> RunKey:
    seed = folder.name.removeprefix("seed")
    robots = folder.parent.name.removeprefix("N")
    return RunKey(folder.parent.parent.parent.name, folder.parent.parent.name, int(robots),
                  int(seed))


def _load_json(path: Path) -> dict:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as err:
        raise SweepError(f"{path}: unreadable ({err}); delete the file to recompute the run") from None


def collect(root: Path) -> list[dict[str, Any]]:
    """One row per run folder: finished (summary.json) or failed (error.txt)."""
    rows = []
    for folder in _run_folders(root):
        key = _key_of(folder)
        base = {"map": key.map, "strategy": key.strategy, "robots": key.robots, "seed": key.seed}
        summary_path = folder / "summary.json"
        if summary_path.is_file():
            s = _load_json(summary_path)
            run = s.get("run", {})
            row = {**base, "duration_s": run.get("duration_s", s.get("duration_s")),
                   "status": "ok", "error": ""}
            row.update({c: s.get(c) for c in METRIC_COLUMNS})
            row.update({"wall_time_s": run.get("wall_time_s"), "finished_at": run.get("finished_at"),
                        "map_source": run.get("map_source")})
        elif (folder / "error.txt").is_file():
            meta = _load_json(folder / "config.json") if (folder / "config.json").is_file() else {}
            task = meta.get("task", {})
            first = (folder / "error.txt").read_text().strip().splitlines()
            row = {**base, "duration_s": task.get("duration_s"), "status": "error",
                   "error": first[0] if first else "error",
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
    _atomic_write(results, _csv_text(rows, RESULT_COLUMNS).encode())
    out = io.StringIO()
    out.write(",".join(SAMPLE_COLUMNS) + "\n")
    for row in rows:
        if row["status"] != "ok":
            continue
        samples = read_samples(RunKey(row["map"], row["strategy"], row["robots"],
                                      row["seed"]).folder(root))
        prefix = f"{row['map']},{row['strategy']},{row['robots']},{row['seed']},"
        out.writelines(f"{prefix}{v:.3f}\n" for v in samples)
    buf = io.BytesIO()
    with gzip.GzipFile(fileobj=buf, mode="wb", mtime=0) as gz:
        gz.write(out.getvalue().encode())
    samples_path = root / "samples.csv.gz"
    _atomic_write(samples_path, buf.getvalue())
    return results, samples_path


def reference_rows(maps: list[MapSpec], robots: Iterable[int]) -> list[dict[str, Any]]:
    """Reference tours (tours.py) per (map, N) at the map's nominal speed."""
    from .maps import load_map
    from .tours import reference_tours

    rows = []
    for spec in maps:
        pm = load_map(spec.source)
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


def write_reference(root: Path, maps: list[MapSpec], robots: Iterable[int]) -> Path:
    """Merge the reference tours of these (map, N) into DIR/reference.csv."""
    path = Path(root) / "reference.csv"
    old = []
    if path.is_file():
        with open(path, newline="") as f:
            old = list(csv.DictReader(f))
    new = reference_rows(maps, robots)
    fresh = {(r["map"], int(r["robots"])) for r in new}
    keep = [r for r in old if (r["map"], int(r["robots"])) not in fresh]
    rows = sorted(keep + new, key=lambda r: (r["map"], int(r["robots"])))
    _atomic_write(path, _csv_text(rows, REFERENCE_COLUMNS).encode())
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
        if not math.isclose(float(run.get("duration_s", math.nan)), spec.duration_s):
            raise SweepError(
                f"{path.parent}: finished with duration {run.get('duration_s')} s, but this sweep "
                f"asks for {spec.duration_s:g} s; use another --out folder (or delete that run)")
        source = run.get("map_source")
        if source is not None and source != spec.source_of(key.map):
            raise SweepError(
                f"{path.parent}: map '{key.map}' came from {source}, this sweep gives "
                f"{spec.source_of(key.map)}; use another --out folder")
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
    write_reference(root, spec.maps, spec.robots)
    start = time.perf_counter()
    if todo:
        # The longest runs first (more robots), so the end of the sweep is not one long tail.
        todo.sort(key=lambda k: (-k.robots, k.map, k.strategy, k.seed))
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
                    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                           dashboard_address=None, host="127.0.0.1",
                                           local_directory=tempfile.gettempdir())
                client = Client(cluster)
            futures = {client.submit(run_task, spec.task(k), pure=False,
                                     key=f"run-{k.map}-{k.strategy}-N{k.robots}-s{k.seed}-"
                                         f"{time.time_ns()}"): k
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
                        bar.write(f"run {key.map}/{key.strategy}/N{key.robots}/seed{key.seed} "
                                  f"failed: {result['error'].splitlines()[0]}")
                    else:
                        outcome.ran += 1
                    if on_result is not None:
                        on_result(key, result)
                    bar.set_postfix_str(f"{key.map} {key.strategy} N={key.robots} s={key.seed}",
                                        refresh=False)
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


def _finish(root: Path, spec: SweepSpec, outcome: SweepOutcome) -> None:
    write_tables(root)
    record = {"maps": [asdict(m) for m in spec.maps], "strategies": spec.strategies,
              "robots": spec.robots, "seeds": spec.seeds, "duration_s": spec.duration_s,
              **{k: v for k, v in outcome.to_dict().items() if k != "computed"}}
    _atomic_write(Path(root) / "sweep.json", _json_bytes(record))
