"""Benchmark of `tpuaf analyze` (issue 21, item 4): whole process on fleet bags, and where the
time goes in-process (reading and replaying the bag vs writing the results folder).

Run: .venv/bin/python benchmarks/bench_analyze.py [--repeats K] [--bags DIR]
Bags: DIR/demo/run.bag (the demo's: `tpuaf fleet --map grid --robots 4 --duration 600`) and
DIR/c12/run.bag (`tpuaf fleet --map <patrolling_sim>/cumberland --robots 12 --duration 3600`);
missing ones are made with those commands first (the 1 h fleet takes a while). Writes
benchmarks/results/analyze.md. Targets: demo bag under 1 s, 1 h of 12 robots under 10 s.
"""

from __future__ import annotations

import argparse
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
TPUAF = REPO / ".venv" / "bin" / "tpuaf"
SHARED = REPO.parent / "shared" / "maps" / "patrolling_sim"
BAGS = {
    "demo": (["--map", "grid", "--robots", "4", "--duration", "600"], "grid", 1.0),
    "c12": (["--map", str(SHARED / "cumberland"), "--robots", "12", "--duration", "3600"],
            str(SHARED / "cumberland"), 10.0),
}


def make_bag(folder: Path, args: list[str]) -> Path:
    bag = folder / "run.bag"
    if not bag.is_file():
        print(f"making {bag}: tpuaf fleet {' '.join(args)}", flush=True)
        proc = subprocess.run([str(TPUAF), "fleet", *args, "--seed", "1", "--out", str(folder),
                               "--overwrite", "--quiet"], capture_output=True, text=True)
        if proc.returncode != 0 or not bag.is_file():
            sys.exit(f"tpuaf fleet failed: {proc.stderr[-2000:]}")
    return bag


def whole_process(bag: Path, out: Path) -> tuple[float, float]:
    """Wall and CPU (user + system) time [s] of `tpuaf analyze BAG --out OUT --overwrite`."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([str(TPUAF), "analyze", str(bag), "--out", str(out), "--overwrite"],
                          capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode not in (0, 1):  # 1: differs from the monitor (reported, not fatal)
        sys.exit(f"tpuaf analyze failed: {proc.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def in_process(bag: Path, map_ref: str) -> dict:
    """analyze() (read + replay) and the results folder, in one fresh interpreter."""
    code = f"""
import json, tempfile, time
from tpuaf.maps import load_map
from tpuaf.measure.bag import analyze
from tpuaf.experiments.results import ResultsWriter
m = load_map({map_ref!r})
t0 = time.process_time()
a = analyze({str(bag)!r}, m)
t1 = time.process_time()
with tempfile.TemporaryDirectory() as d:
    w = ResultsWriter(d + "/out", {{"map": {map_ref!r}}})
    w.finish(a.summary, a.recorder)
t2 = time.process_time()
print(json.dumps({{"analyze_s": t1 - t0, "results_s": t2 - t1, "visits": a.summary["visits"]}}))
"""
    proc = subprocess.run([str(REPO / ".venv" / "bin" / "python"), "-c", code],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        sys.exit(proc.stderr[-2000:])
    import json

    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--bags", type=Path, default=Path(tempfile.gettempdir()) / "tpuaf_bench_bags")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, (fleet_args, map_ref, target) in BAGS.items():
            bag = make_bag(args.bags / name, fleet_args)
            runs = [whole_process(bag, Path(tmp) / name) for _ in range(args.repeats)]
            split = [in_process(bag, map_ref) for _ in range(max(1, args.repeats // 2))]
            wall = statistics.median(w for w, _ in runs)
            cpu = statistics.median(c for _, c in runs)
            rows.append((name, " ".join(fleet_args).replace(str(SHARED) + "/", ""),
                         bag.stat().st_size / 1e6, wall, cpu,
                         statistics.median(s["analyze_s"] for s in split),
                         statistics.median(s["results_s"] for s in split), target))
            print(f"{name}: wall {wall:.2f} s, CPU {cpu:.2f} s (target {target:g} s)", flush=True)
    lines = [header("tpuaf analyze: whole process on fleet bags"),
             f"Command: `.venv/bin/python benchmarks/bench_analyze.py --repeats {args.repeats}`; "
             f"load average {os.getloadavg()[0]:.1f} at the end (2 cores). Medians.", "",
             "CPU time is what a quiet machine's wall time would be (one thread); the wall "
             "time here includes waiting for the other processes of a loaded machine. The "
             "verdict is on CPU time.", "",
             "| bag | fleet | size | whole process wall | CPU | analyze() CPU | results folder "
             "CPU (CSVs, summary.png) | target | verdict |",
             "|---|---|---|---|---|---|---|---|---|"]
    for name, what, size, wall, cpu, an, res, target in rows:
        verdict = "met" if cpu <= target else f"missed by {cpu / target:.1f}x"
        lines.append(f"| {name} | {what} | {size:.1f} MB | {wall:.2f} s | {cpu:.2f} s | "
                     f"{an:.2f} s | {res:.2f} s | {target:g} s | {verdict} |")
    lines += ["", "analyze() is the bag read and replay through the monitor logic (in a process "
              "whose imports are done); the rest of the whole process is Python start-up, "
              "imports (rosbags, numpy, matplotlib) and the results folder."]
    write("analyze.md", "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
