"""Cost of liveness from heartbeats (issue 19 item 4) in the graph runtime.

Whole-process wall time of `tpuaf run` (1 h, cumberland, N = 12, a quarter of the team dying at
1800 s: robots 0, 4, 8) for TPUAF and tpuaf_plus, this checkout against a baseline checkout
(`--baseline-src`: the `src/tpuaf_ros/src` of a tree before the change, e.g. a `git worktree`
of the commit before it, where the survivors were told by an oracle). The runs alternate
(baseline, current, ...) so that a changing machine load hits both alike; medians and the ratio.
In-process, the time spent in the liveness code (feeding, planning and running the checks) and
the number of checks, for the current tree. Then what detection from heartbeats changes in the
results: a quarter of the team dying at 1800 s, alone and with 30 % loss and/or 5 s delay,
oracle (baseline) against heartbeats (current): detection delays and the worst idleness after.

    .venv/bin/python benchmarks/bench_liveness.py --baseline-src /tmp/base/src/tpuaf_ros/src
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import header, write

REPO = Path(__file__).resolve().parents[1]
CUMBERLAND = REPO.parent / "shared" / "maps" / "patrolling_sim" / "cumberland"
DEATHS = ["--fail", "0@1800", "--fail", "4@1800", "--fail", "8@1800"]
CASES = [("tpuaf", []), ("tpuaf_plus", []), ("tpuaf", ["--loss", "0.3"])]


CURRENT_SRC = str(REPO / "src" / "tpuaf_ros" / "src")  # this checkout's package


def command(strategy: str, extra: list[str], out: str) -> list[str]:
    return [str(Path(sys.executable).parent / "tpuaf"), "run", "--map", str(CUMBERLAND),
            "--robots", "12", "--strategy", strategy, "--duration", "3600", *DEATHS, *extra,
            "--quiet", "--out", out]


def environment(src: str) -> dict:
    """The environment of a child that imports tpuaf from `src` first."""
    env = dict(os.environ)
    env["PYTHONPATH"] = src + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return env


def wall(strategy: str, extra: list[str], src: str) -> tuple[float, float]:
    """(wall [s], CPU user + system [s]) of one whole `tpuaf run` process."""
    env = environment(src)
    with tempfile.TemporaryDirectory() as tmp:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        subprocess.run(command(strategy, extra, str(Path(tmp) / "run")), env=env, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=REPO)
        elapsed = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        return elapsed, cpu


def liveness_share(strategy: str, extra: list[str]) -> tuple[float, float, int]:
    """(run s, liveness s, checks) of one in-process run of the current tree."""
    from tpuaf.maps import load_map
    from tpuaf.runtimes.config import RunConfig
    from tpuaf.runtimes.graph import GraphRun

    spent = [0.0, 0]

    def timed(fn, count=False):
        def wrapper(*args, **kwargs):
            t0 = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                spent[0] += time.perf_counter() - t0
                spent[1] += count

        return wrapper

    loss = float(extra[1]) if extra else 0.0
    config = RunConfig(map=str(CUMBERLAND), strategy=strategy, robots=12, duration_s=3600.0,
                       fail=["0@1800", "4@1800", "8@1800"], loss=loss)
    engine = GraphRun(config, load_map(str(CUMBERLAND)))
    # Only the outermost liveness calls are timed (planning is also called from a check).
    engine.liveness_due = timed(engine.liveness_due, count=True)
    engine.start_liveness = timed(engine.start_liveness)
    inject = engine.inject
    engine.inject = timed(inject)  # a death replans every survivor
    t0 = time.perf_counter()
    engine.run()
    return time.perf_counter() - t0, spent[0], spent[1]


EFFECT_MAPS = ["grid", str(CUMBERLAND)]
EFFECT_STRATEGIES = ["tpuaf", "tpuaf_plus", "cgg"]
EFFECT_FAULTS = [{}, {"loss": 0.3}, {"delay_s": 5.0}, {"loss": 0.3, "delay_s": 5.0}]


def effects() -> list[dict]:
    """One 1 h run per (map, strategy, faults) at N = 8, robots 0 and 4 dying at 1800 s."""
    from tpuaf.runtimes.config import RunConfig
    from tpuaf.runtimes.graph import GraphRun

    rows = []
    for m in EFFECT_MAPS:
        for strategy in EFFECT_STRATEGIES:
            for faults in EFFECT_FAULTS:
                s = GraphRun(RunConfig(map=m, strategy=strategy, robots=8, duration_s=3600.0,
                                       seed=0, fail=["0@1800", "4@1800"], **faults)).run()
                rec = s["recovery"]
                rows.append({"map": Path(m).name, "strategy": strategy, "faults": faults,
                             "worst_after_s": max(r["worst_idleness_after_s"] for r in rec),
                             "recovery_s": max(r["recovery_time_s"] or math.inf for r in rec),
                             "liveness": s.get("liveness")})
    return rows


def effects_of(src: str) -> list[dict]:
    env = environment(src)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "effects.json"
        subprocess.run([sys.executable, __file__, "--effects-json", str(out)], env=env,
                       check=True, cwd=REPO)
        return json.loads(out.read_text())


def faults_label(faults: dict) -> str:
    parts = [f"loss {faults['loss']:g}"] if "loss" in faults else []
    parts += [f"delay {faults['delay_s']:g} s"] if "delay_s" in faults else []
    return ", ".join(parts) or "deaths only"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline-src", help="src/tpuaf_ros/src of the tree to compare with")
    parser.add_argument("--current-src", default=CURRENT_SRC,
                        help="src/tpuaf_ros/src of the tree measured (default: this checkout's)")
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--out", default="liveness.md")
    parser.add_argument("--effects-json", help=argparse.SUPPRESS)  # internal: one tree's runs
    args = parser.parse_args()
    if args.effects_json:
        Path(args.effects_json).write_text(json.dumps(effects()))
        return 0
    for src in (args.baseline_src, args.current_src):
        if src and not (Path(src) / "tpuaf").is_dir():
            print(f"bench_liveness: no tpuaf package in {src}", file=sys.stderr)
            return 2
    load0 = os.getloadavg()[0]
    rows = []
    for strategy, extra in CASES:
        base, cur = [], []
        for _ in range(args.repeats):
            if args.baseline_src:
                base.append(wall(strategy, extra, args.baseline_src))
            cur.append(wall(strategy, extra, args.current_src))
        rows.append((strategy, extra, base, cur))
        print(strategy, extra, base, cur, flush=True)
    load1 = os.getloadavg()[0]
    shares = [(s, e, *liveness_share(s, e)) for s, e in CASES]  # imports tpuaf: run it under
    # PYTHONPATH=CURRENT_SRC when that is not this checkout
    text = header("Liveness from heartbeats: cost in the graph runtime")
    text += (f"Load average (1 min) {load0:.1f} at the start, {load1:.1f} at the end of the "
             "whole-process runs (2 cores, shared).\n\n"
             "Command (whole process, each run alone, repeated alternately with the baseline):\n\n"
             f"    {' '.join(command('STRATEGY', ['[--loss 0.3]'], 'OUT'))}\n\n"
             f"Reproduce: `.venv/bin/python benchmarks/bench_liveness.py --baseline-src "
             "BASE/src/tpuaf_ros/src` (BASE: a `git worktree` of the commit before the change).\n\n"
             f"Medians of {args.repeats} runs each: wall time, and the process's CPU time (user "
             "+ system: less sensitive to the other jobs on the machine).\n\n"
             "| strategy | faults | wall: oracle [s] | wall: liveness [s] | ratio | "
             "CPU: oracle [s] | CPU: liveness [s] | ratio |\n"
             "|---|---|---|---|---|---|---|---|\n")
    for strategy, extra, base, cur in rows:
        nan = (float("nan"), float("nan"))
        wb, cb = (statistics.median(x) for x in zip(*base, strict=True)) if base else nan
        wc, cc = (statistics.median(x) for x in zip(*cur, strict=True))
        faults = "3 deaths at 1800 s" + (f", loss {extra[1]}" if extra else "")
        text += (f"| {strategy} | {faults} | {wb:.2f} | {wc:.2f} | {wc / wb:.3f} | {cb:.2f} | "
                 f"{cc:.2f} | {cc / cb:.3f} |\n")
    text += ("\nIn-process, current tree (one run each): the time spent in the liveness code "
             "(checks, death replans; feeding the delivered messages is inline in delivery and "
             "not counted) and the number of checks run.\n\n"
             "| strategy | faults | run [s] | liveness [s] | share | checks |\n"
             "|---|---|---|---|---|---|\n")
    for strategy, extra, run_s, live_s, checks in shares:
        faults = "3 deaths" + (f", loss {extra[1]}" if extra else "")
        text += (f"| {strategy} | {faults} | {run_s:.2f} | {live_s:.3f} | "
                 f"{100 * live_s / run_s:.1f} % | {checks} |\n")
    if args.baseline_src:
        old, new = effects_of(args.baseline_src), effects_of(args.current_src)
        text += ("\nWhat it changes (N = 8, robots 0 and 4 die at 1800 s, 1 h, seed 0): when the "
                 "survivors notice (after the death, fastest and slowest survivor; the oracle "
                 "told everyone at 10 s) and the worst idleness after the deaths and the recovery "
                 "time, oracle -> heartbeats.\n\n"
                 "| map | strategy | faults | noticed after [s] | worst idleness after [s] | "
                 "recovery [s] | false losses |\n|---|---|---|---|---|---|---|\n")
        for a, b in zip(old, new, strict=True):
            d = b["liveness"]["deaths"]
            first = min(x["first_delay_s"] for x in d)
            last = max(x["last_delay_s"] for x in d)
            text += (f"| {b['map']} | {b['strategy']} | {faults_label(b['faults'])} | "
                     f"{first:.1f}-{last:.1f} | {a['worst_after_s']:.1f} -> "
                     f"{b['worst_after_s']:.1f} | {a['recovery_s']:.1f} -> "
                     f"{b['recovery_s']:.1f} | {b['liveness']['false_losses']} |\n")
    write(args.out, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
