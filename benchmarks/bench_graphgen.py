"""Generated patrol graphs (`tpuaf graph`, maps/generate.py) against the hand-made ones.

For every patrolling_sim reference map and the built-in grid: the graph generated from the
map's own occupancy image, for the map's robot radius and sensing radius r (imported maps:
0.165 m, 5 m), beside the hand-made graph: coverage of the reachable free space (cells seen in
line of sight within r from some vertex, on the generator's work grid; the same count for
both), vertex and edge counts, the best cyclic tour length found (tpuaf.maps.tours), and
tpuaf_plus's I_max (max idleness, graph runtime, N robots, 1 h, seed 0) on both, and the
generation time.

    .venv/bin/python benchmarks/bench_graphgen.py [--maps a,b] [--robots N] [--duration S]

Writes benchmarks/results/graphgen.md, graphgen.json and one picture per map and graph under
benchmarks/results/graphgen/.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from common import RESULTS, header, write

PS = Path("/work/shared/maps/patrolling_sim")
MAPS = ["1r5", "DIAG_labs", "ctcv", "cumberland", "example", "grid", "builtin:grid"]


def load(name: str):
    from tpuaf.maps import load_map

    if name.startswith("builtin:"):
        return load_map(name.split(":", 1)[1])
    return load_map(PS / name, allow_occupied_vertices=True)


def i_max(pm, robots: int, duration_s: float) -> float:
    from tpuaf.runtimes.config import RunConfig
    from tpuaf.runtimes.graph import make_run

    run = make_run(RunConfig(map=pm.name, strategy="tpuaf_plus", robots=robots,
                             duration_s=duration_s, seed=0), pm)
    return float(run.run()["idleness_max_s"])


def one_map(name: str, robots: int, duration_s: float, pictures: Path) -> dict:
    from dataclasses import replace

    from tpuaf.cli.graph import build
    from tpuaf.experiments.graph_figure import graph_png
    from tpuaf.maps.generate import GraphOptions, coverage_of
    from tpuaf.maps.tours import cyclic_tour
    from tpuaf.navigation.lanes import find_lanes
    from tpuaf.navigation.planner import PathPlanner

    hand = load(name)
    s = hand.settings
    occ = hand.occupancy_grid()
    opts = GraphOptions(robot_radius_m=s.robot_radius, sensing_radius_m=s.sensing_radius)
    start = time.perf_counter()
    gen_pm, gen, report = build(occ, opts, f"{hand.name}_gen",
                                replace(s, initial_vertices={}, initial_poses={},
                                        initial_pose_variants={}))
    seconds = time.perf_counter() - start
    hand_cover, hand_mask = coverage_of(gen.grid, hand.positions, s.sensing_radius)
    g = gen.grid
    h, w = g.occupied.shape
    extent = (g.origin[0], g.origin[0] + w * g.cell_m, g.origin[1], g.origin[1] + h * g.cell_m)
    tag = name.replace(":", "_")
    graph_png(hand, pictures / f"{tag}_hand.png", covered=hand_mask, region=g.region,
              extent=extent, title=f"{name} hand-made: {hand.num_vertices} vertices, "
              f"coverage {100 * hand_cover:.1f} % at r = {s.sensing_radius:g} m")
    graph_png(gen_pm, pictures / f"{tag}_generated.png", covered=gen.covered, region=g.region,
              extent=extent, kinds=gen.kinds, title=f"{name} generated: {gen_pm.num_vertices} "
              f"vertices, coverage {100 * gen.coverage:.1f} % at r = {s.sensing_radius:g} m")
    row = {"map": name, "robot_radius_m": s.robot_radius, "sensing_radius_m": s.sensing_radius,
           "generation_s": round(seconds, 2), "work_cell_m": report["work_cell_m"]}
    for key, pm, cover in (("hand", hand, hand_cover), ("gen", gen_pm, gen.coverage)):
        lanes = find_lanes(PathPlanner(pm, s.robot_radius), pm)
        row[key] = {"vertices": pm.num_vertices, "edges": pm.graph.num_edges,
                    "coverage": round(cover, 4),
                    "tour_m": round(float(cyclic_tour(pm).length), 1),
                    "i_max_s": round(i_max(pm, robots, duration_s), 1),
                    "narrow_vertices": len(lanes.narrow_vertices),
                    "lane_edges": sum(len(lane.edges) for lane in lanes.lanes)}
    row["gen"]["dead_ends"] = report["dead_ends"]
    row["gen"]["dropped_edges"] = len(report["dropped_edges"])
    print(json.dumps(row), file=sys.stderr, flush=True)
    return row


def table(rows: list[dict], robots: int, duration_s: float) -> str:
    lines = ["| map | r [m] | coverage hand / gen [%] | vertices hand / gen | edges hand / gen "
             "| tour hand / gen [m] | I_max hand / gen [s] | narrow vertices hand / gen "
             "| lane edges hand / gen | generation [s] |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        h, g = r["hand"], r["gen"]
        lines.append(
            f"| {r['map']} | {r['sensing_radius_m']:g} | {100 * h['coverage']:.1f} / "
            f"{100 * g['coverage']:.1f} | {h['vertices']} / {g['vertices']} | {h['edges']} / "
            f"{g['edges']} | {h['tour_m']:.1f} / {g['tour_m']:.1f} | {h['i_max_s']:.1f} / "
            f"{g['i_max_s']:.1f} | {h['narrow_vertices']} / {g['narrow_vertices']} | "
            f"{h['lane_edges']} / {g['lane_edges']} | {r['generation_s']:.1f} |")
    return "\n".join(lines) + (
        f"\n\nI_max: tpuaf_plus, graph runtime, N = {robots}, {duration_s:g} s, seed 0, each "
        "graph's own vertices (edge lengths: hand-made as declared, generated as planned for "
        "the robot). Coverage: reachable free cells seen in line of sight within r from some "
        "vertex, on the generator's work grid, the same count for both graphs. Narrow "
        "vertices (two robots cannot stand side by side there, every edge from them one robot "
        "wide) and lane edges: the lane map for the map's robot radius (navigation/lanes.py, "
        "docs/LANES.md); the generator counts half the cells a candidate in a doorway sees "
        "(maps/generate.py NARROW_GAIN_SHARE).\n")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--maps", default=",".join(MAPS))
    p.add_argument("--robots", type=int, default=4)
    p.add_argument("--duration", type=float, default=3600.0)
    args = p.parse_args()
    pictures = RESULTS / "graphgen"
    pictures.mkdir(parents=True, exist_ok=True)
    rows = [one_map(m, args.robots, args.duration, pictures) for m in args.maps.split(",")]
    command = ("`.venv/bin/python benchmarks/bench_graphgen.py"
               + (f" --maps {args.maps}" if args.maps != ",".join(MAPS) else "")
               + (f" --robots {args.robots}" if args.robots != 4 else "")
               + (f" --duration {args.duration:g}" if args.duration != 3600 else "") + "`")
    text = (header("Generated patrol graphs against the hand-made ones (tpuaf graph)")
            + f"Command: {command}. Pictures: `benchmarks/results/graphgen/<map>_hand.png`, "
            "`<map>_generated.png` (green: seen, red: reachable but unseen).\n\n"
            + table(rows, args.robots, args.duration))
    write("graphgen.md", text)
    (RESULTS / "graphgen.json").write_text(json.dumps(rows, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
