"""Edge travel times: the model (tpuaf.navigation.travel_time) against the physics runtime.

One robot drives a random walk over the edges of each map (at each vertex reached, the next
goal is a random neighbour, not the one it came from unless a dead end) with the physics
runtime's own parts: the C++ world (robot preset, LDS-01 laser, 0.05 s steps), the agent's
Navigator + LocalController at 10 Hz along the planner's edge paths. A traversal's measured
duration is the time between reaching one vertex (within the goal tolerance) and reaching the
next. Per map and robot: edges measured, median measured/model ratio, and the median edge's
error |model - measured| / measured (per edge the median of its traversals), for the model and
for the plain planned length / speed.

    .venv/bin/python benchmarks/bench_travel_time.py [--maps a,b] [--duration S] [--quick]
        [--robots auto,burger]

Writes benchmarks/results/travel_time.md and .json. Target: the model within 10 % of physics
on the median edge of every map.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from common import RESULTS, header, write

PS = Path("/work/shared/maps/patrolling_sim")
MAPS = ["1r5", "DIAG_labs", "ctcv", "cumberland", "example", "grid", "lab", "builtin:grid"]
ROBOTS = ["auto", "burger"]
TARGET = 0.10  # model error on the median edge


def load(name: str):
    from tpuaf.maps import load_map

    if name == "lab":
        return load_map("lab")
    if name.startswith("builtin:"):
        return load_map(name.split(":", 1)[1])
    return load_map(PS / name)


def robot_for(name: str, patrol_map):
    """(preset, cruise speed [m/s]) of robot `name` ('auto': the runtime's choice)."""
    from tpuaf.robot.model import choose_robot

    choice = choose_robot(name, patrol_map.settings, env={})
    return choice.preset, float(choice.speed_mps)


def walk(patrol_map, preset: str, speed_mps: float, duration_s: float, seed: int = 0,
         start: int | None = None, route: list[int] | None = None) -> list[tuple[int, int, float]]:
    """Drive one robot for `duration_s` [s] of simulated time on a random walk (or along the
    vertex list `route`, then stop); returns the traversals (u, v, seconds) between vertices
    reached in turn (the first, from the start pose, left out)."""
    from tpuaf.maps import start_poses, start_vertices
    from tpuaf.navigation import (
        ControllerConfig,
        Event,
        GraphRoute,
        LaserMount,
        LocalController,
        Navigator,
        moved_points,
        retry_wait_for,
        scan_points_batch,
    )
    from tpuaf.navigation.controller import CONTROL_PERIOD_S, PHYSICS_STEP_S
    from tpuaf.navigation.planner import shared_planner
    from tpuaf_stage.presets import ROBOT_PRESETS

    from tpuaf_stage.config import WorldConfig, parse_laser, parse_robot

    pm = patrol_map
    preset_name, model = parse_robot(None, {"preset": preset, "max_linear_speed": speed_mps})
    laser_name, laser = parse_laser(None, {"preset": "lds01"})
    first = route[0] if route else (start if start is not None else start_vertices(pm, 1)[0])
    grid = pm.occupancy_grid()
    world = WorldConfig(source=None, occupied=np.asarray(grid.occupied, dtype=bool),
                        resolution=float(grid.resolution),
                        origin=(float(grid.origin[0]), float(grid.origin[1])), robot=model,
                        laser=laser, poses=start_poses(pm, 1, model.radius, [first]), seed=seed,
                        map_description=pm.name, robot_preset=preset_name,
                        laser_preset=laser_name).build()
    planner = shared_planner(pm, model.radius)
    cfg = ControllerConfig(max_linear_speed=speed_mps,
                           max_angular_speed=float(ROBOT_PRESETS[preset]["max_angular_speed"]),
                           robot_radius=model.radius, retry_wait_s=retry_wait_for(0))
    nav = Navigator(LocalController(cfg), pm.visit_radius_m, 0.6, planner)  # as the agents
    positions = np.asarray(pm.positions, dtype=float)
    graph = pm.graph
    nbrs: dict[int, list[int]] = {i: [] for i in range(pm.num_vertices)}
    for i, j, _ in pm.edges:
        nbrs[int(i)].append(int(j))
        nbrs[int(j)].append(int(i))
    rng = np.random.default_rng(seed)
    mount = LaserMount(laser.x, laser.y, laser.yaw)
    scan_every = max(1, round(1.0 / (laser.rate * CONTROL_PERIOD_S)))
    steps = round(CONTROL_PERIOD_S / PHYSICS_STEP_S)
    plan = list(route[1:]) if route else None
    state = {"at": first, "prev": None, "since": None}
    out: list[tuple[int, int, float]] = []

    def next_goal() -> int | None:
        if plan is not None:
            return plan.pop(0) if plan else None
        options = [v for v in nbrs[state["at"]] if v != state["prev"]] or nbrs[state["at"]]
        return int(options[rng.integers(len(options))])

    def go(t: float, pose) -> bool:
        goal = next_goal()
        if goal is None:
            return False
        nav.set_route(GraphRoute(graph, positions, state["at"], goal, from_position=pose[:2],
                                 snap_m=nav.waypoint_tolerance), t)
        return True

    pose = tuple(np.asarray(world.poses(), dtype=float)[0])
    go(0.0, pose)
    points = scan_pose = None
    for k in range(int(duration_s / CONTROL_PERIOD_S)):
        t = k * CONTROL_PERIOD_S
        pose = tuple(float(c) for c in np.asarray(world.poses(), dtype=float)[0])
        if k % scan_every == 0:
            points = scan_points_batch(np.asarray(world.scan_all(), dtype=float),
                                       laser.first_angle, laser.angle_increment, laser.range_min,
                                       laser.range_max, mount,
                                       within_m=nav.controller.reach_m)[0]
            scan_pose = pose
        pts = moved_points(points, scan_pose, pose)
        v = w = 0.0
        for _ in range(4):
            if nav.route is None:
                break
            cmd, event, vertex = nav.step(t, pose, pts)
            v, w = cmd.v, cmd.w
            if event == Event.ARRIVED:
                # (a vertex reached in the same tick as the last one was not driven to)
                if (state["since"] is not None and vertex in nbrs[state["at"]]
                        and t > state["since"]):
                    out.append((state["at"], int(vertex), t - state["since"]))
                state.update(prev=state["at"], at=int(vertex), since=t)
                if not go(t, pose):
                    v = w = 0.0
                    break
                continue
            if event == Event.FAILED:  # start again from the nearest vertex, unmeasured
                state.update(prev=None, at=pm.nearest_vertex(*pose[:2]), since=None)
                go(t, pose)
            break
        if nav.route is None and plan is not None and not plan:
            break
        world.set_commands(np.array([[v, w]]))
        for _ in range(steps):
            world.step(PHYSICS_STEP_S)
    return out


def evaluate(name: str, robot: str, duration_s: float, seed: int = 0) -> dict:
    from tpuaf.navigation.planner import shared_planner
    from tpuaf.navigation.route import polyline_length
    from tpuaf.navigation.travel_time import RobotKinematics, directed_durations

    pm = load(name)
    preset, speed = robot_for(robot, pm)
    kin = RobotKinematics.from_preset(preset, speed)
    planner = shared_planner(pm, kin.radius_m)
    w0 = time.perf_counter()
    directed = directed_durations(pm, kin, planner)
    model_wall = time.perf_counter() - w0
    w0 = time.perf_counter()
    traversals = walk(pm, preset, speed, duration_s, seed)
    wall = time.perf_counter() - w0
    # Undirected edges (the consumers' figure: the mean of both directions), and directed.
    samples: dict[tuple[int, int], list[float]] = {}
    one_way: dict[tuple[int, int], list[float]] = {}
    for u, v, s in traversals:
        samples.setdefault((min(u, v), max(u, v)), []).append(s)
        one_way.setdefault((u, v), []).append(s)
    rows = []
    for (u, v), times in sorted(samples.items()):
        # the mean of the two directions' medians, as the model's (one direction: that one)
        ways = [w for w in ((u, v), (v, u)) if w in one_way]
        measured = statistics.fmean(statistics.median(one_way[w]) for w in ways)
        model = statistics.fmean(directed[w] for w in ways)
        plain = polyline_length(planner.edge_path(u, v)) / speed
        rows.append({"u": int(pm.vertex_ids[u]), "v": int(pm.vertex_ids[v]), "n": len(times),
                     "measured_s": measured, "model_s": model, "plain_s": plain})
    err = [abs(r["model_s"] - r["measured_s"]) / r["measured_s"] for r in rows]
    err_plain = [abs(r["plain_s"] - r["measured_s"]) / r["measured_s"] for r in rows]
    ratio = [r["measured_s"] / r["model_s"] for r in rows]
    err_dir = [abs(directed[e] - statistics.median(t)) / statistics.median(t)
               for e, t in one_way.items()]
    nan = math.nan
    return {"map": name, "robot": robot, "preset": preset, "speed_mps": speed,
            "edges": len(pm.edges), "edges_measured": len(rows),
            "traversals": len(traversals), "sim_s": duration_s, "wall_s": wall,
            "model_wall_s": model_wall,
            "median_ratio": statistics.median(ratio) if rows else nan,
            "median_error": statistics.median(err) if rows else nan,
            "median_error_plain": statistics.median(err_plain) if rows else nan,
            "median_error_directed": statistics.median(err_dir) if err_dir else nan,
            "total_ratio": (sum(r["measured_s"] for r in rows) / sum(r["model_s"] for r in rows)
                            if rows else nan),
            "rows": rows}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--maps", default=",".join(MAPS),
                    help="comma-separated: patrolling_sim names, lab, builtin:grid")
    ap.add_argument("--robots", default=",".join(ROBOTS), help="auto and/or presets")
    ap.add_argument("--duration", type=float, default=3000.0, help="simulated s per map and robot")
    ap.add_argument("--quick", action="store_true", help="300 s per map and robot, no files")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    duration = min(300.0, args.duration) if args.quick else args.duration
    results = []
    t0 = time.perf_counter()
    for name in [m for m in args.maps.split(",") if m]:
        for robot in [r for r in args.robots.split(",") if r]:
            r = evaluate(name, robot, duration, args.seed)
            results.append(r)
            print(f"{name:12s} {robot:7s} {r['preset']:14s} edges {r['edges_measured']:3d}/"
                  f"{r['edges']:3d} ratio {r['median_ratio']:.3f} err {r['median_error']:.3f} "
                  f"plain {r['median_error_plain']:.3f} ({r['wall_s']:.0f} s wall)",
                  file=sys.stderr, flush=True)
    lines = [header("Edge travel times: model vs physics"),
             f"One robot, random walk over edges (no immediate way back), {duration:g} s "
             f"simulated per map and robot, seed {args.seed}; {time.perf_counter() - t0:.0f} s "
             "wall in all. Per edge the mean of its two directions' median traversals (one "
             "direction measured: that one), against the model's figure for the same; `ratio` = median over edges "
             "of measured / model; `error` = median over edges of |model - measured| / "
             "measured; `plain` = the same error of planned length / speed; `directed`: the "
             "model's error per direction of travel; `all edges`: sum of measured / sum of "
             "model; `model [s]`: wall time of the model for the whole map. Target: error "
             f"<= {TARGET:.0%} on every map.\n",
             "| map | robot | preset | v [m/s] | edges measured | traversals | ratio | error "
             "| plain error | error, directed | measured/model, all edges | model [s] |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        lines.append(f"| {r['map']} | {r['robot']} | {r['preset']} | {r['speed_mps']:g} | "
                     f"{r['edges_measured']}/{r['edges']} | {r['traversals']} | "
                     f"{r['median_ratio']:.3f} | {r['median_error']:.1%} | "
                     f"{r['median_error_plain']:.1%} | {r['median_error_directed']:.1%} | "
                     f"{r['total_ratio']:.3f} | {r['model_wall_s']:.2f} |")
    ok = all(r["median_error"] <= TARGET for r in results if r["edges_measured"])
    lines.append(f"\nTarget met on every map: {'yes' if ok else 'no'}.\n")
    text = "\n".join(lines)
    if args.quick:
        print(text)
    else:
        write("travel_time.md", text)
        (RESULTS / "travel_time.json").write_text(json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
