"""What the lane layer changes: lab, TurtleBot3 Burgers, physics runtime, N = 1-4, three modes
(another map and robot: --map, --robot).

For TPUAF and tpuaf_plus, the same seeds with lanes off, with lane locks on every lane, and
with one-way lanes (lanes on cycles driven one way, the others locked; docs/LANES.md): the
time means of instantaneous idleness I_ins and of uncertainty X, visits, goal failures,
give-ways and lane waits (count, seconds), medians over the seeds; and each run's fewest
visits of one robot in the last quarter of the run (0: a robot stopped visiting).

    .venv/bin/python benchmarks/bench_lanes.py [--duration 600] [--seeds 2] [--workers 2]
        [--modes off,locks,one_way] [--strategies tpuaf,tpuaf_plus] [--teams 1,2,3,4]
        [--map lab] [--robot burger] [--out lanes]

Writes benchmarks/results/lanes.md.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import header, write  # noqa: E402

STRATEGIES = ("tpuaf", "tpuaf_plus")
TEAMS = (1, 2, 3, 4)
MODES = ("off", "locks", "one_way")  # PhysicsConfig.lanes (params.LANE_MODES, auto aside)
KEYS = ("ins", "x", "visits", "failures", "give_ways", "waits", "wait_s", "late_min")


def one(case: tuple[str, int, int, float, str, str, str]) -> tuple[tuple, dict]:
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun
    from tpuaf.topics import REACHED

    strategy, n, seed, duration, mode, map_ref, robot = case
    late: dict[int, int] = dict.fromkeys(range(n), 0)  # visits per robot in the last quarter
    run = PhysicsRun(PhysicsConfig(map=map_ref, strategy=strategy, robots=n, duration_s=duration,
                                   seed=seed, robot=robot, lanes=mode))
    for i in range(n):
        listener = run.agents[i]._publish_event

        def counting(kind, vertex, from_vertex, t, i=i, listener=listener):
            if kind == REACHED and t >= 0.75 * duration:
                late[i] += 1
            listener(kind, vertex, from_vertex, t)

        run.agents[i]._publish_event = counting
    s = run.run()
    return case, {"ins": s["idleness_ins_mean_s"], "x": s["uncertainty_mean"],
                  "visits": s["visits"], "failures": s.get("goal_failures", 0),
                  "give_ways": sum(a.navigator.give_ways for a in run.agents),
                  "waits": s.get("lane_waits", 0), "wait_s": s.get("lane_wait_s", 0.0),
                  "late_min": min(late.values())}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--modes", default=",".join(MODES))
    ap.add_argument("--strategies", default=",".join(STRATEGIES), help="names, or all")
    ap.add_argument("--teams", default=",".join(map(str, TEAMS)))
    ap.add_argument("--map", default="lab", help="map name or folder")
    ap.add_argument("--robot", default="burger", help="robot preset (auto: the map's)")
    ap.add_argument("--out", default="lanes", help="results file stem (benchmarks/results/)")
    args = ap.parse_args()
    modes = args.modes.split(",")
    strategies = args.strategies.split(",")
    teams = [int(n) for n in args.teams.split(",")]
    from tpuaf.policies import REGISTRY

    if strategies == ["all"]:
        strategies = REGISTRY.names()
    if not set(modes) <= set(MODES) or not set(strategies) <= set(REGISTRY.names()):
        print(f"--modes from {','.join(MODES)}, --strategies all or from "
              f"{','.join(REGISTRY.names())}", file=sys.stderr)
        return 2
    seeds = range(1, args.seeds + 1)
    cases = [(s, n, seed, args.duration, mode, args.map, args.robot) for s in strategies
             for n in teams for seed in seeds for mode in modes]
    start = time.perf_counter()
    with ProcessPoolExecutor(args.workers) as pool:
        results = dict(pool.map(one, cases))
    wall = time.perf_counter() - start

    def med(s, n, mode, key):
        return statistics.median(results[(s, n, seed, args.duration, mode, args.map,
                                          args.robot)][key] for seed in seeds)

    where = "" if (args.map, args.robot) == ("lab", "burger") else (
        f" --map {args.map} --robot {args.robot}")
    command = (f"`.venv/bin/python benchmarks/bench_lanes.py --duration {args.duration:g} "
               f"--seeds {args.seeds} --modes {args.modes} --strategies {args.strategies} "
               f"--teams {args.teams}{where} --out {args.out}`")
    map_name = Path(args.map).name
    lines = [header(f"Lanes on {map_name}: physics, robot {args.robot}, lanes "
                    + " / ".join(modes)),
             f"{args.duration:g} s per run, seeds 1-{args.seeds}, medians; wall {wall:.0f} s "
             f"with {args.workers} workers, load average {os.getloadavg()[0]:.1f}. Runs: "
             f"`tpuaf run --runtime physics --map {map_name} --robot {args.robot}` (PhysicsConfig lanes, "
             f"one_way). Command: {command}. Last-quarter visits: the fewest visits of one "
             "robot in the run's last quarter, lowest over the seeds (0: a robot stopped).\n",
             "| strategy | N | lanes | I_ins [s] | X | visits | goal failures | give-ways | "
             "lane waits | lane wait [s] | last-quarter visits (min robot) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in strategies:
        for n in teams:
            for mode in modes:
                v = {k: med(s, n, mode, k) for k in KEYS}
                low = min(results[(s, n, seed, args.duration, mode, args.map,
                                   args.robot)]["late_min"] for seed in seeds)
                lines.append(f"| {s} | {n} | {mode} | {v['ins']:.1f} | {v['x']:.3f} | "
                             f"{v['visits']:.0f} | {v['failures']:.0f} | {v['give_ways']:.0f} | "
                             f"{v['waits']:.0f} | {v['wait_s']:.0f} | {low} |")
    verdicts = []
    for s in strategies:
        for mode in modes:
            lows = [results[c]["late_min"] for c in cases if c[0] == s and c[4] == mode]
            verdicts.append(f"- {s}, lanes {mode}: every robot of every run visits in the last "
                            f"quarter (no deadlock): **{'yes' if min(lows) > 0 else 'no'}** "
                            f"({sum(low > 0 for low in lows)} of {len(lows)} runs)")
            for key, name, unit in (("ins", "I_ins", " s"), ("x", "X", "")) if len(teams) > 1 \
                    else ():
                row = [med(s, n, mode, key) for n in teams]
                falls = all(b < a for a, b in zip(row, row[1:], strict=False))
                verdicts.append(f"- {s}, lanes {mode}: {name} falls at every step of N: "
                                f"**{'yes' if falls else 'no'}** ("
                                + " -> ".join(f"{v:.3g}" for v in row) + f"{unit}).")
    text = "\n".join(lines) + "\n\n" + "\n".join(verdicts) + "\n"
    write(f"{args.out}.md", text)
    (Path(__file__).resolve().parent / "results" / f"{args.out}.json").write_text(json.dumps(
        {"command": command, "duration_s": args.duration, "seeds": list(seeds),
         "runs": [{"strategy": c[0], "robots": c[1], "seed": c[2], "mode": c[4], **r}
                  for c, r in results.items()]}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
