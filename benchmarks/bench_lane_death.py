"""A robot dies inside a one-robot aisle: do the survivors keep patrolling? (docs/LANES.md)

Lab, 4 TurtleBot3 Burgers, physics runtime, lanes one-way (the default for tpuaf and
tpuaf_plus), 900 s; one robot dies at a given time, wherever it is then (often inside an
aisle). Two modes: `blocked` (the survivors drop the edge the body lies on, and cut off a vertex
it stands next to: robot/lanes.py) and `freed` (the body's lane lock is only freed after the
teammate timeout, as before: robot/lanes.py BLOCK_LOST_BODIES off). Per strategy and mode,
medians over the runs (seeds x deaths) of: visits after the death, the worst idleness after it
over max(the floor at detection, the survivors' ideal) (the recovery ratio of `tpuaf run`,
1.00 = as good as the death allows), the same ratio over the vertices still reachable
(`ratio_reachable`: without those the body cuts off, which no reaction can visit), and the time
mean of I_ins.

    .venv/bin/python benchmarks/bench_lane_death.py [--seeds 5] [--deaths 1@150,2@300,0@200]
        [--duration 900] [--workers 2] [--out lane_death]

Writes benchmarks/results/lane_death.md and .json.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import RESULTS, header, write  # noqa: E402

MODES = ("blocked", "freed")


def one(case: tuple[str, str, int, str, float]) -> tuple[tuple, dict]:
    from tpuaf.robot import lanes
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    strategy, mode, seed, death, duration = case
    lanes.BLOCK_LOST_BODIES = mode == "blocked"
    died_at = float(death.split("@")[1])
    run = PhysicsRun(PhysicsConfig(map="lab", strategy=strategy, robots=4, duration_s=duration,
                                   seed=seed, robot="burger", fail=[death], lanes="one_way"))
    visits_at_death: list[int] = []

    def progress(t: float) -> None:
        if t >= died_at and not visits_at_death:
            visits_at_death.append(sum(a.machine.visits for a in run.agents))

    s = run.run(progress)
    (recovery,) = s["recovery"]
    ratio = recovery["worst_idleness_ratio_to_detection_reference"]
    return case, {"visits_after": s["visits"] - visits_at_death[0], "ratio": ratio,
                  # over the vertices still reachable (none closed: every vertex)
                  "ratio_reachable": recovery.get("worst_idleness_ratio_reachable", ratio),
                  "closed": s.get("lane_vertices_closed", []),
                  "ins": s["idleness_ins_mean_s"], "blocked": s.get("lane_edges_blocked", []),
                  "failures": s.get("goal_failures", 0)}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=5)
    p.add_argument("--deaths", default="1@150,2@300,0@200")
    p.add_argument("--duration", type=float, default=900.0)
    p.add_argument("--strategies", default="tpuaf,tpuaf_plus")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--out", default="lane_death")
    args = p.parse_args()
    strategies = args.strategies.split(",")
    deaths = args.deaths.split(",")
    cases = [(s, m, seed, d, args.duration) for s in strategies for m in MODES
             for seed in range(1, args.seeds + 1) for d in deaths]
    start = time.perf_counter()
    with ProcessPoolExecutor(args.workers) as pool:
        results = dict(pool.map(one, cases))
    wall = time.perf_counter() - start
    lines = [header("A robot dies in a one-robot aisle: lab, 4 Burgers, one-way lanes"),
             f"Command: `.venv/bin/python benchmarks/bench_lane_death.py --seeds {args.seeds} "
             f"--deaths {args.deaths} --duration {args.duration:g}`. {len(cases)} runs, "
             f"physics, {args.duration:g} s each; wall {wall:.0f} s with {args.workers} "
             "workers.", "",
             "blocked: the survivors drop the body's edge (and cut off a vertex it stands "
             "next to); freed: its lane lock is only freed after the teammate timeout. "
             "Medians over seeds x deaths; ratio: worst idleness after the death over "
             "max(floor at detection, survivors' ideal), 1.00 = as good as the death allows; "
             "ratio_reachable: the same over the vertices still reachable (without those the "
             "body cuts off: `lane_vertices_closed`, no reaction can visit them; docs/LANES.md).",
             "", "| strategy | mode | visits after the death | ratio | ratio_reachable | "
             "I_ins [s] | goal failures | runs with an edge blocked |",
             "|---|---|---|---|---|---|---|---|"]
    for s in strategies:
        for m in MODES:
            rows = [results[c] for c in cases if c[0] == s and c[1] == m]
            med = {k: statistics.median(r[k] for r in rows)
                   for k in ("visits_after", "ratio", "ratio_reachable", "ins", "failures")}
            blocked = sum(1 for r in rows if r["blocked"])
            lines.append(f"| {s} | {m} | {med['visits_after']:.0f} | {med['ratio']:.2f} | "
                         f"{med['ratio_reachable']:.2f} | {med['ins']:.1f} | "
                         f"{med['failures']:.0f} | {blocked} / {len(rows)} |")
    lines += ["", "Per run (visits after the death, ratio / ratio_reachable):", ""]
    for s in strategies:
        for d in deaths:
            cells = []
            for m in MODES:
                runs = [results[c] for c in cases if c[0] == s and c[1] == m and c[3] == d]
                cells.append(f"{m} " + ", ".join(f"{r['visits_after']} ({r['ratio']:.2f} / "
                                                 f"{r['ratio_reachable']:.2f})"
                                                 for r in runs))
            lines.append(f"- {s}, robot {d.replace('@', ' dies at ')} s: " + "; ".join(cells))
    write(f"{args.out}.md", "\n".join(lines) + "\n")
    (RESULTS / f"{args.out}.json").write_text(json.dumps(
        [{"case": list(c), **results[c]} for c in cases], indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
