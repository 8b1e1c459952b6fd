"""Corridors one Burger wide that meet at a tight junction (docs/LANES.md): the T of corridors
between three rooms and the star of three dead ends of tests/test_lanes.py, with TPUAF and
tpuaf_plus, in physics with the lane rule of now (the corridors through a tight junction are
one lane), of before (each corridor its own lane, the junction their waiting spot:
navigation/lanes.py `tight_spots` finding none, the old rule exactly) and with lanes off; the
graph runtime (the promise, no bodies) beside them.

    .venv/bin/python benchmarks/bench_tight_junctions.py [--duration 900] [--seeds 3]

Writes benchmarks/results/tight_junctions.md and tight_junctions.json.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT))
from common import header, write_report  # noqa: E402

MAPS = {"tee": (2, 3, 4), "star": (2, 3)}  # map -> team sizes
VARIANTS = ("now", "before", "off", "graph")


def one(case: tuple) -> dict:
    """One run: (map folder, map name, strategy, N, variant, duration [s], seed)."""
    import tpuaf.navigation.lanes as lanes
    from tpuaf.maps import load_map
    from tpuaf.runtimes.config import PhysicsConfig, RunConfig
    from tpuaf.runtimes.graph import make_run
    from tpuaf.runtimes.physics import PhysicsRun

    folder, name, strategy, n, variant, duration, seed = case
    pm = load_map(folder)
    kept = lanes.tight_spots
    if variant == "before":
        lanes.tight_spots = lambda *_: frozenset()
    try:
        if variant == "graph":
            summary = make_run(RunConfig(map=name, strategy=strategy, robots=n, seed=seed,
                                         duration_s=duration, robot="burger"), pm).run()
            late = [0]
        else:
            run = PhysicsRun(PhysicsConfig(map=name, strategy=strategy, robots=n, seed=seed,
                                           duration_s=duration, robot="burger",
                                           lanes="off" if variant == "off" else "auto"), pm)
            marks: dict[str, list[int]] = {}

            def mark(t: float) -> None:  # each robot's visits at 3/4 of the run
                if t >= 0.75 * duration and "q" not in marks:
                    marks["q"] = [a.machine.visits for a in run.agents]

            summary = run.run(mark)
            late = [a.machine.visits - q for a, q in zip(run.agents, marks["q"], strict=True)]
    finally:
        lanes.tight_spots = kept
    return {"map": name, "strategy": strategy, "N": n, "variant": variant, "seed": seed,
            "i_max_s": summary["idleness_max_s"], "visits": summary["visits"],
            "unvisited": summary["unvisited_vertices"], "last_quarter_min": min(late),
            "lane_wait_s": summary.get("lane_wait_s", 0.0),
            "collisions": summary.get("collisions", 0),
            "goal_failures": summary.get("goal_failures", 0)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=900.0)
    ap.add_argument("--seeds", type=int, default=3, help="seeds 1..SEEDS; medians")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    from tests.test_lanes import star_map, tee_map

    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        folders = {"tee": str(tee_map(Path(tmp) / "tee")),
                   "star": str(star_map(Path(tmp) / "star"))}
        cases = [(folders[m], m, s, n, v, args.duration, seed)
                 for m, teams in MAPS.items() for n in teams for s in ("tpuaf", "tpuaf_plus")
                 for v in VARIANTS for seed in range(1, args.seeds + 1)]
        with ProcessPoolExecutor(args.workers) as pool:
            runs = list(pool.map(one, cases))
    groups: dict[tuple, list[dict]] = {}
    for r in runs:
        groups.setdefault((r["map"], r["N"], r["strategy"], r["variant"]), []).append(r)
    lines = ["| map | N | strategy | lanes | I_max [s] | visits | unvisited | last-quarter "
             "visits (fewest) | lane waits [s] | contacts | failed goals |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for (m, n, s, v), rs in groups.items():
        med = {k: statistics.median(r[k] for r in rs) for k in (
            "i_max_s", "visits", "lane_wait_s", "collisions", "goal_failures")}
        label = "graph runtime" if v == "graph" else v
        quarter = "-" if v == "graph" else str(min(r["last_quarter_min"] for r in rs))
        lines.append(f"| {m} | {n} | {s} | {label} | {med['i_max_s']:.1f} | "
                     f"{med['visits']:.0f} | {max(r['unvisited'] for r in rs)} | {quarter} | "
                     f"{med['lane_wait_s']:.0f} | {med['collisions']:.0f} | "
                     f"{med['goal_failures']:.0f} |")
    wall = time.perf_counter() - start
    body = (header("Tight junctions: corridors one Burger wide meeting where no robot can wait")
            + f"\nCommand: `.venv/bin/python benchmarks/bench_tight_junctions.py`. Medians over "
            f"seeds 1-{args.seeds} per row ({args.duration:g} s each; unvisited vertices and "
            "the fewest last-quarter visits of one robot: the worst seed); wall "
            f"{wall:.0f} s with {args.workers} workers.\n\n"
            "Maps of `tests/test_lanes.py`: `tee`, corridors 0.45 m wide from a left room to a "
            "right one with a stem down to a third (vertices 0, 4, 6 in the rooms, 2 the "
            "junction); `star`, three dead-end corridors 0.45 m wide from one junction, no room "
            "anywhere. Lanes `now`: the corridors through the tight junction are one lane "
            "(tee: waiting spots in the rooms; star: none); `before`: each corridor its own "
            "lane, the junction their waiting spot; `off`: no lanes (give-way only). The graph "
            "runtime's robots are points (no contacts, no lane waits).\n\n"
            + "\n".join(lines) + "\n")
    write_report("tight_junctions", body, runs)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
