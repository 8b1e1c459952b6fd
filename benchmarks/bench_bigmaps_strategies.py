"""Big maps (issue 34 item 6) for every strategy: a 1 h `tpuaf run` with 100 robots on the
10,000-vertex building of bench_bigmaps.py, one process per strategy: wall time, CPU time,
peak RSS and I_max against the target (10 s, 1 GB).

    .venv/bin/python benchmarks/bench_bigmaps_strategies.py [--size 10000] [--robots 100]
        [--duration 3600] [--strategies cbls,cgg,...] [--timeout 120] [--max-memory 4]
        [--out NAME]

A run that takes longer than --timeout [s] of wall time is stopped, one that needs more than
--max-memory [GB] of address space fails (prlimit); both are reported as such.
Writes benchmarks/results/<out>.md and .json (default: bigmaps_strategies).
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_bigmaps import TARGET_MB, TARGET_S, measure, tpuaf_command, write_building  # noqa: E402
from common import RESULTS, header, write  # noqa: E402

STRATEGIES = "cbls,cgg,cr,dtag,dtap,gbs,hcr,hpcc,msp,rand,sebs,tpuaf,tpuaf_plus"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--size", type=int, default=10_000, help="vertices (the square side rounded)")
    p.add_argument("--robots", type=int, default=100)
    p.add_argument("--duration", type=float, default=3600.0, help="[s] simulated")
    p.add_argument("--strategies", default=STRATEGIES, help="comma-separated")
    p.add_argument("--timeout", type=float, default=120.0, help="[s] wall time per run")
    p.add_argument("--max-memory", type=float, default=4.0,
                   help="[GB] address space per run (prlimit): a run needing more fails there "
                        "instead of exhausting the shared machine")
    p.add_argument("--out", default="bigmaps_strategies")
    args = p.parse_args()
    command = "benchmarks/bench_bigmaps_strategies.py " + shlex.join(sys.argv[1:])
    rows = []
    with tempfile.TemporaryDirectory(prefix="bigmaps_") as tmp:
        folder = write_building(Path(tmp) / "map", args.size)
        for strategy in args.strategies.split(","):
            cmd = ["timeout", f"{args.timeout:g}", "prlimit",
                   f"--as={int(args.max_memory * 2**30)}"] + tpuaf_command() + [
                "run", "--map", str(folder), "--strategy", strategy, "--robots",
                str(args.robots), "--duration", f"{args.duration:g}", "--quiet"]
            row = {"strategy": strategy, **measure(cmd)}
            rows.append(row)
            print(f"{strategy:<11} {row['wall_s']:7.2f} s  (CPU {row['cpu_s']:6.2f} s)  "
                  f"{row['peak_mb']:6.0f} MB  exit {row['exit']}", flush=True)
    lines = ["| strategy | `run` wall [s] | `run` CPU [s] | peak RSS [MB] | I_max [s] | "
             "within target |", "|---|---:|---:|---:|---:|---|"]
    for r in rows:
        stopped = r["exit"] == 124
        ok = r["exit"] == 0 and r["wall_s"] < TARGET_S and r["peak_mb"] < TARGET_MB
        within = "yes" if ok else ("no (stopped)" if stopped else
                                   f"no (exit {r['exit']})" if r["exit"] else "no")
        i_max = f"{r['i_max_s']:,.1f}" if "i_max_s" in r and not r["exit"] else "-"
        lines.append(f"| {r['strategy']} | {r['wall_s']:.2f} | {r['cpu_s']:.2f} | "
                     f"{r['peak_mb']:.0f} | {i_max} | {within} |")
    text = header(f"Big maps: a 1 h run of every strategy on {args.size:,} vertices")
    text += (f"Command: `.venv/bin/python {command.strip()}`\n\n"
             f"`run --map MAP --strategy S --robots {args.robots} --duration "
             f"{args.duration:g} --quiet` (the graph runtime), one process per strategy, one run each, "
             f"stopped after {args.timeout:g} s of wall time and limited to "
             f"{args.max_memory:g} GB of address space (prlimit); the map is bench_bigmaps.py's "
             f"building (`write_building`). Target (issue 34): under {TARGET_S:g} s and "
             f"{TARGET_MB:g} MB. Wall time depends on the other loads of the shared 2-core "
             "machine; CPU time (user + system) less so.\n\n")
    text += "\n".join(lines) + "\n"
    write(f"{args.out}.md", text)
    (RESULTS / f"{args.out}.json").write_text(json.dumps(
        {"command": command, "size": args.size, "robots": args.robots,
         "duration_s": args.duration, "rows": rows}, indent=2) + "\n")


if __name__ == "__main__":
    main()
