"""Passing another robot: early (navigation/controller.py `_pass_bias`) and keeping right
(navigation/navigator.py `keep_right`), over seeds: fast robots (1 m/s) jammed on 1r5, ctcv
and example at N = 8-12 (issue 32/35).

For each case and seed, the graph runtime (the plan, on the robot's travel times) and the
physics runtime three times: `without` either rule (`PASS_BIAS_RAD` = 0 and
`KEEP_RIGHT_SHARE` = 0: the navigator before both), `bias` (the passing rule only: before
keeping right) and `with` both (the navigator as it is). Figures per case, medians over the
seeds: driven visits ratio and I_max ratio (physics / graph, as bench_fidelity.py), world
contacts and failed goals (sums over the seeds).

    .venv/bin/python benchmarks/bench_passing.py                      # ~25 min on 2 cores
    .venv/bin/python benchmarks/bench_passing.py --cases 1r5:tpuaf:12 --seeds 1 2 --quick

Writes benchmarks/results/passing_seeds.md and .json.
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
from bench_fidelity import map_ref  # noqa: E402
from common import RESULTS, header, write  # noqa: E402

CASES = ("1r5:tpuaf:4", "1r5:tpuaf_plus:4", "1r5:tpuaf:8", "1r5:tpuaf:12", "ctcv:tpuaf:12",
         "ctcv:tpuaf_plus:8", "ctcv:tpuaf_plus:12", "example:tpuaf_plus:8",
         "ctcv:tpuaf:12:burger")
VARIANTS = ("without", "bias", "with")


def parse(case: str) -> dict:
    parts = case.split(":")
    if parts[0] == "builtin" and len(parts) > 1:
        parts = [f"builtin:{parts[1]}", *parts[2:]]
    if len(parts) not in (3, 4) or not parts[2].isdigit() or int(parts[2]) < 1:
        raise ValueError(f"a case is MAP:STRATEGY:N[:ROBOT], got {case!r}")
    return dict(map=parts[0], strategy=parts[1], robots=int(parts[2]),
                robot=parts[3] if len(parts) == 4 else "auto")


def one(job: tuple[str, str, int, float]) -> dict:
    """One case, seed and variant: the graph and physics runs' figures. Runs in a fresh
    process (the variant sets a module constant)."""
    variant, case, seed, duration = job
    from tpuaf.navigation import controller, navigator
    from tpuaf.runtimes.config import PhysicsConfig, RunConfig
    from tpuaf.runtimes.graph import make_run
    from tpuaf.runtimes.physics import PhysicsRun

    if variant == "without":
        controller.PASS_BIAS_RAD = 0.0
    if variant in ("without", "bias"):
        navigator.KEEP_RIGHT_SHARE = 0.0
    c = parse(case)
    common = dict(map=map_ref(c["map"]), strategy=c["strategy"], robots=c["robots"],
                  duration_s=duration, seed=seed, robot=c["robot"], lanes="auto")
    g = make_run(RunConfig(**common)).run()
    p = PhysicsRun(PhysicsConfig(**common)).run()
    return dict(variant=variant, case=case, seed=seed, graph_visits=g["visits"],
                visits=p["visits"], graph_imax_s=g["idleness_max_s"],
                imax_s=p["idleness_max_s"], contacts=p["collisions"],
                goal_failures=p["goal_failures"])


def table(results: list[dict], cases, seeds) -> str:
    rows = ["| case | seeds | visits ratio without / bias / with | I_max ratio without / bias / "
            "with | contacts without / bias / with | failed goals without / bias / with |",
            "|---|---|---|---|---|---|"]
    for case in cases:
        figs = {}
        for v in VARIANTS:
            rs = [r for r in results if r["case"] == case and r["variant"] == v]
            figs[v] = dict(
                visits=statistics.median(r["visits"] / r["graph_visits"] for r in rs),
                imax=statistics.median(r["imax_s"] / r["graph_imax_s"] for r in rs),
                contacts=sum(r["contacts"] for r in rs),
                fails=sum(r["goal_failures"] for r in rs))
        a, m, b = figs["without"], figs["bias"], figs["with"]
        rows.append(f"| {case} | {len(seeds)} | {a['visits']:.2f} / {m['visits']:.2f} / "
                    f"**{b['visits']:.2f}** | {a['imax']:.2f} / {m['imax']:.2f} / "
                    f"**{b['imax']:.2f}** | {a['contacts']} / {m['contacts']} / {b['contacts']} | "
                    f"{a['fails']} / {m['fails']} / {b['fails']} |")
    return "\n".join(rows) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=list(CASES), metavar="MAP:STRATEGY:N[:ROBOT]")
    ap.add_argument("--seeds", nargs="+", type=int, default=[1, 2, 3])
    ap.add_argument("--duration", type=float, default=900.0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--quick", action="store_true", help="print, do not write the results")
    args = ap.parse_args()
    try:
        for case in args.cases:
            parse(case)
    except ValueError as err:
        ap.error(str(err))
    jobs = [(v, c, s, args.duration) for c in args.cases for s in args.seeds for v in VARIANTS]
    start = time.perf_counter()
    results = []
    # one process per run: the variant is a module constant of the controller
    with ProcessPoolExecutor(args.workers, max_tasks_per_child=1) as pool:
        for r in pool.map(one, jobs):
            results.append(r)
            print(f"{r['case']} seed {r['seed']} {r['variant']}: visits "
                  f"{r['visits'] / r['graph_visits']:.2f}x, I_max "
                  f"{r['imax_s'] / r['graph_imax_s']:.2f}x", file=sys.stderr, flush=True)
    wall = time.perf_counter() - start
    cmd = " ".join(sys.argv[1:])
    text = header("Passing another robot (early, keeping right), with and without, over seeds") + (
        f"Cases {', '.join(args.cases)}; seeds {', '.join(map(str, args.seeds))}; "
        f"{args.duration:g} s each; wall {wall:.0f} s with {args.workers} workers. Command: "
        f"`.venv/bin/python benchmarks/bench_passing.py{' ' + cmd if cmd else ''}`.\n\n"
        "Ratios are physics / graph runtime on the same robot model (bench_fidelity.py), "
        "medians over the seeds; contacts (world contact steps) and failed goals are sums. "
        "`without`: `PASS_BIAS_RAD` = 0 and `KEEP_RIGHT_SHARE` = 0, the navigator before both "
        "rules; `bias`: the passing rule only (docs/RUNTIMES.md, \"Passing another robot "
        "early\"); `with`: both, legs kept right too (\"Keeping right\"). Targets (issue 32): "
        "visits >= 0.9, I_max <= 1.2.\n\n") + table(results, args.cases, args.seeds)
    if args.quick:
        print(text)
        return 0
    write("passing_seeds.md", text)
    (RESULTS / "passing_seeds.json").write_text(json.dumps(
        dict(argv=sys.argv[1:], seeds=args.seeds, duration=args.duration, wall_s=wall,
             results=results), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
