"""Benchmark of the graph (batch) runtime: Python engine vs native C++ engine, scale, sweeps.

Run: .venv/bin/python benchmarks/bench_batch.py [--repeats K] [--quick]
Writes benchmarks/results/batch.md. Cumberland is imported from ../shared (never copied); the
1,000-vertex graph is generated here (`grid1000`: a 40 x 25 lattice at 5.7 m, the grid map's
settings, 141 edges dropped at random, seed 0, keeping it connected: 1,794 edges).

Every figure is a median over `--repeats` runs of 1 simulated hour, seed 1, measured two ways:
- whole process: a fresh interpreter that imports tpuaf, loads or builds the map, runs and
  exits (what a user or a sweep worker pays per run);
- in-engine: engine.run() alone, in this process.
Peak RSS is the child process's own maximum resident set.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from common import header, write

REPO = Path(__file__).resolve().parents[1]
SHARED_MAPS = REPO.parent / "shared" / "maps" / "patrolling_sim"
GRID1000 = "grid1000"


def make_grid1000(cols: int = 40, rows: int = 25, spacing_m: float = 5.7, drop: int = 141,
                  seed: int = 0):
    """The generated 1,000-vertex benchmark graph (see the module docstring)."""
    from tpuaf.maps import MapSettings, PatrolMap

    ids, pos, edges = [], [], []
    for c in range(cols):
        for r in range(rows):
            ids.append(c * rows + r)
            pos.append((spacing_m * c, spacing_m * r))
            if r < rows - 1:
                edges.append((c * rows + r, c * rows + r + 1))
            if c < cols - 1:
                edges.append((c * rows + r, (c + 1) * rows + r))
    adjacency: dict[int, set[int]] = {v: set() for v in range(len(ids))}
    for u, v in edges:
        adjacency[u].add(v)
        adjacency[v].add(u)

    def connected(u: int, v: int) -> bool:
        seen, stack = {u}, [u]
        while stack:
            w = stack.pop()
            if w == v:
                return True
            for x in adjacency[w] - seen:
                seen.add(x)
                stack.append(x)
        return False

    dropped: set[int] = set()
    for k in np.random.default_rng(seed).permutation(len(edges)).tolist():
        if len(dropped) == drop:
            break
        u, v = edges[k]
        adjacency[u].discard(v)
        adjacency[v].discard(u)
        if connected(u, v):
            dropped.add(k)
        else:
            adjacency[u].add(v)
            adjacency[v].add(u)
    kept = [(u, v, float("nan")) for k, (u, v) in enumerate(edges) if k not in dropped]
    settings = MapSettings(nominal_speed=1.0, sensing_radius=5.0, interference_distance=2.0,
                           goal_tolerance=0.4, robot_radius=0.105)
    n = len(ids)
    return PatrolMap(name=GRID1000, vertex_ids=ids, positions=np.array(pos, dtype=float),
                     edges=kept, importance=np.full(n, settings.default_importance),
                     initial_uncertainty=np.full(n, settings.default_initial_uncertainty),
                     settings=settings)


def load(map_name: str):
    from tpuaf.maps import load_map

    if map_name == GRID1000:
        return make_grid1000()
    if map_name == "cumberland":
        return load_map(str(SHARED_MAPS / "cumberland"))
    return load_map(map_name)


def one_run(map_name: str, strategy: str, robots: int, engine: str, duration_s: float) -> dict:
    """One run in this process: timings of its phases and this process's peak RSS."""
    from tpuaf.runtimes.config import RunConfig
    from tpuaf.runtimes.graph import BatchRun
    from tpuaf.runtimes.native import NativeRun

    t0 = time.perf_counter()
    patrol_map = load(map_name)
    patrol_map.graph  # noqa: B018 - build the graph (all-pairs paths) outside the run
    t1 = time.perf_counter()
    config = RunConfig(map=map_name, strategy=strategy, robots=robots, duration_s=duration_s,
                       seed=1)
    run = NativeRun(config, patrol_map) if engine == "native" else BatchRun(config, patrol_map)
    t2, c2 = time.perf_counter(), time.process_time()
    summary = run.run()
    t3, c3 = time.perf_counter(), time.process_time()
    return {"map_s": t1 - t0, "setup_s": t2 - t1, "run_s": t3 - t2, "run_cpu_s": c3 - c2,
            "visits": summary["visits"],
            "native_policy": bool(getattr(run, "native_policy", False)),
            "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}


def whole_process(map_name: str, strategy: str, robots: int, engine: str,
                  duration_s: float) -> dict:
    """One run in a fresh interpreter; adds its wall time from spawn to exit."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    out = subprocess.run(
        [sys.executable, __file__, "--one", map_name, strategy, str(robots), engine,
         str(duration_s)], capture_output=True, text=True, check=True, cwd=REPO)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    result = json.loads(out.stdout.strip().splitlines()[-1])
    result["process_s"] = wall
    result["process_cpu_s"] = (after.ru_utime - before.ru_utime) + (after.ru_stime -
                                                                    before.ru_stime)
    return result


def measure(map_name, strategy, robots, engine, duration_s, repeats) -> dict:
    runs = [whole_process(map_name, strategy, robots, engine, duration_s)
            for _ in range(repeats)]
    med = {k: statistics.median(r[k] for r in runs)
           for k in ("process_s", "process_cpu_s", "run_s", "run_cpu_s", "map_s", "rss_mb")}
    med["visits"] = runs[0]["visits"]
    med["native_policy"] = runs[0]["native_policy"]
    med["range"] = (min(r["process_s"] for r in runs), max(r["process_s"] for r in runs))
    return med


SWEEP_STRATEGIES = ["tpuaf", "gbs", "dtag", "dtap"]  # dtap runs its Python policy


def sweep_wall(workers: int, root: Path) -> float:
    """Wall time of one small sweep (grid x SWEEP_STRATEGIES x N = 4, 12 x 2 seeds x 30 min) on
    a local Dask cluster of `workers` single-threaded processes, cluster start included."""
    from tpuaf.experiments.sweep import make_spec, run_sweep

    spec = make_spec(["grid"], SWEEP_STRATEGIES, [4, 12], 2, 1800.0)
    start = time.perf_counter()
    outcome = run_sweep(spec, root, workers=workers, progress=False)
    wall = time.perf_counter() - start
    if outcome.failed or outcome.ran != len(spec.keys()):
        raise RuntimeError(f"sweep with {workers} workers: {outcome}")
    return wall


def uptime() -> str:
    try:
        return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    except OSError:
        return "unknown"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--duration", type=float, default=3600.0)
    parser.add_argument("--quick", action="store_true", help="skip the Python engine rows and "
                        "the sweep")
    parser.add_argument("--one", nargs=5, metavar=("MAP", "STRATEGY", "N", "ENGINE", "S"),
                        help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        m, s, n, e, d = args.one
        print(json.dumps(one_run(m, s, int(n), e, float(d))))
        return
    r = args.repeats
    lines = [header("Graph runtime benchmark (benchmarks/bench_batch.py)")]
    lines.append(f"Machine load before: `{uptime()}` (2 cores shared with other jobs; figures "
                 "scale with it).\n")
    lines.append(f"One run = {args.duration:g} simulated seconds, seed 1, default settings, no "
                 f"results folder. Median of {r} runs. *whole process* = fresh interpreter: "
                 "imports, map, run, exit; *in-engine* = `run()` alone. Wall and CPU time "
                 "(user + system) of each: on a shared, loaded machine the CPU time is what a "
                 "quiet machine's wall time would be (every run is single-threaded). Real-time "
                 "factor = simulated / time.\n")
    lines.append("## Cumberland, 12 TPUAF robots (target 10,000x real time)\n")
    lines.append("| engine | visits | whole process wall s (min-max) | whole CPU s | "
                 "in-engine wall s | in-engine CPU s | real time, whole (wall / CPU) | "
                 "real time, in-engine (wall / CPU) | peak RSS MB |")
    lines.append("|---|---|---|---|---|---|---|---|---|")
    engines = ["native"] if args.quick else ["python", "native"]
    for engine in engines:
        m = measure("cumberland", "tpuaf", 12, engine, args.duration, r)
        lines.append(
            f"| {engine}{' (C++ TPUAF)' if m['native_policy'] else ''} | {m['visits']:,} | "
            f"{m['process_s']:.2f} ({m['range'][0]:.2f}-{m['range'][1]:.2f}) | "
            f"{m['process_cpu_s']:.2f} | {m['run_s']:.3f} | {m['run_cpu_s']:.3f} | "
            f"{args.duration / m['process_s']:,.0f}x / {args.duration / m['process_cpu_s']:,.0f}x"
            f" | {args.duration / m['run_s']:,.0f}x / {args.duration / m['run_cpu_s']:,.0f}x | "
            f"{m['rss_mb']:.0f} |")
        print(lines[-1], flush=True)
    lines.append("\n## Generated 1,000-vertex graph (grid1000, 1,794 edges), TPUAF, native "
                 "engine\n")
    lines.append("Targets: N = 100 in <= 3 s, N = 300 in < 15 s with peak RSS < 300 MB. "
                 "Before (Python engine, issue 14, quiet machine): 2.4 / 3.5 / 12.3 / 105.7 s "
                 "at N = 10 / 30 / 100 / 300, 297 MB at 300.\n")
    lines.append("| N | visits | whole process wall s (min-max) | whole CPU s | of which map "
                 "build wall s | in-engine wall s | in-engine CPU s | real time, in-engine CPU | "
                 "peak RSS MB |")
    lines.append("|---|---|---|---|---|---|---|---|---|")
    scale = {}
    for n in (10, 30, 100, 300):
        m = measure(GRID1000, "tpuaf", n, "native", args.duration, r)
        scale[n] = m
        lines.append(
            f"| {n} | {m['visits']:,} | {m['process_s']:.2f} ({m['range'][0]:.2f}-"
            f"{m['range'][1]:.2f}) | {m['process_cpu_s']:.2f} | {m['map_s']:.2f} | "
            f"{m['run_s']:.2f} | {m['run_cpu_s']:.2f} | {args.duration / m['run_cpu_s']:,.0f}x | "
            f"{m['rss_mb']:.0f} |")
        print(lines[-1], flush=True)
    for key, label in (("process_s", "whole process wall"), ("process_cpu_s", "whole process CPU"),
                       ("run_s", "in-engine wall"), ("run_cpu_s", "in-engine CPU")):
        exponent = math.log(scale[300][key] / scale[100][key]) / math.log(3.0)
        lines.append(f"\nFitted exponent of wall time in N from 100 to 300 ({label}): "
                     f"**{exponent:.2f}** (before: about 2).")
    if not args.quick:
        lines.append("\n## Sweep on a local Dask cluster (1 thread per worker)\n")
        lines.append("`tpuaf.experiments.sweep.run_sweep` of grid x {" + ", ".join(SWEEP_STRATEGIES) +
                     "} x N {4, 12} x 2 seeds, 30 min each (16 runs; tpuaf, gbs, dtag on the "
                     "native engine, dtap in Python), cluster start included, one fresh results "
                     f"folder per measurement; median of {min(r, 2)}.\n")
        lines.append("| workers | wall s (median) | runs/min |")
        lines.append("|---|---|---|")
        for workers in (1, 2):
            walls = []
            for _ in range(min(r, 2)):
                with tempfile.TemporaryDirectory() as tmp:
                    walls.append(sweep_wall(workers, Path(tmp)))
            w = statistics.median(walls)
            lines.append(f"| {workers} | {w:.1f} | {16 / w * 60:.1f} |")
            print(lines[-1], flush=True)
    lines.append(f"\nMachine load after: `{uptime()}`.\n")
    write("batch.md", "\n".join(lines) + "\n")


if __name__ == "__main__":
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    main()
