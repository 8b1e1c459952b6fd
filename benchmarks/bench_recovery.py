"""Recovery after deaths, every shipped strategy: worst idleness after the deaths against the
survivors' ideal and against the floor no strategy could avoid (metrics.death_floor).

Graph runtime, deaths of K robots (K = 1 and N/4; robots drawn per seed) at half the run; the
survivors notice them from what they stop hearing. Per case the median and worst over seeds of

- after / ideal: worst idleness after the deaths over the survivors' reference tour (issue 19's
  ratio; a cycle plan cannot go under 2 (m - 1) / m of it without graph shortcuts);
- after / reference: over max(floor, ideal), the fairer ratio: 1.0 is as good as the deaths
  allow;
- settled / ideal: the worst visit gap over the last half of the time after the deaths (the
  regime the survivors settle into: as good as a fresh plan at about 1.0-1.1);
- floor at detection / ideal: the same floor from the team's state when the teammate timeout
  ran out (the deaths + RunConfig.teammate_timeout_s): no reaction can start sooner, so where it
  exceeds 1.3 the target is out of reach for that strategy's pre-death plan. The summary's, max
  over the deaths: with simultaneous deaths the windows of all but the last are empty, and their
  floor is the idleness at the deaths (as unavoidable).

A strategy "keeps covering" when every vertex is visited again after every death in every run.
Command: `.venv/bin/python benchmarks/bench_recovery.py [--quick] [--workers 2] [--maps ...]
[--reuse [--reuse-from JSON]] [--plus-params KEY=VALUE ...] [--runtime physics] [--out NAME]`
(grid and every patrolling_sim map by default). `--runtime physics`: the same deaths in the
physics runtime (what a building gets), beside recovery.json's graph-runtime runs.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import RESULTS, header, write  # noqa: E402

MAPS_DIR = Path(__file__).resolve().parents[2] / "shared" / "maps" / "patrolling_sim"
MAPS = ("grid", "cumberland", "DIAG_labs", "example", "1r5", "ctcv")
STRATEGIES = ("tpuaf_plus", "tpuaf", "cgg", "msp", "dtap", "dtag", "gbs", "sebs", "cbls", "hpcc",
              "hcr", "cr", "rand")


def map_arg(name: str) -> str:
    return name if name in ("grid", "lab") else str(MAPS_DIR / name)


def death_run(name: str, strategy: str, n: int, k: int, seed: int, duration_s: float,
              params: dict, runtime: str = "graph", loss: float = 0.0):
    """(run, its summary, the dying robots): the graph (or physics) runtime, K robots (drawn
    per seed) dying at half the run; `loss`: the team messages' loss probability."""
    from tpuaf.runtimes.config import PhysicsConfig, RunConfig
    from tpuaf.runtimes.graph import make_run
    from tpuaf.runtimes.physics import PhysicsRun

    dying = sorted(np.random.default_rng([seed, n, k]).choice(n, k, replace=False).tolist())
    fields = dict(map=map_arg(name), strategy=strategy, robots=n, duration_s=duration_s,
                  seed=seed, fail=[[int(r), duration_s / 2] for r in dying],
                  strategy_params=params, loss=loss)
    if runtime == "physics":
        run = PhysicsRun(PhysicsConfig(**fields))
    else:
        run = make_run(RunConfig(**fields))
    return run, run.run(), dying


