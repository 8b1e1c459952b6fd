"""A sweep on Dask (a LocalCluster on loopback, or a scheduler's cluster): the runs still to do
(checked against the finished ones), each result written as it arrives, then the tables,
plan.json and sweep.json."""

from __future__ import annotations

import contextlib
import json
import math
import os
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

from tpuaf.experiments.sweep.folders import json_bytes, load_json, write_run
from tpuaf.experiments.sweep.grid import RunKey, SweepError, SweepSpec
from tpuaf.experiments.sweep.tables import write_reference, write_tables
from tpuaf.experiments.sweep.worker import run_task
from tpuaf.files import atomic_write
from tpuaf.params import LIVENESS_DEFAULTS


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
        run = load_json(path).get("run", {})
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
                    _record(root, spec, futures[future], future, outcome, bar, on_result)
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


def _record(root: Path, spec: SweepSpec, key: RunKey, future, outcome: SweepOutcome, bar,
            on_result: Callable[[RunKey, dict], None] | None) -> None:
    """One finished future: its run folder written, counted, shown on the progress bar."""
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


def _git_commit() -> str | None:
    """The commit of the code that ran (with '+dirty' when files differ), None outside git."""
    import subprocess

    here = Path(__file__).resolve().parent.parent  # experiments/
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
    atomic_write(Path(root) / PLAN_FILE, json_bytes(record))


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
    atomic_write(path, json_bytes(record))
