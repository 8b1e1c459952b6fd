"""tpuaf_plus under message loss and delay: I_max against the same run without them (issue 19).

Graph runtime, 1 h, grid and every patrolling_sim map at N = 4, 8 and 12, 5 seeds; each seed
is run without faults, with 30 % loss (per recipient) and with a 5 s delay on every team
message. Per case: I_max (SPEC's worst interval idleness, the whole run) without faults, then
the change with loss and with delay, median and worst over seeds; the same for the steady
state (visit gaps that start at or after STEADY_FROM_S). Target: at most 5 %.

Command: `.venv/bin/python benchmarks/bench_message_faults.py [--seeds 5] [--workers 2]`.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from concurrent.futures import ProcessPoolExecutor

from bench_recovery import MAPS, map_arg
from common import header, write

DURATION_S = 3600.0
FAULTS = {"none": {}, "loss 0.3": {"loss": 0.3}, "delay 5 s": {"delay_s": 5.0}}
STEADY_FROM_S = 600.0  # [s] the steady state's visit gaps start after this (past the first laps)


def one_run(case: tuple[str, int, int, str]) -> dict:
    from tpuaf.runtimes.config import RunConfig
    from tpuaf.runtimes.graph import make_run

    name, n, seed, fault = case
    config = RunConfig(map=map_arg(name), strategy="tpuaf_plus", robots=n,
                       duration_s=DURATION_S, seed=seed, **FAULTS[fault])
    run = make_run(config)
    summary = run.run()
    steady = 0.0
    for times in run.recorder.vertex_times:
        late = [t for t in times if t >= STEADY_FROM_S]
        steady = max(steady, *(b - a for a, b in zip(late[:-1], late[1:], strict=True)))
    return {"map": name, "N": n, "seed": seed, "fault": fault,
            "imax_s": summary["idleness_max_s"], "steady_s": steady}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    cases = [(m, n, seed, f) for m in MAPS for n in (4, 8, 12)
             for seed in range(1, args.seeds + 1) for f in FAULTS]
    load = os.getloadavg()[0]
    start = time.perf_counter()
    with ProcessPoolExecutor(args.workers) as pool:
        rows = list(pool.map(one_run, cases, chunksize=8))
    wall = time.perf_counter() - start
    lines = [header("tpuaf_plus under message loss and delay: I_max against no faults"),
             f"Command: `.venv/bin/python benchmarks/bench_message_faults.py --seeds "
             f"{args.seeds}`. {len(cases)} runs (graph runtime, {DURATION_S:.0f} s each); wall "
             f"{wall:.0f} s with {args.workers} workers, load average (1 min) {load:.1f} at the "
             "start.", "",
             "Change of I_max against the same seed without faults, median and worst over "
             "seeds (a positive change is worse). Target (issue 19): at most 5 %.", "",
             "| map | N | I_max, no faults [s] | loss 0.3: change | delay 5 s: change | within "
             "5 % | steady I_max, no faults [s] | steady, loss 0.3 | steady, delay 5 s | "
             "steady within 5 % |", "|---|---|---|---|---|---|---|---|---|---|"]
    within = {"imax_s": 0, "steady_s": 0}
    total = 0
    worst_change = {(f, k): [] for f in FAULTS if f != "none" for k in within}
    for m in MAPS:
        for n in (4, 8, 12):
            cells = []
            for key in within:
                base = {r["seed"]: r[key] for r in rows
                        if (r["map"], r["N"], r["fault"]) == (m, n, "none")}
                ok = True
                cells.append(f"{statistics.median(base.values()):.1f}")
                for fault in FAULTS:
                    if fault == "none":
                        continue
                    change = [r[key] / base[r["seed"]] - 1.0 for r in rows
                              if (r["map"], r["N"], r["fault"]) == (m, n, fault)]
                    worst_change[fault, key].append(max(change))
                    ok &= max(change) <= 0.05 + 1e-9
                    cells.append(f"{100 * statistics.median(change):+.1f} %, "
                                 f"{100 * max(change):+.1f} %")
                within[key] += ok
                cells.append("yes" if ok else "**no**")
            total += 1
            lines.append(f"| {m} | {n} | " + " | ".join(cells) + " |")
    lines += ["", f"- Within 5 % in every seed, with loss and with delay: whole run "
              f"{within['imax_s']} of {total} cases, steady state {within['steady_s']} of "
              f"{total}."]
    for (fault, key), changes in worst_change.items():
        lines.append(f"- {fault}, {'whole run' if key == 'imax_s' else 'steady state'}: worst "
                     f"change over the cases {100 * min(changes):+.1f} % to "
                     f"{100 * max(changes):+.1f} %.")
    lines += [f"- Load average (1 min) at the end: {os.getloadavg()[0]:.1f}.", ""]
    write("message_faults.md", "\n".join(lines))


if __name__ == "__main__":
    main()
