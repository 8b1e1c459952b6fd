"""CPU of one patrol agent's control tick, without ROS: the work `patrol_agent` does per 10 Hz
pose tick (scan -> points when a new scan came, AgentRuntime.on_pose + tick) for 4 TPUAF robots
on grid, driven by the C++ world (laser at 5 Hz, as in `tpuaf fleet`), for several laser
subsamplings (agent ~scan_beams; 360 = no subsampling). Optional cProfile of the tick.
Prints a Markdown table (append it to benchmarks/results/fleet.md by hand when it changes).

    .venv/bin/python benchmarks/bench_agent.py [--seconds 300] [--profile]
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import time

import numpy as np
from tpuaf.maps import load_map
from tpuaf.navigation import ControllerConfig, Scan, scan_points
from tpuaf.policies import REGISTRY
from tpuaf.robot.model import choose_robot
from tpuaf.runtimes.agent import AgentRuntime

from tpuaf_stage.config import parse_world

STEP_S, TICK_S, SCAN_EVERY = 0.01, 0.1, 2  # physics step, control period, ticks per scan


def run(map_name: str, n: int, seconds: float, beams: int, profile: bool = False) -> dict:
    pm = load_map(map_name)
    robot = choose_robot("auto", pm.settings)
    world_cfg = parse_world({"patrol_map": map_name, "robots": n,
                             "robot": {"preset": robot.preset,
                                       "max_linear_speed": robot.speed_mps}})
    world = world_cfg.build()
    la = world_cfg.laser
    agents = []
    inbox: list = []
    for i in range(n):
        cfg = ControllerConfig(max_linear_speed=robot.speed_mps, robot_radius=robot.radius_m,
                               retry_wait_s=0.5 + 0.5 * (i % 4))
        rt = AgentRuntime(pm, REGISTRY.create("tpuaf", {}), i, n, 0, inbox.append,
                          lambda *a: None, cfg)
        agents.append(rt)
    points: list = [None] * n
    visits = 0
    cpu = 0.0
    prof = cProfile.Profile() if profile else None
    ticks = int(seconds / TICK_S)
    for k in range(ticks):
        t = k * TICK_S
        poses = world.poses()
        scans = world.scan_all() if k % SCAN_EVERY == 0 else None
        cmds = np.zeros((n, 2))
        c0 = time.process_time()
        if prof:
            prof.enable()
        for i, rt in enumerate(agents):
            if scans is not None:
                step = max(1, -(-la.beams // beams))
                points[i] = scan_points(Scan(scans[i][::step], la.first_angle,
                                             la.angle_increment * step, la.range_min,
                                             la.range_max))
            rt.on_pose(t, *poses[i])
            cmds[i] = rt.tick(t, points[i])
        while inbox:  # the team bus without delay or loss
            msg = inbox.pop()
            for j, other in enumerate(agents):
                if j != getattr(msg, "robot", -1):
                    other.on_message(msg)
        if prof:
            prof.disable()
        cpu += time.process_time() - c0
        world.set_commands(cmds)
        for _ in range(round(TICK_S / STEP_S)):
            world.step(STEP_S)
        visits = sum(len(getattr(rt, "visit_times", [])) for rt in agents)
    out = {"beams": beams, "ms_per_tick": 1000 * cpu / (ticks * n), "ticks": ticks * n,
           "visits": visits}
    if prof:
        pstats.Stats(prof).sort_stats("cumulative").print_stats(18)
    return out


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=300.0)
    ap.add_argument("--robots", type=int, default=4)
    ap.add_argument("--map", default="grid")
    ap.add_argument("--profile", action="store_true")
    args = ap.parse_args()
    rows = [run(args.map, args.robots, args.seconds, b) for b in (360, 180, 90)]
    print(f"| laser beams used (of 360) | agent CPU per tick ({args.map}, N = {args.robots}, "
          f"{args.seconds:g} s) |\n|---|---|")
    for r in rows:
        print(f"| {r['beams']} | {r['ms_per_tick']:.3f} ms |")
    if args.profile:
        run(args.map, args.robots, args.seconds, 180, profile=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
