"""Real-time factor of the ROS fleet (`tpuaf fleet`: tpuaf_stage + N patrol_agent + monitor +
rosbag record with the default topics) for N = 4, 8, 12 on grid and cumberland.

Two modes per configuration:
- paced: the simulator is paced at 10x real time (the target); reported: the achieved RTF and the
  control health = fleet visits / batch visits for the same map, strategy, N and seed (1.0 = the
  agents kept up and navigation costs nothing);
- free: the simulator runs as fast as it can; the same figures (agents may fall behind: then
  health drops).
Writes benchmarks/results/fleet.md. Usage: .venv/bin/python benchmarks/bench_fleet.py [--quick]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MAPS = {"grid": "grid", "cumberland": "/work/shared/maps/patrolling_sim/cumberland"}
BAG_TOPICS = ("/clock, /fleet/agent_events, /fleet/start, /fleet/metrics, /team/* (typed team "
              "messages), /robot_<i>/base_pose_ground_truth; LZ4; no scans, odom or tf")


def fleet(map_ref: str, n: int, duration: float, rtf: float, out: Path) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ROS_")}
    cmd = [str(REPO / ".venv/bin/python"), "-m", "tpuaf.cli", "fleet", "--map", map_ref,
           "--robots", str(n), "--duration", str(duration), "--seed", "0", "--out", str(out),
           "--rtf", str(rtf), "--quiet"]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=1800)
    timing = json.loads((out / "fleet_timing.json").read_text())
    summary = json.loads((out / "summary.json").read_text())
    bag = out / "run.bag"
    return {"ok": proc.returncode == 0, "rtf": timing["real_time_factor"],
            "visits": summary["visits"], "deaths": summary["deaths"],
            "bag_mb": bag.stat().st_size / 1e6 if bag.is_file() else None}


def batch_visits(map_ref: str, n: int, duration: float) -> int:
    from tpuaf.maps import load_map
    from tpuaf.runtimes.graph import BatchRun, RunConfig

    run = BatchRun(RunConfig(map=map_ref, strategy="tpuaf", robots=n, duration_s=duration,
                             seed=0), load_map(map_ref))
    return run.run()["visits"]


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--duration", type=float, default=120.0, help="simulated s per run")
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--quick", action="store_true", help="grid, N = 4 only")
    args = ap.parse_args()
    maps = {"grid": MAPS["grid"]} if args.quick else MAPS
    sizes = [4] if args.quick else [4, 8, 12]
    rows = []
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        for name, ref in maps.items():
            for n in sizes:
                ref_visits = batch_visits(ref, n, args.duration)
                row = {"map": name, "n": n}
                for mode, rtf in (("paced", 10.0), ("free", 0.0)):
                    runs = [fleet(ref, n, args.duration, rtf, Path(tmp) / f"{name}_{n}_{mode}_{k}")
                            for k in range(args.repeats)]
                    row[mode] = {
                        "rtf": statistics.median(r["rtf"] or 0.0 for r in runs),
                        "health": statistics.median(r["visits"] / ref_visits for r in runs),
                        "deaths": max(r["deaths"] for r in runs),
                        "bag_mb": statistics.median(r["bag_mb"] or 0.0 for r in runs),
                        "ok": all(r["ok"] for r in runs),
                    }
                    print(name, n, mode, row[mode], file=sys.stderr, flush=True)
                rows.append(row)
    lines = [
        "# Fleet real-time factor (benchmarks/bench_fleet.py)",
        "",
        f"Machine: {platform.machine()}, {os.cpu_count()} cores, load average {load:.1f} at the "
        "start (other jobs were running). TPUAF, seed 0, "
        f"{args.duration:g} s of simulated time per run, median of {args.repeats} run(s); "
        "simulator step 0.01 s, poses and control at 10 Hz, scans at 5 Hz (LDS-01 preset).",
        "",
        f"Bag (default recording): {BAG_TOPICS}.",
        "",
        "RTF = simulated seconds per wall second from the run's start to its end (start-up of "
        "~15 s not included). Health = fleet visits / batch visits (same map, N, seed): near 1 "
        "when the agents keep up; it drops when the simulator outruns them (robots stop on the "
        "cmd_vel watchdog) and with real navigation effects (turns, avoidance).",
        "",
        "| map | N | paced 10x: RTF | health | free: RTF | health | deaths | bag MB |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        p, f = r["paced"], r["free"]
        lines.append(f"| {r['map']} | {r['n']} | {p['rtf']:.1f} | {p['health']:.2f} | "
                     f"{f['rtf']:.1f} | {f['health']:.2f} | {max(p['deaths'], f['deaths'])} | "
                     f"{p['bag_mb']:.2f} |")
    out = REPO / "benchmarks" / "results" / ("fleet_quick.md" if args.quick else "fleet.md")
    out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
