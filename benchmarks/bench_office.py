"""A generated office as a new user would run it: the office of tests/test_doors.py (a 1.4 m
corridor, five rooms, doors 0.55-0.7 m wide), `tpuaf graph` for a Burger, then TPUAF and
tpuaf_plus with 4 Burgers in the graph runtime (the promise) and in physics (lanes auto), on
the graph of the generator as it is and as it was before doorways counted half and targets
kept a robot's width apart (maps/generate.py NARROW_GAIN_SHARE = 1, SPACING_ROBOT_WIDTHS = 0),
and in physics with the controller as it was before
its door rule (navigation/controller.py NARROW_COST_RAD = 100 rad: a heading with the wide
clearance always wins, the old rule exactly).

    .venv/bin/python benchmarks/bench_office.py [--duration 900] [--seeds 3]

Writes benchmarks/results/office.md and office.json.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT))
from common import header, write_report  # noqa: E402


def office_folder(tmp: Path, before: bool) -> Path:
    """The office's map folder from `tpuaf graph`, by the generator of before or of now."""
    import tpuaf.maps.generate as generate
    from tpuaf.cli import main

    from tests.map_folders import write_map_server
    from tests.test_doors import OFFICE

    source = write_map_server(tmp / "src", OFFICE, (14.0, 9.0), "office", origin=(-1.0, -2.0))
    kept = generate.NARROW_GAIN_SHARE, generate.SPACING_ROBOT_WIDTHS
    if before:
        generate.NARROW_GAIN_SHARE, generate.SPACING_ROBOT_WIDTHS = 1.0, 0.0
    try:
        folder = tmp / ("office_before" if before else "office")
        if main(["graph", str(source), "--robot", "burger", "--out", str(folder)]) != 0:
            raise SystemExit("tpuaf graph failed")
    finally:
        generate.NARROW_GAIN_SHARE, generate.SPACING_ROBOT_WIDTHS = kept
    return folder


def one(folder: Path, strategy: str, runtime: str, duration: float, seed: int,
        narrow_cost: float | None = None) -> dict:
    from tpuaf.maps import load_map
    from tpuaf.navigation.lanes import find_lanes
    from tpuaf.navigation.planner import PathPlanner
    from tpuaf.runtimes.config import PhysicsConfig, RunConfig

    pm = load_map(str(folder))
    cls = PhysicsConfig if runtime == "physics" else RunConfig
    config = cls(map="office", strategy=strategy, robots=4, duration_s=duration, seed=seed,
                 robot="burger")
    if runtime == "physics":
        from tpuaf.navigation import controller
        from tpuaf.runtimes.physics import PhysicsRun

        kept = controller.NARROW_COST_RAD
        controller.NARROW_COST_RAD = kept if narrow_cost is None else narrow_cost
        try:
            summary = PhysicsRun(config, pm).run()
        finally:
            controller.NARROW_COST_RAD = kept
    else:
        from tpuaf.runtimes.graph import make_run

        summary = make_run(config, pm).run()
    lanes = find_lanes(PathPlanner(pm, 0.105), pm)
    return {"strategy": strategy, "runtime": runtime, "vertices": pm.num_vertices,
            "narrow_vertices": len(lanes.narrow_vertices),
            "lane_edges": sum(len(lane.edges) for lane in lanes.lanes),
            "i_max_s": summary["idleness_max_s"], "i_ins_s": summary["idleness_ins_mean_s"],
            "worst_s": summary["worst_idleness_s"], "visits": summary["visits"],
            "min_visits": min(summary["visits_per_vertex"].values()),
            "lane_wait_s": summary.get("lane_wait_s", 0.0),
            "goal_failures": summary.get("goal_failures", 0)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=900.0)
    ap.add_argument("--seeds", type=int, default=3, help="seeds 1..SEEDS; medians")
    args = ap.parse_args()
    start = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        # (generator, controller, NARROW_COST_RAD or None: today's)
        cases = (("before", "before", 100.0), ("before", "now", None), ("now", "now", None))
        folders = {g: office_folder(Path(tmp), g == "before") for g in ("before", "now")}
        for graph, ctrl, cost in cases:
            for strategy in ("tpuaf", "tpuaf_plus"):
                for runtime in ("graph", "physics") if ctrl == "now" else ("physics",):
                    runs = [one(folders[graph], strategy, runtime, args.duration, seed, cost)
                            for seed in range(1, args.seeds + 1)]
                    row = {"graph": graph, "controller": ctrl if runtime == "physics" else "-",
                           **{k: statistics.median(r[k] for r in runs)
                              if isinstance(runs[0][k], float | int) else runs[0][k]
                              for k in runs[0]}, "seeds": runs}
                    print(json.dumps(row), file=sys.stderr, flush=True)
                    rows.append(row)
    lines = ["| generator | controller | strategy | runtime | vertices (in doorways) "
             "| lane edges | I_max [s] | I_ins [s] | worst idleness [s] "
             "| visits (fewest per vertex) | lane waits [s] | failed goals |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['graph']} | {r['controller']} | {r['strategy']} | {r['runtime']} "
                     f"| {r['vertices']} "
                     f"({r['narrow_vertices']}) | {r['lane_edges']} | {r['i_max_s']:.1f} | "
                     f"{r['i_ins_s']:.1f} | {r['worst_s']:.1f} | {r['visits']} "
                     f"({r['min_visits']}) | {r['lane_wait_s']:.1f} | {r['goal_failures']} |")
    wall = time.perf_counter() - start
    body = (header("A generated office, 4 Burgers: doorway vertices before and now")
            + f"\nCommand: `.venv/bin/python benchmarks/bench_office.py`. Medians over seeds "
            f"1-{args.seeds} per row (fewest visits per vertex: median of each run's fewest), "
            f"{args.duration:g} s, lanes auto; wall {wall:.0f} s.\n\n"
            "The office of `tests/test_doors.py` (map frame: corridor y 2.0-3.4 m). "
            "Generator `before`: NARROW_GAIN_SHARE = 1 (a vertex in a doorway counted like "
            "any other) and SPACING_ROBOT_WIDTHS = 0 (targets two work cells apart at "
            "least), `now`: 0.5 and 1. Controller (physics only) `before`: NARROW_COST_RAD = "
            "100 rad (a wide heading at any angle wins, the rule before the door rule), "
            "`now`: 0.5 rad.\n\n"
            + "\n".join(lines) + "\n")
    write_report("office", body, rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
