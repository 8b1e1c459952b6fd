"""Physical fidelity, like for like: the physics runtime against the graph runtime on the same
robot's travel times (issue 32, part 5).

Each case runs one map, strategy, robot model and team size twice, 900 s, seed 1:
- the graph runtime with `--robot` (the plan at the robot's speed, each edge timed by the
  travel-time model: navigation/travel_time.py), the promise;
- the physics runtime with the same robot model, what a building gets.
Both count visits by the one visit rule (docs/RUNTIMES.md): an arrival driven to within the
visit radius; standing or dwelling on a vertex is no visit.

Figures per case: I_max ratio (physics / graph), worst wait after the first visit ratio, driven
visits ratio, the share of robot time standing still in physics (moved under 5 cm in a 1 s
window) and the graph runtime's dwell share, the travel-time model's error on the patrol's
own traversals (departure to visit, as the robots learn them from the team messages; median
over edges driven at least 3 times of |model - measured median| / measured median), and the share of edges whose planned path has a stretch one robot wide
(two robots cannot pass: clearance < 2 r + safety margin). Each case that misses a target gets a
cause from those figures (rules in `cause`).

    .venv/bin/python benchmarks/bench_fidelity.py                  # every case, ~25 min
    .venv/bin/python benchmarks/bench_fidelity.py --maps builtin:grid --robots 4 --quick
    .venv/bin/python benchmarks/bench_fidelity.py --case builtin:lab:tpuaf_plus:4:burger \
        --out fidelity_lab                                         # chosen cases only

Writes benchmarks/results/fidelity.md and fidelity.json (`--out NAME`: NAME.md, NAME.json).
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import RESULTS, header, write  # noqa: E402

SHARED = Path(__file__).resolve().parents[2] / "shared" / "maps" / "patrolling_sim"
SHARED_MAPS = ("1r5", "DIAG_labs", "ctcv", "cumberland", "example", "grid")
BUILTIN_MAPS = ("builtin:grid", "builtin:lab")
# Targets (issue 32): I_max <= 1.2x and worst wait <= 1.5x where aisles let robots pass,
# driven visits >= 0.9x, travel-time model within 10 % on the median edge.
IMAX_MAX, WAIT_MAX, VISITS_MIN, MODEL_MAX = 1.2, 1.5, 0.9, 0.10
STAND_WINDOW_S, STAND_MOVE_M = 1.0, 0.05  # standing: moved under 5 cm in a 1 s window
MIN_TRAVERSALS = 3  # an edge's measured median needs this many traversals
STEADY_FROM_S = 300.0  # [s] the steady state: intervals that begin after the first 300 s
SEEDS = 5  # a case missed by online choices alone is also run on seeds 1..SEEDS


def map_ref(name: str) -> str:
    if name.startswith("builtin:"):
        return name.split(":", 1)[1]
    return str(SHARED / name) if name in SHARED_MAPS else name


def worst_wait_after_first_visit(visits, end_s: float, n_vertices: int) -> float:
    """[s] the longest a vertex waited after its first visit (end of the run included); the
    whole run for a vertex never visited."""
    times: dict[int, list[float]] = {v: [] for v in range(n_vertices)}
    for t, _, v in visits:
        times[v].append(t)
    worst = 0.0
    for ts in times.values():
        if not ts:
            return end_s
        ts.sort()
        worst = max(worst, max(b - a for a, b in zip(ts, [*ts[1:], end_s], strict=True)))
    return worst


def model_error(measured: dict, modelled: dict) -> tuple[float, int]:
    """(median over edges driven >= MIN_TRAVERSALS times of |model - median| / median, edges)."""
    errors = [abs(modelled[e] - statistics.median(ts)) / statistics.median(ts)
              for e, ts in measured.items() if len(ts) >= MIN_TRAVERSALS and e in modelled]
    return (statistics.median(errors) if errors else math.nan), len(errors)


def one_lane_share(planner, robot_radius_m: float, margin_m: float, edges) -> float:
    """Share of edges whose planned path has a point where two robots cannot pass."""
    import numpy as np

    narrow = 0
    for i, j, _ in edges:
        path = planner.edge_path(int(i), int(j))
        if path is None:
            continue
        clearance = planner.distances_to_obstacle(np.asarray(path, dtype=float))
        narrow += bool((clearance < 2 * robot_radius_m + margin_m).any())
    return narrow / max(1, len(edges))


class StandingMeter:
    """Robot-seconds spent standing still, from the poses the physics runtime records."""

    def __init__(self) -> None:
        self.anchor: list | None = None  # (t [s], positions) at the window's start
        self.standing_s = 0.0

    def __call__(self, t: float, positions) -> None:
        import numpy as np

        xy = np.asarray(positions, dtype=float)
        if self.anchor is None:
            self.anchor = (t, xy.copy())
            return
        t0, xy0 = self.anchor
        if t - t0 >= STAND_WINDOW_S - 1e-9:
            moved = np.hypot(*(xy - xy0).T)
            self.standing_s += (t - t0) * int((moved < STAND_MOVE_M).sum())
            self.anchor = (t, xy.copy())


def steady_imax(visits, start_s: float = STEADY_FROM_S) -> float:
    """[s] the longest interval between two visits of a vertex that begins after start_s."""
    times: dict[int, list[float]] = {}
    for t, _, v in visits:
        times.setdefault(v, []).append(t)
    gaps = [b - a for ts in map(sorted, times.values())
            for a, b in zip(ts, ts[1:], strict=False) if a >= start_s]
    return max(gaps, default=math.nan)


def figures(summary: dict, visits, duration: float, n_vertices: int) -> dict:
    return {"visits": summary["visits"], "imax_s": summary["idleness_max_s"],
            "imax_steady_s": steady_imax(visits),
            "wait_s": worst_wait_after_first_visit(visits, duration, n_vertices),
            "visits_patrolling_sim": summary.get("visits_patrolling_sim"),
            "dwell_s": summary.get("dwell_time_s", 0.0),
            "interferences": summary.get("interferences", 0)}


def one(case: dict) -> dict:
    from tpuaf.navigation.planner import shared_planner
    from tpuaf.runtimes.config import PhysicsConfig, RunConfig
    from tpuaf.runtimes.graph import make_run
    from tpuaf.runtimes.physics import PhysicsRun

    common = dict(map=map_ref(case["map"]), strategy=case["strategy"], robots=case["robots"],
                  duration_s=case["duration"], seed=case["seed"], robot=case["robot"],
                  lanes=case.get("lanes", "auto"),
                  strategy_params=dict(case.get("strategy_params", {})))
    out = dict(case)
    try:
        graph = make_run(RunConfig(**common))
    except Exception as err:  # e.g. an edge no robot of this size can drive: say so
        out["error"] = str(err).splitlines()[0]
        return out
    robot_s = case["robots"] * case["duration"]
    n = graph.patrol_map.num_vertices
    s = graph.run()
    out["graph"] = figures(s, graph.recorder.visits, case["duration"], n)
    out["graph"]["dwell_share"] = out["graph"]["dwell_s"] / robot_s
    cpu0 = time.process_time()
    run = PhysicsRun(PhysicsConfig(**common))
    meter = StandingMeter()
    record = run.recorder.record_positions

    def record_and_meter(t, xy):
        meter(t, xy)
        return record(t, xy)

    run.recorder.record_positions = record_and_meter
    s = run.run()
    cpu = time.process_time() - cpu0
    ph = figures(s, run.recorder.visits, case["duration"], n)
    ph.update(collisions=s["collisions"], goal_failures=s["goal_failures"],
              standing_share=meter.standing_s / robot_s,
              sim_per_cpu=case["duration"] / cpu if cpu > 0 else math.inf)
    out["physics"] = ph
    robot = run.robot
    planner = shared_planner(run.source_map, robot.radius_m)
    # The team's own single-edge traversals (departure to visit, dwells left out), as every
    # robot learns them from the team messages (robot/learning.py), against the model's times.
    learned = run.agents[0].machine.learned.durations
    out["model_error"], out["model_edges"] = model_error(learned.measured(), learned.model)
    margin = run.agents[0].navigator.controller.config.safety_margin
    out["one_lane_share"] = one_lane_share(planner, robot.radius_m, margin, run.patrol_map.edges)
    out["preset"], out["speed_mps"] = robot.preset, robot.speed_mps
    return out


def ratio(a: float, b: float) -> float:
    return a / b if b else math.inf


def ratios(r: dict) -> dict:
    g, p = r["graph"], r["physics"]
    return {"imax": ratio(p["imax_s"], g["imax_s"]), "wait": ratio(p["wait_s"], g["wait_s"]),
            "steady": ratio(p["imax_steady_s"], g["imax_steady_s"]),
            "visits": ratio(p["visits"], g["visits"])}


def cause(r: dict, q: dict) -> str:
    """Why a case misses a target, from its own figures (first rule that holds)."""
    p = r["physics"]
    if r["graph"]["imax_s"] is None:
        return ("no interval in the plan: every robot parks on a vertex (N = vertices) and "
                "standing is no visit; both runtimes' worst wait is the whole run")
    if r["one_lane_share"] > 0 and (p["goal_failures"] or p["standing_share"] > 0.2):
        return (f"one-robot aisles ({r['one_lane_share']:.0%} of edges; "
                f"{p['standing_share']:.0%} of robot time standing, "
                f"{p['goal_failures']} failed goals)")
    if p["collisions"] or p["goal_failures"]:
        return f"jams ({p['collisions']} contacts, {p['goal_failures']} failed goals)"
    if q["steady"] <= IMAX_MAX and q["visits"] >= VISITS_MIN:
        return (f"start transient (I_max of intervals from {STEADY_FROM_S:g} s on: "
                f"{q['steady']:.2f}x)")
    if math.isfinite(r["model_error"]) and r["model_error"] > MODEL_MAX:
        return (f"travel times off the model by {r['model_error']:.0%} (waits and give-way "
                "round teammates)")
    if p["standing_share"] > 2 * r["graph"]["dwell_share"] + 0.1:
        return f"waiting ({p['standing_share']:.0%} of robot time standing)"
    if r["strategy"] == "tpuaf":
        over = ""
        if r.get("seeds"):
            over = (f"; over seeds 1-{len(r['seeds'])} median physics / median graph I_max "
                    f"{seed_ratio(r):.2f}x")
        return (f"online choices diverge from the plan's (one seed; steady-state I_max "
                f"{q['steady']:.2f}x, travel times within {r['model_error']:.0%} of the "
                f"model{over})")
    return (f"spacing drift (steady-state I_max {q['steady']:.2f}x; {p['interferences']} "
            f"robot meetings within 2 m against {r['graph']['interferences']} in the plan)")


def seed_ratio(r: dict) -> float:
    """Median physics I_max over the case's seeds / median graph I_max over them."""
    return ratio(statistics.median(s["physics_imax_s"] for s in r["seeds"]),
                 statistics.median(s["graph_imax_s"] for s in r["seeds"]))