def one_run(case: tuple[str, str, int, int, int, float, dict, str, float]) -> dict:
    name, strategy, n, k, seed, duration_s, params, runtime, loss = case
    t0 = time.process_time()
    run, summary, _ = death_run(name, strategy, n, k, seed, duration_s, params, runtime, loss)
    rec = summary["recovery"]
    recorder = run.recorder
    # physics: vertices the dead robots' bodies cut off in truth (navigation/bodies.py) no
    # reaction can visit again; the figures are over the other vertices (`..._reachable`)
    closed = recorder.bodies_closed()
    after = max(r.get("worst_idleness_after_reachable_s", r["worst_idleness_after_s"])
                for r in rec)
    ideal = rec[-1]["ideal_worst_idleness_survivors_s"]
    floor = max(r["floor_worst_idleness_after_s"] for r in rec)
    last_death = max(r["time_s"] for r in rec)
    covered = all(any(t > last_death for t in times)
                  for v, times in enumerate(recorder.vertex_times) if v not in closed)
    # the floor from where the team stood when the survivors could first know: the deaths
    # plus the teammate timeout (no reaction to them can start sooner)
    detect = max(r["detection_floor_worst_idleness_after_s"] for r in rec)
    # the regime the survivors settle into: the worst visit gap over the last half of the time
    # after the deaths (gaps between visits in it, and each vertex's gap still open at the end)
    settle_from = duration_s / 2 + duration_s / 4
    settled = 0.0
    for v, times in enumerate(recorder.vertex_times):
        if v in closed:
            continue
        late = [t for t in times if t >= settle_from]
        gaps = [b - a for a, b in zip(late[:-1], late[1:], strict=True)]
        settled = max(settled, *gaps, duration_s - (times[-1] if times else 0.0))
    # mean uncertainty X over the 1 Hz rows after the deaths (what the worst idleness hides)
    x_after = [row["uncertainty_mean"] for row in recorder.timeseries
               if row["time_s"] > duration_s / 2]
    return {"map": name, "strategy": strategy, "N": n, "K": k, "seed": seed, "after_s": after,
            "x_after": float(np.mean(x_after)) if x_after else math.nan,
            "ideal_s": ideal, "floor_s": floor, "detect_floor_s": detect, "covered": covered,
            "settled_s": settled, "closed": len(closed),
            # closed by the survivors although a survivor could still reach them (in truth):
            # in the figures, unvisited
            "closed_no_body": len(recorder.closed - closed),
            "cpu_s": time.process_time() - t0}


def x_cell(rows: list[dict]) -> str:
    """Median over seeds of the mean uncertainty after the deaths (older rows lack it)."""
    values = [r["x_after"] for r in rows if r.get("x_after") is not None]
    return f"{statistics.median(values):.3f}" if values else "-"


