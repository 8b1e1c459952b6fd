"""Physics runtime speed: simulated seconds per wall second (real-time factor) and per CPU second.

    .venv/bin/python benchmarks/bench_physics.py [--duration 300] [--repeats 3]

Cases: 12 robots on cumberland (the issue 9 target: >= 100x real time), 4 on grid, 4 TurtleBot3
Burgers on lab at 0.1 m/s. Medians of `--repeats` runs; the machine load (`uptime`) before and
after is written with the figures, since the machine is shared. CPU time (process_time) is
also given: on a loaded machine it is closer to what the runtime costs than wall time.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import header, write  # noqa: E402

SHARED = Path(__file__).resolve().parents[2] / "shared" / "maps" / "patrolling_sim"
CASES = [
    ("cumberland", str(SHARED / "cumberland"), 12, "auto"),
    ("grid", "grid", 4, "auto"),
    ("lab", "lab", 4, "burger"),
]


def load() -> str:
    return "load average " + ", ".join(f"{x:.2f}" for x in os.getloadavg())


def one(source: str, robots: int, robot: str, duration: float, seed: int):
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    run = PhysicsRun(PhysicsConfig(map=source, robots=robots, robot=robot, duration_s=duration,
                                   seed=seed))
    wall, cpu = time.perf_counter(), time.process_time()
    summary = run.run()
    return (time.perf_counter() - wall, time.process_time() - cpu, summary,
            run.robot.preset)


def cpu_split(source: str, robots: int, duration: float) -> dict[str, float]:
    """CPU seconds of one run by part: the agents' navigator (tpuaf.navigation), laser scans
    and world steps (C++), the rest (state machines, bus, recorder, this loop)."""
    from tpuaf import navigation
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    acc = {"navigator": 0.0, "scans": 0.0, "world steps": 0.0}
    step = navigation.Navigator.step

    def timed_step(self, *a):
        t = time.process_time()
        out = step(self, *a)
        acc["navigator"] += time.process_time() - t
        return out

    run = PhysicsRun(PhysicsConfig(map=source, robots=robots, duration_s=duration))
    world = run.world

    class TimedWorld:
        def __getattr__(self, name):
            return getattr(world, name)

        def scan_all(self):
            t = time.process_time()
            out = world.scan_all()
            acc["scans"] += time.process_time() - t
            return out

        def step(self, dt):
            t = time.process_time()
            world.step(dt)
            acc["world steps"] += time.process_time() - t

    run.world = TimedWorld()
    navigation.Navigator.step = timed_step
    try:
        t0 = time.process_time()
        run.run()
        total = time.process_time() - t0
    finally:
        navigation.Navigator.step = step
    acc["rest"] = total - sum(acc.values())
    return {k: v / total for k, v in acc.items()}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=300.0, help="simulated seconds per run")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    before = load()
    rows = []
    for name, source, robots, robot in CASES:
        if name == "cumberland" and not Path(source).is_dir():
            print(f"skipping {name}: {source} not found")
            continue
        walls, cpus = [], []
        for k in range(args.repeats):
            wall, cpu, summary, preset = one(source, robots, robot, args.duration, seed=k)
            walls.append(wall)
            cpus.append(cpu)
            print(f"{name} N={robots} seed {k}: {args.duration / wall:.0f}x wall, "
                  f"{args.duration / cpu:.0f}x CPU, {summary['visits']} visits, "
                  f"{summary['unvisited_vertices']} unvisited, {summary['collisions']} contacts",
                  flush=True)
        rows.append((name, robots, preset, args.duration / statistics.median(walls),
                     args.duration / statistics.median(cpus), summary))
    split = cpu_split(CASES[0][1], CASES[0][2], min(args.duration, 200.0)) if rows and \
        rows[0][0] == "cumberland" else {}
    after = load()
    text = header("Physics runtime (tpuaf run --runtime physics)")
    text += (f"{args.duration:g} simulated s per run, {args.repeats} seeds, medians; 0.05 s "
             "physics steps, 10 Hz control, 5 Hz LDS-01 scans (runtimes/physics.py).\n"
             f"Machine load before: {before}; after: {after} (2 cores shared by other "
             "jobs: wall-clock figures are lower bounds).\n\n"
             "| map | N | robot | real-time factor (wall) | sim s per CPU s | visits (last) "
             "| contacts (last) |\n|---|---|---|---|---|---|---|\n")
    for name, robots, preset, rtf_wall, rtf_cpu, summary in rows:
        text += (f"| {name} | {robots} | {preset} | {rtf_wall:.0f}x | {rtf_cpu:.0f}x | "
                 f"{summary['visits']} | {summary['collisions']} |\n")
    if split:
        text += ("\nWhere the CPU goes (cumberland, N = 12): " + ", ".join(
            f"{k} {100 * v:.0f} %" for k, v in split.items()) + ".\n")
    text += ("\nReproduce: `.venv/bin/python benchmarks/bench_physics.py --duration "
             f"{args.duration:g} --repeats {args.repeats}`\n")
    write("physics.md", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
