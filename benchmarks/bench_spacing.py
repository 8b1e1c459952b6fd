"""tpuaf_plus's closed-loop spacing (issue 32, part 4): quality before / after.

1. Graph runtime: tpuaf_plus I_max against the best-known tours (patrol_bounds.csv) on every
   shared map and grid at N = 2, 4, 8, 12 (3600 s, seed 1: tpuaf_plus draws no random number),
   in all and in the steady state (the longest visit gap starting after STEADY_S).
2. Physics runtime: tpuaf_plus I_max over the graph runtime's (same map, N and robot, the graph
   runtime on the robot's timed map) on a few cases (900 s, seed 1), and the steady state: the
   longest visit gap that starts after STEADY_S.
3. Convoys (physics): N robots leave N adjacent vertices of a ring together (the plan's start
   schedule dropped, as tests/test_spacing_physics.py): the longest visit gap starting in each
   lap, in laps.

Each side is measured by the code it imports, so "before" runs on a checkout of the old code
(BASE: `git worktree add --detach BASE <commit>`, cmake configured as setup.sh does with
CATKIN_DEVEL_PREFIX=BASE/devel, `cmake --build BASE/build --target _core`):

    PYTHONPATH=BASE/devel/lib/python3/dist-packages \
        .venv/bin/python benchmarks/bench_spacing.py --label before           # old code
    .venv/bin/python benchmarks/bench_spacing.py --label after                # this code
    .venv/bin/python benchmarks/bench_spacing.py --report                     # spacing.md

`--label L` writes benchmarks/results/spacing_L.json; `--report` joins before and after.
"""

from __future__ import annotations

import argparse
import csv
import json
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import RESULTS, header, visit_rule_reference, write  # noqa: E402

SHARED = Path(__file__).resolve().parents[2] / "shared"
MAPS = SHARED / "maps" / "patrolling_sim"
BOUNDS = SHARED / "reference" / "patrol_bounds.csv"
GRAPH_MAPS = ("grid", "cumberland", "example", "DIAG_labs", "1r5", "ctcv")
GRAPH_N = (2, 4, 8, 12)
# (map, N): the built-in grid and lab, and patrolling_sim's example
PHYSICS_CASES = (("grid", 4), ("grid", 8), ("lab", 4), ("lab", 8), ("example", 4))
STEADY_S = 300.0  # [s] the physics steady state starts here
CONVOYS = ((8, 2), (12, 4), (16, 6))  # (ring vertices, robots)
CONVOY_LAPS = 5


def gaps_from(visits, start_s: float, end_s: float) -> float:
    """[s] the longest gap between two visits of a vertex that starts in [start_s, end_s)."""
    times: dict = {}
    for t, _, v in visits:
        times.setdefault(v, []).append(t)
    return max((b - a for ts in times.values() for a, b in zip(ts, ts[1:], strict=False)
                if start_s <= a < end_s), default=0.0)


def map_ref(name: str) -> str:
    return name if name in ("grid", "lab") else str(MAPS / name)


def best_known() -> dict:
    out = {}
    for row in csv.DictReader(BOUNDS.open()):
        out[(row["map"], int(row["N"]))] = float(row["best_known_worst_idleness_s"])
    return out


def graph_case(case: tuple) -> tuple:
    from tpuaf.runtimes.config import RunConfig
    from tpuaf.runtimes.graph import GraphRun

    name, n = case
    config = RunConfig(map=map_ref(name), strategy="tpuaf_plus", robots=n, duration_s=3600.0,
                       seed=1)
    run = GraphRun(config)
    i_max = run.run()["idleness_max_s"]
    return ("graph", name, n), {"i_max": i_max,
                                "steady": gaps_from(run.recorder.visits, STEADY_S, 3600.0)}


def physics_case(case: tuple) -> tuple:
    from tpuaf.runtimes.config import PhysicsConfig, RunConfig
    from tpuaf.runtimes.graph import GraphRun
    from tpuaf.runtimes.physics import PhysicsRun

    name, n = case
    common = dict(map=map_ref(name), strategy="tpuaf_plus", robots=n, duration_s=900.0, seed=1)
    graph = GraphRun(RunConfig(**common, robot="auto")).run()["idleness_max_s"]
    run = PhysicsRun(PhysicsConfig(**common))
    physics = run.run()["idleness_max_s"]
    steady = gaps_from(run.recorder.visits, STEADY_S, 900.0)
    return ("physics", name, n), {"graph": graph, "physics": physics, "steady": steady}


