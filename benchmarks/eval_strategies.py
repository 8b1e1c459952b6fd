"""Strategies against the best-known tours: I_max and X over maps x team sizes x seeds.

Runs the graph runtime in-process (at most 2 worker processes) and prints, per map and N, the
median over seeds of I_max (worst interval idleness) and of X (time-mean uncertainty), and
I_max divided by the best-known tour's worst idleness (patrol_bounds.csv), beside the reference
tour under the visit rule and each strategy's worst idleness (a vertex never visited again
shows there, not in I_max). Faults: --fail-quarter
kills robots 0..N/4-1 at --fail-time; --loss and --delay act on every message.

    .venv/bin/python benchmarks/eval_strategies.py --strategies tpuaf_plus,msp \\
        --maps grid,cumberland --robots 4,8,12 --seeds 5 [--markdown out.md]
"""

from __future__ import annotations

import argparse
import csv
import multiprocessing as mp
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import visit_rule_reference  # noqa: E402

SHARED = Path(os.environ.get("TPUAF_SHARED", "/work/shared"))
MAPS_DIR = SHARED / "maps" / "patrolling_sim"
BOUNDS = SHARED / "reference" / "patrol_bounds.csv"
ALL_MAPS = ["grid", "cumberland", "example", "DIAG_labs", "1r5", "ctcv"]

_MAP_CACHE: dict = {}


def _load(name: str):
    from tpuaf.maps import load_map

    if name not in _MAP_CACHE:
        src = name if name in ("grid", "lab") or "/" in name else str(MAPS_DIR / name)
        _MAP_CACHE[name] = load_map(src)
    return _MAP_CACHE[name]


def run_one(job: tuple) -> tuple:
    """(strategy, map, N, seed, scenario dict) -> (job, I_max [s], X mean, wall [s])."""
    strategy, map_name, n, seed, scenario = job
    from tpuaf.runtimes.config import RunConfig
    from tpuaf.runtimes.graph import GraphRun

    fail = []
    if scenario.get("fail_quarter"):
        t = scenario.get("fail_time", 1800.0)
        fail = [f"{r}@{t:g}" for r in range(max(1, n // 4))] if n > 1 else []
    config = RunConfig(
        map=map_name, strategy=strategy, robots=n, duration_s=scenario.get("duration", 3600.0),
        seed=seed, delay_s=scenario.get("delay", 0.0), loss=scenario.get("loss", 0.0),
        strategy_params=dict(scenario.get("params", {})), fail=fail,
    )
    t0 = time.perf_counter()
    engine = GraphRun(config, patrol_map=_load(map_name))
    summary = engine.run()
    # worst idleness also counts a vertex never visited again (a dead robot's part)
    return job, summary["idleness_max_s"], summary["uncertainty_mean"], (
        summary["worst_idleness_s"], time.perf_counter() - t0)


def best_known() -> dict:
    out = {}
    if BOUNDS.exists():
        for row in csv.DictReader(BOUNDS.open()):
            out[(row["map"], int(row["N"]))] = float(row["best_known_worst_idleness_s"])
    return out


def evaluate(strategies, maps, robots, seeds, scenario, processes=2) -> dict:
    jobs = [(s, m, n, k, scenario) for s in strategies for m in maps for n in robots
            for k in range(1, seeds + 1)]
    results: dict = {}
    if processes > 1:
        with mp.get_context("fork").Pool(processes) as pool:
            done = pool.imap_unordered(run_one, jobs)
            for k, (job, i_max, x, extra) in enumerate(done):
                results.setdefault(job[:3], []).append((i_max, x, extra[0]))
                print(f"{k + 1}/{len(jobs)} {job[:4]} I_max {i_max:.1f}", file=sys.stderr,
                      flush=True)
    else:
        for job in jobs:
            job, i_max, x, extra = run_one(job)
            results.setdefault(job[:3], []).append((i_max, x, extra[0]))
    return results


def table(results, strategies, maps, robots, bounds, worst=True) -> list[str]:
    """Markdown rows; `worst` adds each strategy's worst idleness [s] (median): it also counts a
    vertex never visited again, which I_max (gaps between visits) cannot show."""
    per = 3 if worst else 2
    head = "| map | N | best-known [s] | reference, visit rule [s] | " + " | ".join(
        f"{s} I_max (ratio) | {s} X" + (f" | {s} worst" if worst else "")
        for s in strategies) + " |"
    lines = [head, "|" + "---|" * (4 + per * len(strategies))]
    for m in maps:
        for n in robots:
            b = bounds.get((m, n))
            cells = [m, str(n), f"{b:.2f}" if b is not None else "-",
                     f"{visit_rule_reference(_load(m), n):.2f}"]
            for s in strategies:
                rows = results.get((s, m, n), [])
                if not rows:
                    cells += ["-"] * per
                    continue
                i_max = statistics.median(r[0] for r in rows)
                x = statistics.median(r[1] for r in rows)
                ratio = f" ({i_max / b:.2f}x)" if b else ""
                cells += [f"{i_max:.1f}{ratio}", f"{x:.3f}"]
                if worst:
                    cells.append(f"{statistics.median(r[2] for r in rows):.1f}")
            lines.append("| " + " | ".join(cells) + " |")
    return lines


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--strategies", default="tpuaf_plus,tpuaf,cgg,msp")
    p.add_argument("--maps", default=",".join(ALL_MAPS))
    p.add_argument("--robots", default="4,8,12")
    p.add_argument("--seeds", type=int, default=5)
    p.add_argument("--duration", type=float, default=3600.0)
    p.add_argument("--delay", type=float, default=0.0)
    p.add_argument("--loss", type=float, default=0.0)
    p.add_argument("--fail-quarter", action="store_true",
                   help="robots 0..N/4-1 die at --fail-time")
    p.add_argument("--fail-time", type=float, default=1800.0)
    p.add_argument("--param", action="append", default=[], help="KEY=VALUE for every strategy")
    p.add_argument("--processes", type=int, default=2)
    p.add_argument("--markdown", help="append the table to this file")
    p.add_argument("--title", default="")
    a = p.parse_args(argv)
    strategies = a.strategies.split(",")
    maps = a.maps.split(",")
    robots = [int(x) for x in a.robots.split(",")]
    params = {}
    for kv in a.param:
        k, v = kv.split("=", 1)
        try:
            params[k] = float(v)
        except ValueError:
            params[k] = v
    scenario = {"duration": a.duration, "delay": a.delay, "loss": a.loss,
                "fail_quarter": a.fail_quarter, "fail_time": a.fail_time, "params": params}
    t0 = time.time()
    results = evaluate(strategies, maps, robots, a.seeds, scenario, min(2, a.processes))
    wall = time.time() - t0
    lines = table(results, strategies, maps, robots, best_known())
    load = os.getloadavg()[0]
    deaths = f"robots 0..N/4-1 die at {a.fail_time:g} s" if a.fail_quarter else "no deaths"
    desc = (f"{a.title}\n\nmedian of {a.seeds} seeds, {a.duration:g} s; delay {a.delay:g} s, "
            f"loss {a.loss:g}, {deaths}; wall {wall:.0f} s, load {load:.1f}\n\n")
    text = desc + "\n".join(lines) + "\n"
    print(text)
    if a.markdown:
        with open(a.markdown, "a") as f:
            f.write(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
