"""Physical fidelity: the physics runtime against the graph runtime (issue 18).

Same map, strategy, team size and seed: visits, I_max (the longest interval between two visits
of a vertex) and the worst wait after the first lap (the longest a vertex waits after its first
visit, the end of the run included; a vertex never visited waits the whole run). The graph
runtime runs twice: on the map's declared edge lengths and on the planned path lengths of the
robot's footprint (`--travel planned`), the fair reference where a declared length is
physically impossible (an edge through a wall, or shorter than the straight line).

    .venv/bin/python benchmarks/bench_fidelity.py                 # every map, N = 4, 8, 12
    .venv/bin/python benchmarks/bench_fidelity.py --maps grid --robots 4 --duration 300 --quick
    .venv/bin/python benchmarks/bench_fidelity.py --case lab:tpuaf:4 --case 1r5:tpuaf:8:auto \
        --out fidelity_jams                                       # chosen cases only

Writes benchmarks/results/fidelity.md and fidelity.json (`--out NAME`: NAME.md, NAME.json).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import RESULTS, header, write  # noqa: E402

SHARED = Path(__file__).resolve().parents[2] / "shared" / "maps" / "patrolling_sim"
SHARED_MAPS = ("1r5", "DIAG_labs", "ctcv", "cumberland", "example", "grid")
# Targets (issue 18): visits >= 0.9, I_max <= 1.2x, worst wait after the first lap <= 2x.
VISITS_MIN, IMAX_MAX, WAIT_MAX = 0.9, 1.2, 2.0


def map_ref(name: str) -> str:
    return str(SHARED / name) if name in SHARED_MAPS else name


def worst_wait_after_first_visit(recorder, end_s: float, n_vertices: int) -> float:
    """[s] the longest a vertex waited after its first visit (end of the run included); the
    whole run for a vertex never visited."""
    times: dict[int, list[float]] = {v: [] for v in range(n_vertices)}
    for t, _, v in recorder.visits:
        times[v].append(t)
    worst = 0.0
    for v in range(n_vertices):
        ts = sorted(times[v])
        if not ts:
            return end_s
        gaps = [b - a for a, b in zip(ts, ts[1:], strict=False)] + [end_s - ts[-1]]
        worst = max(worst, max(gaps))
    return worst


def one(case: dict) -> dict:
    from dataclasses import replace

    from tpuaf.maps import load_map
    from tpuaf.runtimes.config import PhysicsConfig, choose_robot
    from tpuaf.runtimes.graph import make_run
    from tpuaf.runtimes.physics import PhysicsRun

    pm = load_map(map_ref(case["map"]))
    n = pm.num_vertices
    # The graph runtime drives at the robot's speed (a Burger is capped at 0.22 m/s).
    speed = choose_robot(case["robot"], pm.settings).speed_mps
    graph_map = replace(pm, settings=replace(pm.settings, nominal_speed=speed))
    common = dict(map=map_ref(case["map"]), strategy=case["strategy"], robots=case["robots"],
                  duration_s=case["duration"], seed=case["seed"])
    out = dict(case)
    for label, travel in (("graph", "declared"), ("graph_planned", "planned")):
        cfg = PhysicsConfig(**common, travel=travel, robot=case["robot"])
        from tpuaf.runtimes.config import RunConfig

        base = RunConfig(**{k: getattr(cfg, k) for k in RunConfig.__dataclass_fields__})
        try:
            run = make_run(base, graph_map)
            s = run.run()
        except Exception as err:  # a map whose edges cannot be driven: say so in the table
            out[label] = {"error": str(err)}
            continue
        out[label] = {"visits": s["visits"], "imax_s": s["idleness_max_s"],
                      "wait_s": worst_wait_after_first_visit(run.recorder, case["duration"], n)}
    cpu0 = time.process_time()
    run = PhysicsRun(PhysicsConfig(**common, robot=case["robot"]), pm)
    s = run.run()
    cpu = time.process_time() - cpu0
    out["physics"] = {"visits": s["visits"], "imax_s": s["idleness_max_s"],
                      "wait_s": worst_wait_after_first_visit(run.recorder, case["duration"], n),
                      "collisions": s["collisions"], "goal_failures": s["goal_failures"],
                      "replans": s.get("replans", 0), "cpu_s": cpu,
                      "sim_per_cpu": case["duration"] / cpu if cpu > 0 else float("inf")}
    return out


def ratio(a: float, b: float) -> float:
    return a / b if b else float("inf")


def verdict(phys: dict, ref: dict) -> tuple[float, float, float, bool]:
    v = ratio(phys["visits"], ref["visits"])
    i = ratio(phys["imax_s"], ref["imax_s"])
    w = ratio(phys["wait_s"], ref["wait_s"])
    return v, i, w, (v >= VISITS_MIN and i <= IMAX_MAX and w <= WAIT_MAX)


def table(results: list[dict]) -> str:
    rows = ["| map | robot | strategy | N | graph visits (declared / planned) | physics visits | "
            "visits ratio | I_max ratio | wait ratio | met | collisions | failures | sim s / CPU s |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    met = total = 0
    for r in results:
        ph = r["physics"]
        ref_key = "graph_planned" if "error" not in r["graph_planned"] else "graph"
        ref = r[ref_key]
        if "error" in ref:
            rows.append(f"| {r['map']} | {r['robot']} | {r['strategy']} | {r['robots']} | "
                        f"{ref['error'][:60]} | {ph['visits']} | - | - | - | - | - | - | - |")
            continue
        v, i, w, ok = verdict(ph, ref)
        total += 1
        met += ok
        decl = r["graph"].get("visits", "-")
        rows.append(
            f"| {r['map']} | {r['robot']} | {r['strategy']} | {r['robots']} | {decl} / "
            f"{r['graph_planned'].get('visits', '-')} | {ph['visits']} | {v:.2f} | {i:.2f} | "
            f"{w:.2f} | {'yes' if ok else '**no**'} | {ph['collisions']} | "
            f"{ph['goal_failures']} | {ph['sim_per_cpu']:.0f}x |")
    summary = (f"\nTargets met (visits >= {VISITS_MIN}, I_max <= {IMAX_MAX}x, worst wait after "
               f"the first lap <= {WAIT_MAX}x, against the graph runtime on planned lengths): "
               f"**{met} of {total}** cases.\n")
    return "\n".join(rows) + "\n" + summary


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", nargs="+", default=[*SHARED_MAPS, "lab"])
    ap.add_argument("--robots", nargs="+", type=int, default=[4, 8, 12])
    ap.add_argument("--strategies", nargs="+", default=["tpuaf", "tpuaf_plus"])
    ap.add_argument("--robot-models", nargs="+", default=["auto", "burger"])
    ap.add_argument("--duration", type=float, default=900.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--case", action="append", default=[], metavar="MAP:STRATEGY:N[:ROBOT]",
                    help="one case (repeatable; robot default auto); replaces the cross "
                         "product of --maps, --robots, --strategies, --robot-models")
    ap.add_argument("--out", default="fidelity",
                    help="name of the results files in benchmarks/results (default fidelity)")
    ap.add_argument("--quick", action="store_true", help="do not write the results files")
    args = ap.parse_args()
    if not args.out.replace("_", "").replace("-", "").isalnum():
        ap.error(f"--out must be a plain file name, got {args.out!r}")
    if args.case:
        cases = []
        for text in args.case:
            parts = text.split(":")
            if len(parts) not in (3, 4) or not parts[2].isdigit() or int(parts[2]) < 1:
                ap.error(f"--case wants MAP:STRATEGY:N[:ROBOT] with N >= 1, got {text!r}")
            cases.append(dict(map=parts[0], robots=int(parts[2]), strategy=parts[1],
                              robot=parts[3] if len(parts) == 4 else "auto",
                              duration=args.duration, seed=args.seed))
    else:
        cases = [dict(map=m, robots=n, strategy=s, robot=rb, duration=args.duration,
                      seed=args.seed)
                 for m in args.maps for rb in args.robot_models for s in args.strategies
                 for n in args.robots]
    from tpuaf.errors import TpuafError
    from tpuaf.maps import load_map
    from tpuaf.policies import REGISTRY

    for name in sorted({c["strategy"] for c in cases}):
        if name not in REGISTRY.names():
            ap.error(f"unknown strategy {name!r}")
    from tpuaf.runtimes.config import choose_robot

    for name in sorted({c["map"] for c in cases}):
        try:
            settings = load_map(map_ref(name)).settings
            for robot in sorted({c["robot"] for c in cases if c["map"] == name}):
                choose_robot(robot, settings)
        except (TpuafError, OSError, ValueError) as err:
            ap.error(f"map {name!r}: {err}")
    start = time.perf_counter()
    results = []
    with ProcessPoolExecutor(args.workers) as pool:
        for k, r in enumerate(pool.map(one, cases), 1):
            results.append(r)
            ph = r["physics"]
            print(f"[{k}/{len(cases)}] {r['map']} {r['robot']} {r['strategy']} N={r['robots']}: "
                  f"graph {r['graph'].get('visits')} / planned {r['graph_planned'].get('visits')}"
                  f" / physics {ph['visits']}", file=sys.stderr, flush=True)
    wall = time.perf_counter() - start
    load = os.getloadavg()
    text = header("Physical fidelity: physics runtime against graph runtime")
    text += (f"{len(cases)} cases, {args.duration:g} s each, seed {args.seed}; wall {wall:.0f} s "
             f"with {args.workers} workers; load average at the end {load[0]:.1f}.\n"
             "Ratios are physics / graph runtime on planned path lengths (declared lengths "
             "where planning fails), the graph runtime driving at the robot's speed. Robot "
             "`auto` is the map's preset (as `tpuaf fleet`), `burger` a TurtleBot3 Burger "
             "(0.22 m/s, or the map's speed if slower). Command: `.venv/bin/python "
             f"benchmarks/bench_fidelity.py{' ' + ' '.join(sys.argv[1:]) if sys.argv[1:] else ''}"
             "`.\n\n")
    text += table(results)
    if not args.quick:
        write(f"{args.out}.md", text)
        (RESULTS / f"{args.out}.json").write_text(json.dumps(results, indent=1))
    else:
        print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