def convoy_case(case: tuple) -> tuple:
    from dataclasses import replace

    import numpy as np
    import tpuaf.policies.tpuaf_plus as tpuaf_plus
    from tpuaf.maps.model import MapSettings, PatrolMap
    from tpuaf.runtimes.config import PhysicsConfig, run_robot, travel_map
    from tpuaf.runtimes.physics import PhysicsRun

    n_vertices, n = case
    make_plan = tpuaf_plus.make_plan
    tpuaf_plus.make_plan = lambda *a, **k: replace(make_plan(*a, **k), schedule={})
    a = 2 * np.pi * np.arange(n_vertices) / n_vertices
    radius = 4.0 / (2 * np.sin(np.pi / n_vertices))  # 4 m edges
    pm = PatrolMap("ring", list(range(n_vertices)), np.c_[np.cos(a), np.sin(a)] * radius,
                   [(i, (i + 1) % n_vertices, float("nan")) for i in range(n_vertices)],
                   np.ones(n_vertices), np.ones(n_vertices),
                   MapSettings(initial_vertices={n: list(range(n))}))
    config = PhysicsConfig(map="ring", strategy="tpuaf_plus", robots=n, seed=1)
    travel = travel_map(config, pm, run_robot(config, pm))
    lap = sum(c for _, _, c in travel.graph.edges) / travel.settings.nominal_speed
    run = PhysicsRun(replace(config, duration_s=CONVOY_LAPS * lap), patrol_map=pm)
    run.run()
    tpuaf_plus.make_plan = make_plan
    laps = [gaps_from(run.recorder.visits, k * lap, (k + 1) * lap) / lap
            for k in range(CONVOY_LAPS - 1)]
    return ("convoy", n_vertices, n), laps


def measure(label: str, workers: int) -> None:
    jobs = [(graph_case, (m, n)) for m in GRAPH_MAPS for n in GRAPH_N]
    jobs += [(physics_case, c) for c in PHYSICS_CASES]
    jobs += [(convoy_case, c) for c in CONVOYS]
    out: dict = {}
    t0 = time.perf_counter()
    with ProcessPoolExecutor(workers) as pool:
        futures = [pool.submit(fn, case) for fn, case in jobs]
        for f in futures:
            key, value = f.result()
            out["/".join(map(str, key))] = value
            print(key, value, file=sys.stderr, flush=True)
    out["_wall_s"] = time.perf_counter() - t0
    import subprocess

    import tpuaf

    src = Path(tpuaf.__file__).resolve().parent
    out["_commit"] = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=src,
                                    capture_output=True, text=True).stdout.strip()
    path = RESULTS / f"spacing_{label}.json"
    path.write_text(json.dumps(out, indent=1, sort_keys=True) + "\n")
    print(f"written to {path}")


