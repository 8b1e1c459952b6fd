"""Global planner speed (tpuaf_core.Costmap, GridPlanner) on the patrolling_sim reference maps:
start-up (costmap build + planner + the paths of every graph edge) and one replan across the
map (the farthest vertex pair along the graph), medians over repetitions.

    .venv/bin/python benchmarks/bench_planner.py [--quick] [--maps DIR] [--out FILE]

Writes benchmarks/results/planner.md. Targets on DIAG_labs (1000 x 800 cells at 0.05 m):
start-up < 1 s, replan < 20 ms (median).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import tpuaf_core as tc
from common import RESULTS, header, write

MAPS = Path("/work/shared/maps/patrolling_sim")
COARSE_M = 0.1  # [m] planning resolution that meets the DIAG_labs targets
ROBOT_RADIUS_M = 0.105  # TurtleBot3 Burger: the discs of other robots in the obstacle replan


def timed(fn, reps: int) -> tuple[float, float, object]:
    """Median wall and thread-CPU seconds of fn() over reps calls, and the last result."""
    wall, cpu, out = [], [], None
    for _ in range(reps):
        w0, c0 = time.perf_counter(), time.thread_time()
        out = fn()
        cpu.append(time.thread_time() - c0)
        wall.append(time.perf_counter() - w0)
    return statistics.median(wall), statistics.median(cpu), out


def bench_map(folder: Path, planning_m: float, reps: int, replans: int) -> dict:
    from tpuaf.maps import load_map

    pm = load_map(folder)
    grid = pm.occupancy_grid()
    spec = tc.CostmapSpec()
    edges = np.array([(u, v) for u, v, *_ in pm.edges], dtype=int)

    def startup():
        cm = tc.Costmap(grid.occupied, grid.resolution, grid.origin, spec, planning_m)
        planner = tc.GridPlanner(cm)
        return cm, planner, planner.plan_edges(pm.positions, edges)

    up_wall, up_cpu, (cm, planner, plans) = timed(startup, reps)
    build_wall, _, _ = timed(
        lambda: tc.Costmap(grid.occupied, grid.resolution, grid.origin, spec, planning_m), reps)
    edges_wall, edges_cpu, _ = timed(lambda: planner.plan_edges(pm.positions, edges), reps)

    d = pm.graph.distances
    i, j = np.unravel_index(np.argmax(d), d.shape)
    a, b = pm.positions[i], pm.positions[j]
    re_wall, re_cpu, plan = timed(lambda: planner.plan(a, b), replans)
    # Other robots parked on four vertices spread along the graph (not the start or goal).
    others = [v for v in np.argsort(d[i]) if v not in (i, j)]
    parked = [others[k * len(others) // 5] for k in range(1, 5)]
    discs = np.array([[*pm.positions[v], ROBOT_RADIUS_M] for v in parked])
    ob_wall, ob_cpu, ob_plan = timed(lambda: planner.plan(a, b, discs), replans)
    straight = np.linalg.norm(pm.positions[edges[:, 1]] - pm.positions[edges[:, 0]], axis=1)
    lengths = np.array([p.length_m for p in plans])
    ok = np.array([p.ok for p in plans])
    return {
        "map": folder.name,
        "size": f"{grid.width} x {grid.height}",
        "map_res": grid.resolution,
        "plan_res": cm.resolution,
        "cells": cm.width * cm.height,
        "free": float(np.mean(~cm.lethal())),
        "startup_ms": up_wall * 1e3,
        "startup_cpu_ms": up_cpu * 1e3,
        "build_ms": build_wall * 1e3,
        "edges_ms": edges_wall * 1e3,
        "edges_cpu_ms": edges_cpu * 1e3,
        "edges": len(plans),
        "edges_ok": int(ok.sum()),
        "snapped": sum(p.start_snapped or p.goal_snapped for p in plans),
        "detour": float(np.median(lengths[ok] / straight[ok])) if ok.any() else float("nan"),
        "replan_ms": re_wall * 1e3,
        "replan_cpu_ms": re_cpu * 1e3,
        "replan_status": str(plan.status).split(".")[-1],
        "replan_len": plan.length_m,
        "graph_len": float(d[i, j]),
        "replan_expanded": plan.expanded,
        "replan_points": len(plan.points),
        "obst_ms": ob_wall * 1e3,
        "obst_cpu_ms": ob_cpu * 1e3,
        "obst_status": str(ob_plan.status).split(".")[-1],
        "obst_len": ob_plan.length_m,
    }


def report(rows: list[dict], load0, load1, args) -> str:
    def load(la):
        return " / ".join(f"{x:.2f}" for x in la)

    diag = [r for r in rows if r["map"] == "DIAG_labs"]
    lines = [
        header("Global planner (benchmarks/bench_planner.py)").rstrip(),
        f"Load average at start {load(load0)}, at end {load(load1)} (1 / 5 / 15 min; a shared "
        "2-core machine: the thread-CPU figures are the less disturbed ones).",
        "",
        "Costmap: inscribed radius 0.2 m (TurtleBot3 Burger 0.105 m + margin), inflation 0.6 m, "
        "cost scaling 5 / m, cost weight 1; snap radius 0.5 m; smoothing on. Start-up = Costmap "
        "build + GridPlanner + `plan_edges` for every graph edge. Replan = `plan` between the "
        "two vertices farthest apart along the graph; with obstacles: the same with four 0.105 m "
        f"discs (robots parked on vertices). Medians of {args.reps} start-ups and "
        f"{args.replans} replans; wall clock, thread CPU in brackets.",
        "",
    ]
    if diag:
        best = min(diag, key=lambda r: r["replan_ms"])
        lines += [
            "## Targets (DIAG_labs)",
            "",
            "| figure | median | target |",
            "|---|---|---|",
            f"| start-up, planning grid {best['plan_res']:.2f} m | {best['startup_ms']:.0f} ms "
            f"({best['startup_cpu_ms']:.0f} ms CPU) | < 1000 ms |",
            f"| replan across the map, planning grid {best['plan_res']:.2f} m | "
            f"{best['replan_ms']:.1f} ms ({best['replan_cpu_ms']:.1f} ms CPU) | < 20 ms |",
            "",
        ]
    lines += [
        "## All maps",
        "",
        "| map | cells (res) | planning grid | free | start-up ms | of which costmap ms | "
        "edges ms | edges ok | snapped | detour | replan ms | replan | expanded | "
        "with obstacles ms |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['map']} | {r['size']} ({r['map_res']:.3g} m) | {r['plan_res']:.3g} m, "
            f"{r['cells']:,} cells | {r['free'] * 100:.0f}% | {r['startup_ms']:.1f} "
            f"({r['startup_cpu_ms']:.1f}) | {r['build_ms']:.1f} | {r['edges_ms']:.1f} "
            f"({r['edges_cpu_ms']:.1f}) | {r['edges_ok']}/{r['edges']} | {r['snapped']} | "
            f"{r['detour']:.3f} | {r['replan_ms']:.2f} ({r['replan_cpu_ms']:.2f}) | "
            f"{r['replan_status']}, {r['replan_len']:.1f} m (graph {r['graph_len']:.1f} m), "
            f"{r['replan_points']} points | {r['replan_expanded']:,} | {r['obst_ms']:.2f} "
            f"({r['obst_cpu_ms']:.2f}), {r['obst_status']}, {r['obst_len']:.1f} m |")
    lines += [
        "",
        "free: non-lethal share of the planning grid. snapped: edges whose end vertex lies in a "
        "lethal cell and moved to the nearest visible free one. detour: median of path length / "
        "straight distance over the edges. expanded: cells expanded by the replan's A*.",
    ]
    return "\n".join(lines) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", type=Path, default=MAPS, help="folder of patrolling_sim maps")
    ap.add_argument("--quick", action="store_true", help="fewer repetitions")
    ap.add_argument("--out", type=Path, default=RESULTS / "planner.md")
    args = ap.parse_args()
    args.reps, args.replans = (3, 7) if args.quick else (9, 31)
    folders = sorted(p for p in args.maps.iterdir() if p.is_dir() and any(p.glob("*.graph")))
    folders.sort(key=lambda p: (p.name != "DIAG_labs", p.name))
    load0 = os.getloadavg()
    rows = []
    for folder in folders:
        from tpuaf.maps import load_map

        res = load_map(folder).occupancy_grid().resolution
        for planning_m in [0.0] + ([COARSE_M] if round(COARSE_M / res) > 1 else []):
            row = bench_map(folder, planning_m, args.reps, args.replans)
            rows.append(row)
            print(f"{row['map']:>10} grid {row['plan_res']:.3f} m: start-up "
                  f"{row['startup_ms']:.1f} "
                  f"ms (costmap {row['build_ms']:.1f}, edges {row['edges_ms']:.1f}), edges ok "
                  f"{row['edges_ok']}/{row['edges']}, replan {row['replan_ms']:.2f} ms "
                  f"(CPU {row['replan_cpu_ms']:.2f}) {row['replan_status']} "
                  f"{row['replan_len']:.1f} m, with obstacles {row['obst_ms']:.2f} ms "
                  f"{row['obst_status']}", flush=True)
    text = report(rows, load0, os.getloadavg(), args)
    write(args.out.resolve(), text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