def seed_runs(results: list[dict], workers: int) -> None:
    """Cases missed by online choices alone (TPUAF: a chaotic policy, one seed against one
    seed) are run on seeds 2..SEEDS as well, in both runtimes: r["seeds"], seed 1 first."""
    diverged = [r for r in distinct(results) if "error" not in r
                and not all(met(ratios(r)).values())
                and cause(r, ratios(r)).startswith("online choices")]
    extra = [dict(r, seed=s) for r in diverged for s in range(2, SEEDS + 1)]
    keep = ("map", "robot", "strategy", "robots", "duration", "lanes", "strategy_params")
    for r in diverged:
        r["seeds"] = [{"seed": r["seed"], "graph_imax_s": r["graph"]["imax_s"],
                       "physics_imax_s": r["physics"]["imax_s"]}]
    with ProcessPoolExecutor(workers) as pool:
        for case, out in zip(extra, pool.map(one, [{k: c[k] for k in (*keep, "seed") if k in c}
                                                     for c in extra]), strict=True):
            owner = next(r for r in diverged if all(r.get(k) == case.get(k) for k in keep))
            owner["seeds"].append({"seed": case["seed"], "graph_imax_s": out["graph"]["imax_s"],
                                   "physics_imax_s": out["physics"]["imax_s"]})
            print(f"[seed {case['seed']}] {case['map']} {case['robot']} {case['strategy']} "
                  f"N={case['robots']}", file=sys.stderr, flush=True)


