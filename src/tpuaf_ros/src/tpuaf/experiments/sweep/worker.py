"""One run of a sweep on a worker: its RunConfig (scenario included), its runtime's engine,
the summary and interval idleness samples it returns (never raising)."""

from __future__ import annotations

import os
import socket
import time
import traceback
from typing import Any

import numpy as np

from tpuaf.experiments.sweep.grid import RUNTIMES, SweepError
from tpuaf.params import LIVENESS_DEFAULTS

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