def med_max(values: list[float]) -> str:
    if not values:
        return "-"
    return f"{statistics.median(values):.2f}, {max(values):.2f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="2 maps, N = 4 and 8, 1 seed")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--duration", type=float, default=1800.0, help="run length [s]")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--strategies", nargs="+", default=list(STRATEGIES))
    ap.add_argument("--maps", nargs="+", default=list(MAPS), choices=MAPS)
    ap.add_argument("--runtime", choices=("graph", "physics"), default="graph",
                    help="physics: the same deaths in the physics runtime (what a building "
                         "gets), beside recovery.json's graph-runtime runs of the same seeds")
    ap.add_argument("--out", default=None,
                    help="report name (default: recovery.md, recovery_physics.md)")
    ap.add_argument("--reuse", action="store_true",
                    help="run only --strategies on --maps; take the other rows from the last "
                         "run's JSON (same teams, seeds and duration)")
    ap.add_argument("--reuse-from", default=None,
                    help="with --reuse: the JSON in benchmarks/results to take them from "
                         "(default: the one beside --out)")
    ap.add_argument("--loss", type=float, default=0.0,
                    help="team message loss probability in [0, 1) (default 0)")
    ap.add_argument("--plus-params", nargs="+", default=[], metavar="KEY=VALUE",
                    help="tpuaf_plus parameters for its runs, e.g. repair=merge")
    args = ap.parse_args()
    default_out = "recovery.md" if args.runtime == "graph" else "recovery_physics.md"
    args.out = args.out or default_out
    if not args.out.endswith(".md"):  # a report name without its suffix
        args.out += ".md"
    plus_params = dict(kv.split("=", 1) for kv in args.plus_params if "=" in kv)
    if len(plus_params) != len(args.plus_params):
        ap.error("--plus-params takes KEY=VALUE pairs")
    maps = MAPS[:2] if args.quick else [m for m in MAPS if m in args.maps]
    teams = (4, 8) if args.quick else (4, 8, 12)
    seeds = 1 if args.quick else args.seeds
    saved = RESULTS / Path(args.out).with_suffix(".json").name
    source = RESULTS / args.reuse_from if args.reuse_from else saved
    kept = []
    if args.reuse and source.is_file():
        old = json.loads(source.read_text())
        if old.get("duration_s") == args.duration and old.get("seeds") == seeds:
            kept = [r for r in old["rows"] if (r["strategy"] not in args.strategies
                                               or r["map"] not in maps) and r["N"] in teams]
    strategies = list(args.strategies) + [s for s in STRATEGIES if any(
        r["strategy"] == s for r in kept) and s not in args.strategies]
    cases = [(m, s, n, k, seed, args.duration, plus_params if s == "tpuaf_plus" else {},
              args.runtime, args.loss)
             for m in maps for n in teams
             for k in sorted({1, max(1, n // 4)}) for s in args.strategies
             for seed in range(1, seeds + 1)]
    load_before = os.getloadavg()[0]
    start = time.perf_counter()
    rows = []
    with ProcessPoolExecutor(args.workers) as pool:
        for i, row in enumerate(pool.map(one_run, cases, chunksize=4), 1):
            rows.append(row)
            if i % 20 == 0 or i == len(cases):
                print(f"{i}/{len(cases)} runs, {time.perf_counter() - start:.0f} s", flush=True)
    wall = time.perf_counter() - start
    saved.write_text(json.dumps({"duration_s": args.duration, "seeds": seeds,
                                 "rows": rows + kept}, indent=1))
    rows += kept
    shown = [m for m in MAPS if any(r["map"] == m for r in rows)]  # run now or kept

    def pick(m, n, k, s):
        return [r for r in rows if (r["map"], r["N"], r["K"], r["strategy"]) == (m, n, k, s)]

    lines = [header("Recovery after deaths: every strategy against the survivors' ideal and "
                    "the unavoidable floor"),
             f"Command: `.venv/bin/python benchmarks/bench_recovery.py{' --quick' if args.quick else ''}"
             f" --seeds {seeds} --duration {args.duration:.0f}"
             + (f" --plus-params {' '.join(args.plus_params)}" if plus_params else "")
             + (f" --runtime {args.runtime}" if args.runtime != "graph" else "")
             + (f" --loss {args.loss:g}" if args.loss else "")
             + (f" --strategies {' '.join(args.strategies)}" if not kept
                and list(args.strategies) != list(STRATEGIES) else "")
             + (f" --out {args.out}" if args.out != default_out else "")
             + (f" --maps {' '.join(maps)} --strategies {' '.join(args.strategies)} --reuse"
                + (f" --reuse-from {args.reuse_from}" if args.reuse_from else "")
                + f"` (the other rows from {source.name})" if kept else "`")
             + (f" (tpuaf_plus with {', '.join(args.plus_params)})" if plus_params else "")
             + f". {len(cases)} runs now, {len(rows)} in the tables, {args.runtime} "
             f"runtime, {args.duration:.0f} s each, deaths at {args.duration / 2:.0f} s"
             + (f", {100 * args.loss:g} % of team messages lost" if args.loss else "")
             + "; wall "
             f"{wall:.0f} s with {args.workers} workers; load average (1 min) {load_before:.1f} "
             "at the start.", "",
             "Per cell: median, worst over seeds of the worst idleness after the deaths over "
             "**max(floor, ideal)** (1.00 = as good as the deaths allow), then in brackets over "
             "the survivors' **ideal** alone (issue 19's ratio). `never` = some vertex was not "
             "visited again after a death in some run (the strategy stops covering). Mean X "
             "after: the median over seeds of the mean uncertainty (SPEC's X) over the 1 Hz rows "
             "after the deaths."
             + (" Physics: the worst idleness after, `settled` and `never` are over the vertices "
                "the dead robots' bodies do not cut off, in truth (the summary's "
                "`vertices_under_bodies`, navigation/bodies.py: no survivor can plan a way to within "
                "the visit radius of them round the bodies; "
                f"{sum(1 for r in rows if r.get('closed'))} of {len(rows)} runs had one). The "
                "vertices the survivors closed themselves (`lane_vertices_closed`, as they locate "
                "a body from the team messages) stay in the figures; of these, a survivor could "
                "still reach (a misjudgement, which the figures then count against the strategy): "
                f"{sum(r.get('closed_no_body', 0) for r in rows)} vertices in "
                f"{sum(1 for r in rows if r.get('closed_no_body'))} runs."
                if args.runtime == "physics" else ""), ""]
    verdicts = []
    ours_settled: list[float] = []
    for m in shown:
        for n in teams:
            for k in sorted({1, max(1, n // 4)}):
                lines += [f"### {m}, N = {n}, K = {k} death{'s' if k > 1 else ''}", "",
                          "| strategy | after / max(floor, ideal) | (after / ideal) | "
                          "floor / ideal | floor at detection / ideal | settled / ideal | "
                          "mean X after | keeps covering |", "|---|---|---|---|---|---|---|---|"]
                ours = (math.nan,) * 4
                others: list[tuple[float, str]] = []
                for s in strategies:
                    got = pick(m, n, k, s)
                    if not got:
                        continue
                    ref = [r["after_s"] / max(r["floor_s"], r["ideal_s"]) for r in got]
                    ideal = [r["after_s"] / r["ideal_s"] for r in got]
                    floor = [r["floor_s"] / r["ideal_s"] for r in got]
                    detect = [r["detect_floor_s"] / r["ideal_s"] for r in got]
                    covered = all(r["covered"] for r in got)
                    settled = [r["settled_s"] / r["ideal_s"] for r in got]
                    lines.append(f"| {s} | {med_max(ref)} | ({med_max(ideal)}) | "
                                 f"{statistics.median(floor):.2f} | {med_max(detect)} | "
                                 f"{med_max(settled)} | {x_cell(got)} | "
                                 f"{'yes' if covered else 'never'} |")
                    if s == "tpuaf_plus":
                        ours = (max(ideal), max(ref), max(detect),
                                max(r["after_s"] / max(r["detect_floor_s"], r["ideal_s"])
                                    for r in got))
                        ours_settled.append(max(settled))
                    elif covered:
                        others.append((max(ideal), s))
                verdicts.append((m, n, k, ours, min(others, default=(math.inf, "-"))))
                lines.append("")
    lines += ["## Verdicts (worst over seeds)", "",
              "Which strategy recovers best is judged on the worst idleness after the deaths "
              "itself (over the ideal, the same for every strategy of a case); the floor differs "
              "per strategy (it depends on where the team stood at the death), so the ratio to "
              "max(floor, ideal) says how much better tpuaf_plus could have done from where it "
              "stood, not how it ranks.", "",
              "| map | N | K | tpuaf_plus after / ideal | best other that keeps covering, "
              "after / ideal | tpuaf_plus lowest | tpuaf_plus after / max(floor, ideal) | "
              "tpuaf_plus floor at detection / ideal | 1.3x reachable after detection | "
              "tpuaf_plus after / max(floor at detection, ideal) |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    within = lowest = ideal_ok = reachable = detect_within = 0
    for m, n, k, (ours, ours_ref, ours_detect, ours_dref), (other, who) in verdicts:
        w, lo, reach = ours_ref <= 1.3, ours <= other and math.isfinite(other), ours_detect <= 1.3
        within += w
        lowest += lo
        ideal_ok += ours <= 1.3
        reachable += reach
        detect_within += ours_dref <= 1.3
        lines.append(f"| {m} | {n} | {k} | {ours:.2f} | "
                     + (f"{other:.2f} ({who}) | {'yes' if lo else '**no**'}"
                        if math.isfinite(other) else "- | -")
                     + f" | {ours_ref:.2f} | {ours_detect:.2f} | "
                     f"{'yes' if reach else 'no'} | {ours_dref:.2f} |")
    lines += ["", f"- tpuaf_plus after / survivors' ideal within 1.3x (issue 19's target): "
              f"{ideal_ok} of {len(verdicts)} cases.",
              f"- tpuaf_plus after / max(floor, ideal) within 1.3x: {within} of "
              f"{len(verdicts)} cases.",
              f"- 1.3x of the ideal reachable at all once the survivors can know (tpuaf_plus's "
              f"floor at detection <= 1.3 ideal in every seed): {reachable} of {len(verdicts)} "
              "cases; in the others no reaction to the death, however good, meets the target "
              "from where the team stood when the teammate timeout ran out.",
              f"- tpuaf_plus after / max(floor at detection, ideal) within 1.3x: "
              f"{detect_within} of {len(verdicts)} cases.",
              f"- tpuaf_plus settled / ideal (worst over seeds, the last half of the time after "
              f"the deaths): {min(ours_settled, default=math.nan):.2f}-"
              f"{max(ours_settled, default=math.nan):.2f} "
              f"({sum(x <= 1.1 + 1e-9 for x in ours_settled)} of {len(ours_settled)} cases "
              f"within 1.1x, {sum(x <= 1.3 + 1e-9 for x in ours_settled)} within 1.3x).",
              (f"- tpuaf_plus lowest worst idleness after the deaths of the strategies that keep "
               f"covering: {lowest} of {len(verdicts)} cases." if len(strategies) > 1 else
               "- no other strategy in these runs: no ranking."),
              f"- CPU per run: median {statistics.median(r['cpu_s'] for r in rows):.2f} s.",
              f"- Load average (1 min) at the end: {os.getloadavg()[0]:.1f}.", ""]
    if args.runtime == "physics":
        lines += against_graph(rows, teams, seeds, args.duration)
    write(args.out, "\n".join(lines))


def against_graph(rows: list[dict], teams, seeds: int, duration_s: float) -> list[str]:
    """Physics runs beside recovery.json's graph-runtime runs of the same cases and seeds
    (tpuaf_plus): what a building gets against the promise."""
    saved = RESULTS / "recovery.json"
    graph = json.loads(saved.read_text()) if saved.is_file() else {}
    if graph.get("duration_s") != duration_s:
        return ["(no recovery.json of the same duration to compare with)", ""]
    lines = ["## Physics against the graph runtime (tpuaf_plus, the same deaths and seeds)", "",
             "Worst over seeds, over the survivors' ideal (the graph's, at the robots' speed).",
             "", "| map | N | K | graph: after | physics: after | physics / graph | graph: "
             "settled | physics: settled |", "|---|---|---|---|---|---|---|---|"]
    ratios = []
    for m in MAPS:
        for n in teams:
            for k in sorted({1, max(1, n // 4)}):
                def worst(source, field, m=m, n=n, k=k):
                    got = [r[field] / r["ideal_s"] for r in source
                           if (r["map"], r["N"], r["K"], r["strategy"]) == (m, n, k, "tpuaf_plus")
                           and r["seed"] <= seeds]
                    return max(got) if got else math.nan
                ga, pa = worst(graph["rows"], "after_s"), worst(rows, "after_s")
                if not (math.isfinite(ga) and math.isfinite(pa)):
                    continue
                ratios.append(pa / ga)
                lines.append(f"| {m} | {n} | {k} | {ga:.2f} | {pa:.2f} | {pa / ga:.2f} | "
                             f"{worst(graph['rows'], 'settled_s'):.2f} | "
                             f"{worst(rows, 'settled_s'):.2f} |")
    if ratios:
        lines += ["", f"- physics / graph worst idleness after the deaths: median "
                  f"{statistics.median(ratios):.2f}, range {min(ratios):.2f}-{max(ratios):.2f} "
                  f"over {len(ratios)} cases.", ""]
    return lines


if __name__ == "__main__":
    main()