def report(before_label: str = "before", after_label: str = "after",
           out: str = "spacing.md") -> None:
    before = json.loads((RESULTS / f"spacing_{before_label}.json").read_text())
    after = json.loads((RESULTS / f"spacing_{after_label}.json").read_text())
    bounds = best_known()
    title = ("tpuaf_plus closed-loop spacing (issue 32, part 4)" if out == "spacing.md"
             else f"tpuaf_plus quality, {before_label} / {after_label}")
    lines = [header(title)]
    lines.append(f"Command: `benchmarks/bench_spacing.py --label {before_label}` on the old code "
                 f"(docstring), `--label {after_label}` on this, then `--report --compare "
                 f"{before_label} {after_label} --out {out}`. "
                 f"Before: commit {before.get('_commit', '?')}, after: commit "
                 f"{after.get('_commit', '?')}; wall {before['_wall_s']:.0f} s and "
                 f"{after['_wall_s']:.0f} s, one worker each, side by side.\n")
    lines.append("## Graph runtime: tpuaf_plus I_max / best-known tour (3600 s, seed 1)\n")
    lines.append(f"I_max over the run, and the steady state: the longest visit gap starting "
                 f"after {STEADY_S:.0f} s.\n")
    lines.append("| map | N | best-known [s] | before I_max [s] (ratio) | after I_max [s] (ratio) "
                 "| before steady (ratio) | after steady (ratio) |")
    lines.append("|---|---|---|---|---|---|---|")
    ratios: dict = {}
    for m in GRAPH_MAPS:
        for n in GRAPH_N:
            key, bound = f"graph/{m}/{n}", bounds.get((m, n))
            cells = []
            for what in ("i_max", "steady"):
                for label, data in (("before", before), ("after", after)):
                    value = data[key][what]
                    if value is None:  # no vertex visited twice (parked robots)
                        cells.append("-")
                    elif bound:
                        ratios.setdefault((label, what), []).append(value / bound)
                        cells.append(f"{value:.1f} ({value / bound:.2f}x)")
                    else:
                        cells.append(f"{value:.1f}")
            lines.append(f"| {m} | {n} | {bound if bound is not None else '-'} | "
                         + " | ".join(cells) + " |")
    lines.append("")
    for (label, what), r in ratios.items():
        lines.append(f"- {label}, {what}: median ratio {statistics.median(r):.3f}, range "
                     f"{min(r):.2f}-{max(r):.2f}x over {len(r)} cases with a bound > 0.")
    # patrol_bounds.csv's best-known tours park robots on vertices where that pays (1r5, ctcv
    # at N >= 8): standing makes no visit, so the fair line is the reference under the rule
    from tpuaf.maps import load_map

    fair = []
    for m in GRAPH_MAPS:
        pm = load_map(map_ref(m))
        for n in GRAPH_N:
            value = after[f"graph/{m}/{n}"]["steady"]
            if value is not None:
                fair.append((value / visit_rule_reference(pm, n), m, n))
    worst = max(fair)
    lines.append(f"- {after_label}, steady / the reference tour under the visit rule (a part of "
                 f"one vertex driven out and back; `common.visit_rule_reference`): median "
                 f"{statistics.median(f[0] for f in fair):.3f}, range "
                 f"{min(fair)[0]:.2f}-{worst[0]:.2f}x over {len(fair)} cases (highest: "
                 f"{worst[1]} N = {worst[2]}).")
    lines.append("\n## Physics runtime: tpuaf_plus I_max, physics / graph runtime (900 s, seed 1)\n")
    lines.append("Robot `auto` (the map's preset); the graph runtime on the robot's timed map.\n")
    lines.append("| map | N | graph I_max [s] | before physics [s] (ratio) | "
                 f"after physics [s] (ratio) | before / after: worst gap from {STEADY_S:.0f} s |")
    lines.append("|---|---|---|---|---|---|")
    phys: dict = {"before": [], "after": []}
    for m, n in PHYSICS_CASES:
        key = f"physics/{m}/{n}"
        cells = []
        for label, data in (("before", before), ("after", after)):
            g, p = data[key]["graph"], data[key]["physics"]
            phys[label].append(p / g)
            cells.append(f"{p:.1f} ({p / g:.2f}x)")
        steady = " / ".join(f"{d[key]['steady']:.1f}" if "steady" in d[key] else "-"
                            for d in (before, after))
        lines.append(f"| {m} | {n} | {after[key]['graph']:.1f} | " + " | ".join(cells)
                     + f" | {steady} |")
    for label in ("before", "after"):
        lines.append(f"\n{label}: median physics / graph {statistics.median(phys[label]):.2f}x.")
    lines.append("\n## Convoys in physics: the longest visit gap starting in each lap [laps]\n")
    lines.append("N robots leave N adjacent vertices of a ring of 4 m edges together (no start "
                 "schedule). Even spacing: 1 / N lap.\n")
    lines.append("| ring vertices | N | even | before, laps 1-4 | after, laps 1-4 |")
    lines.append("|---|---|---|---|---|")
    for v, n in CONVOYS:
        key = f"convoy/{v}/{n}"
        cells = [", ".join(f"{x:.2f}" for x in d[key]) if key in d else "-"
                 for d in (before, after)]
        lines.append(f"| {v} | {n} | {1 / n:.2f} | " + " | ".join(cells) + " |")
    write(out, "\n".join(lines) + "\n")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--label", help="measure with this interpreter's code: spacing_LABEL.json")
    ap.add_argument("--report", action="store_true", help="write spacing.md from both labels")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--compare", nargs=2, metavar=("BEFORE", "AFTER"), default=("before", "after"),
                    help="the labels --report joins (default: before after)")
    ap.add_argument("--out", default="spacing.md", help="the report's file in results/")
    a = ap.parse_args()
    if a.label:
        measure(a.label, a.workers)
    if a.report:
        report(*a.compare, a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