def seeds_table(results: list[dict]) -> str:
    rows = [r for r in distinct(results) if r.get("seeds")]
    if not rows:
        return ""
    out = ["## Cases missed by online choices, over seeds\n",
           f"TPUAF decides online, so one seed of physics against one seed of the graph runtime "
           f"compares two draws of a chaotic process. These cases were also run on seeds "
           f"2-{SEEDS} (same map, robot and N):\n",
           "| map | robot | strategy | N | graph I_max per seed [s] | physics I_max per seed [s] "
           "| median physics / median graph |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        g = ", ".join(f"{s['graph_imax_s']:.1f}" for s in r["seeds"])
        p = ", ".join(f"{s['physics_imax_s']:.1f}" for s in r["seeds"])
        out.append(f"| {r['map']} | {r['robot']} | {r['strategy']} | {r['robots']} | {g} | {p} "
                   f"| {seed_ratio(r):.2f}x |")
    return "\n".join(out) + "\n\n"


def distinct(results: list[dict]) -> list[dict]:
    """The cases, each robot model once per map (on lab `auto` is the Burger: one row)."""
    seen, out = set(), []
    for r in results:
        key = (r["map"], r.get("preset", r["robot"]), r.get("speed_mps"), r["strategy"],
               r["robots"])
        if key not in seen:
            seen.add(key)
            out.append(r)
    return out


def whole_run_wait(r: dict) -> bool:
    """Both runtimes' worst wait is the whole run: some vertex was never visited again after
    its first visit (a robot parked on it for good, docs/STRATEGIES.md), so the wait ratio
    reads 1.00 whatever physics does."""
    end = 0.99 * float(r["duration"])
    return all((r[k].get("wait_s") or 0.0) >= end for k in ("graph", "physics"))


def met(q: dict) -> dict:
    return {"imax": q["imax"] <= IMAX_MAX, "wait": q["wait"] <= WAIT_MAX,
            "visits": q["visits"] >= VISITS_MIN}


def table(results: list[dict]) -> tuple[str, dict]:
    rows = ["| map | robot | strategy | N | graph / physics visits | visits ratio | I_max ratio "
            "| steady I_max ratio | wait ratio | standing (physics) / dwell (graph) | model error "
            "| one-lane edges "
            "| verdict |", "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    counts = {"cases": 0, "imax": 0, "wait": 0, "visits": 0, "all": 0, "passable": 0,
              "passable_met": 0, "trivial_wait": []}
    misses = []
    for r in distinct(results):
        head = f"| {r['map']} | {r['robot']} | {r['strategy']} | {r['robots']} "
        if "error" in r:
            rows.append(head + f"| {r['error'][:70]} | - | - | - | - | - | - | - | not run |")
            continue
        q = ratios(r)
        ok = met(q)
        counts["cases"] += 1
        for k in ("imax", "wait", "visits"):
            counts[k] += ok[k]
        counts["all"] += all(ok.values())
        if r["one_lane_share"] == 0:
            counts["passable"] += 1
            counts["passable_met"] += ok["imax"] and ok["wait"]
        verdict = "met" if all(ok.values()) else "**" + cause(r, q) + "**"
        if not all(ok.values()):
            misses.append((r, q, verdict))
        elif whole_run_wait(r):
            counts["trivial_wait"].append(f"{r['map']} {r['robot']} {r['strategy']} "
                                          f"N = {r['robots']}")
            verdict = ("met, **the wait only trivially**: both runtimes' worst wait is the "
                       "whole run (a robot parked for good, or a team too small to lap)")
        g, p = r["graph"], r["physics"]
        err = "-" if math.isnan(r["model_error"]) else f"{r['model_error']:.1%}"
        rows.append(head + f"| {g['visits']} / {p['visits']} | {q['visits']:.2f} | "
                    f"{q['imax']:.2f} | {q['steady']:.2f} | {q['wait']:.2f} | "
                    f"{p['standing_share']:.0%} / "
                    f"{g['dwell_share']:.0%} | {err} | {r['one_lane_share']:.0%} | {verdict} |")
    counts["causes"] = {}
    for _, _, verdict in misses:
        kind = verdict.strip("*").split(" (")[0].split(":")[0].split(" by ")[0]
        counts["causes"][kind] = counts["causes"].get(kind, 0) + 1
    return "\n".join(rows) + "\n", counts


def per_map(results: list[dict]) -> str:
    rows = ["| map | robot | speed [m/s] | model error, median over cases | one-lane edges |",
            "|---|---|---|---|---|"]
    keys = sorted({(r["map"], r["robot"]) for r in distinct(results) if "error" not in r})
    worst = 0.0
    for m, rb in keys:
        rs = [r for r in results if (r["map"], r["robot"]) == (m, rb) and "error" not in r]
        errs = [r["model_error"] for r in rs if not math.isnan(r["model_error"])]
        e = statistics.median(errs) if errs else math.nan
        worst = max(worst, e) if not math.isnan(e) else worst
        rows.append(f"| {m} | {rb} ({rs[0]['preset']}) | {rs[0]['speed_mps']:g} | "
                    f"{'-' if math.isnan(e) else f'{e:.1%}'} | {rs[0]['one_lane_share']:.0%} |")
    return "\n".join(rows) + f"\n\nWorst map: {worst:.1%} (target {MODEL_MAX:.0%}).\n"


def report(results: list[dict], args, wall: float, head: str) -> str:
    body, c = table(results)
    cmd = " ".join(sys.argv[1:])
    text = head.replace("Medians of repeated runs.", "One run per case.") + (
        f"{len(distinct(results))} distinct cases ({len(results)} run; where `auto` is the "
        f"Burger, as on lab, its rows are shown once), {args.duration:g} s each, seed "
        f"{args.seed}; wall {wall:.0f} s "
        f"with {args.workers} workers. Command: "
        f"`.venv/bin/python benchmarks/bench_fidelity.py{' ' + cmd if cmd else ''}`.\n\n"
        "Ratios are physics / graph runtime, both on the same robot model: the graph runtime "
        "plans and drives each edge in the travel-time model's duration for that robot "
        "(`tpuaf run --robot R`). Visits are driven visits (the one visit rule: "
        "docs/RUNTIMES.md). Robot `auto` is the map's preset (as `tpuaf fleet`), `burger` a "
        "TurtleBot3 Burger (0.22 m/s, or the map's speed if slower). Standing: the share of "
        f"robot time a robot moved under {STAND_MOVE_M * 100:g} cm in a {STAND_WINDOW_S:g} s "
        "window; dwell: the plan's share of robot time waiting on a vertex. Model error: "
        f"median over edges driven at least {MIN_TRAVERSALS} times in the physics patrol "
        "(departure to visit, as the robots learn them) of |model - measured median| / "
        "measured median (teammates' give-way included). "
        "One-lane edges: planned paths with a point where two robots cannot pass.\n\n")
    text += (
        f"## Verdict\n\nTargets: I_max ratio <= {IMAX_MAX}, worst wait ratio <= {WAIT_MAX} "
        f"where the aisles let robots pass, driven visits ratio >= {VISITS_MIN}.\n\n"
        f"- all three met in **{c['all']} of {c['cases']}** cases;\n"
        f"- I_max <= {IMAX_MAX}x in {c['imax']}, wait <= {WAIT_MAX}x in {c['wait']}, "
        f"visits >= {VISITS_MIN}x in {c['visits']};\n"
        f"- on maps whose every edge lets two robots pass: I_max and wait met in "
        f"**{c['passable_met']} of {c['passable']}** cases;\n"
        f"- of the cases met, {len(c['trivial_wait'])} meet the wait target only trivially "
        "(both runtimes' worst wait is the whole run: a robot parked on a vertex for good, "
        "docs/STRATEGIES.md, or a team too small to lap the graph): "
        + (", ".join(c["trivial_wait"]) or "none") + ".\n\n"
        "Each missed case names its cause in the last column (rules: `cause` in the "
        "script): " + "; ".join(f"{kind}: {k}" for kind, k in sorted(
            c["causes"].items(), key=lambda kv: -kv[1])) + ".\n\n")
    text += seeds_table(results)
    text += "## Travel-time model per map\n\n" + per_map(results) + "\n"
    text += "## Cases\n\n" + body
    return text


def holds(name: str, n: int) -> bool:
    from tpuaf.maps import load_map

    return load_map(map_ref(name)).num_vertices >= n


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", nargs="+", default=[*SHARED_MAPS, *BUILTIN_MAPS])
    ap.add_argument("--robots", nargs="+", type=int, default=[2, 4, 8, 12])
    ap.add_argument("--strategies", nargs="+", default=["tpuaf", "tpuaf_plus"])
    ap.add_argument("--robot-models", nargs="+", default=["auto", "burger"])
    ap.add_argument("--duration", type=float, default=900.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--case", action="append", default=[], metavar="MAP:STRATEGY:N[:ROBOT]",
                    help="one case (repeatable; ROBOT default auto; builtin maps as "
                         "builtin:NAME); replaces the cross product of the other options")
    ap.add_argument("--lanes", default="auto",
                    help="lane mode of both runtimes (params.LANE_MODES; default auto)")
    ap.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                    help="a strategy parameter of every case (repeatable; as `tpuaf run "
                         "--param`), e.g. retime=true for tpuaf_plus")
    ap.add_argument("--out", default="fidelity",
                    help="name of the results files in benchmarks/results (default fidelity)")
    ap.add_argument("--quick", action="store_true", help="print, do not write the results")
    ap.add_argument("--from-json", metavar="NAME", default=None,
                    help="rewrite NAME.md from the measured NAME.json (no runs)")
    args = ap.parse_args()
    if args.from_json:
        saved = json.loads((RESULTS / f"{args.from_json}.json").read_text())
        args.duration, args.seed, args.workers = (saved["duration"], saved["seed"],
                                                  saved["workers"])
        sys.argv = [sys.argv[0], *saved["argv"]]
        write(f"{args.from_json}.md", report(saved["results"], args, saved["wall_s"],
                                             saved["header"]))
        return 0
    if not args.out.replace("_", "").replace("-", "").isalnum():
        ap.error(f"--out must be a plain file name, got {args.out!r}")
    cases = []
    for text in args.case:
        parts = text.split(":")
        if parts[0] == "builtin" and len(parts) > 1:
            parts = [f"builtin:{parts[1]}", *parts[2:]]
        if len(parts) not in (3, 4) or not parts[2].isdigit() or int(parts[2]) < 1:
            ap.error(f"--case wants MAP:STRATEGY:N[:ROBOT] with N >= 1, got {text!r}")
        cases.append(dict(map=parts[0], strategy=parts[1], robots=int(parts[2]),
                          robot=parts[3] if len(parts) == 4 else "auto"))
    if not cases:
        cases = [dict(map=m, robot=rb, strategy=s, robots=n) for m in args.maps
                 for rb in args.robot_models for s in args.strategies for n in args.robots]
    from tpuaf.cli.run import parse_params
    from tpuaf.errors import TpuafError
    from tpuaf.policies import REGISTRY

    try:
        params = parse_params(args.param)
    except TpuafError as err:
        ap.error(str(err))

    for c in cases:
        if c["strategy"] not in REGISTRY.names():
            ap.error(f"unknown strategy {c['strategy']!r}")
        c.update(duration=args.duration, seed=args.seed, lanes=args.lanes)
        if params:
            c["strategy_params"] = params
    try:
        cases = [c for c in cases if holds(c["map"], c["robots"])]
    except (TpuafError, OSError, ValueError) as err:
        ap.error(str(err))
    start = time.perf_counter()
    results = []
    with ProcessPoolExecutor(args.workers) as pool:
        for k, r in enumerate(pool.map(one, cases), 1):
            results.append(r)
            line = r.get("error") or (
                f"I_max {ratios(r)['imax']:.2f}x, wait {ratios(r)['wait']:.2f}x, "
                f"visits {ratios(r)['visits']:.2f}x")
            print(f"[{k}/{len(cases)}] {r['map']} {r['robot']} {r['strategy']} "
                  f"N={r['robots']}: {line}", file=sys.stderr, flush=True)
    seed_runs(results, args.workers)
    wall = time.perf_counter() - start
    head = header("Physical fidelity, like for like: physics against the graph runtime")
    text = report(results, args, wall, head)
    if args.quick:
        print(text)
        return 0
    write(f"{args.out}.md", text)
    saved = {"argv": sys.argv[1:], "duration": args.duration, "seed": args.seed,
             "workers": args.workers, "wall_s": wall, "header": head, "results": results}
    (RESULTS / f"{args.out}.json").write_text(json.dumps(saved, indent=1, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
