"""Simulator speed: the core laser (rays/s on one core) and the tpuaf_stage node (real-time
factor with 12 robots on the imported cumberland map), medians over repetitions.

    .venv/bin/python benchmarks/bench_world.py [--quick] [--map PATH] [--out FILE]

Writes benchmarks/results/world.md (figures, configuration, machine state, date, commit).
Targets (issue 5): laser >= 20 million rays/s on one core; node >= 20x real time with 12 robots,
360-beam lasers at 10 Hz, both with no subscribers and with one subscriber per robot topic.
"""

from __future__ import annotations

import argparse
import datetime
import importlib.util
import os
import platform
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import write  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
CUMBERLAND = Path("/work/shared/maps/patrolling_sim/cumberland")
N_ROBOTS = 12
LASER = {"beams": 360, "rate": 10.0}  # on top of the default LDS-01-like laser (3.5 m)


def world_yaml(map_dir: Path, folder: Path, noise: bool = True) -> Path:
    path = folder / "bench_world.yaml"
    laser = dict(LASER, **({} if noise else {"noise_std": 0.0}))
    path.write_text(
        f"patrol_map: {map_dir}\nrobots: {N_ROBOTS}\nseed: 1\n"
        f"laser: {{{', '.join(f'{k}: {v}' for k, v in laser.items())}}}\n")
    return path


# --- core laser ---------------------------------------------------------------------------------


def bench_laser(map_dir: Path, reps: int, seconds: float) -> dict:
    from tpuaf_stage import load_world

    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for noise in (False, True):
            world = load_world(world_yaml(map_dir, Path(tmp), noise)).build()
            rays_per_call = world.num_robots * LASER["beams"]
            cpu_rates, wall_rates = [], []
            for _ in range(reps):
                calls = 0
                c0, w0 = time.thread_time(), time.perf_counter()
                while time.thread_time() - c0 < seconds:
                    world.scan_all()
                    calls += 1
                cpu, wall = time.thread_time() - c0, time.perf_counter() - w0
                cpu_rates.append(calls * rays_per_call / cpu)
                wall_rates.append(calls * rays_per_call / wall)
            scans = world.scan_all()
            key = "noise" if noise else "exact"
            out[key] = {
                "cpu_median": statistics.median(cpu_rates),
                "wall_median": statistics.median(wall_rates),
                "cpu_all": cpu_rates,
                "no_return_fraction": float(np.isinf(scans).mean()),
            }
        # Physics: steps per second with every robot driving an arc.
        world = load_world(world_yaml(map_dir, Path(tmp))).build()
        world.set_commands(np.tile([0.22, 0.5], (world.num_robots, 1)))
        c0, steps = time.thread_time(), 0
        while time.thread_time() - c0 < seconds:
            world.step(0.01)
            steps += 1
        out["physics_steps_per_s"] = steps / (time.thread_time() - c0)
    return out


# --- node ---------------------------------------------------------------------------------------

SUBSCRIBER = r"""
import sys, time
import rospy
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from rosgraph_msgs.msg import Clock
from tf2_msgs.msg import TFMessage
n, prefix, mode = int(sys.argv[1]), sys.argv[2], sys.argv[3]
rospy.init_node("bench_subscriber")
count = [0]
def cb(_msg):
    count[0] += 1
def cls(typed):  # raw: rospy.AnyMsg, no deserialisation (as rosbag record subscribes)
    return typed if mode == "typed" else rospy.AnyMsg
subs = []
for i in range(n):
    ns = f"{prefix}{i}"
    subs.append(rospy.Subscriber(ns + "/odom", cls(Odometry), cb, queue_size=100))
    subs.append(rospy.Subscriber(ns + "/base_pose_ground_truth", cls(Odometry), cb, queue_size=100))
    subs.append(rospy.Subscriber(ns + "/base_scan", cls(LaserScan), cb, queue_size=100))
subs.append(rospy.Subscriber("/tf", cls(TFMessage), cb, queue_size=100))
subs.append(rospy.Subscriber("/clock", cls(Clock), cb, queue_size=100))
print("subscribed", len(subs), flush=True)
while not rospy.is_shutdown():
    time.sleep(1.0)
    print("messages", count[0], flush=True)
"""


CASES = ("nosubs", "raw", "typed")  # no subscribers; raw (AnyMsg) or typed subscribers


def node_rtf(ros, world: Path, case: str, seconds: float, status_period: float) -> dict:
    name = f"stage_{case}_{time.monotonic_ns()}"
    sub = None
    if case != "nosubs":
        script = ros.home / "bench_subscriber.py"
        script.write_text(SUBSCRIBER)
        sub = ros.start([str(REPO / ".venv/bin/python"), str(script), str(N_ROBOTS), "robot_",
                         case], name=name + "_sub")
        time.sleep(2.0)  # the subscriber is up before the node starts
    node = ros.start(["rosrun", "tpuaf_stage", "tpuaf_stage", f"_world:={world}",
                      f"_status_period:={status_period}", f"__name:={name}"], name=name)
    time.sleep(seconds)
    log = ros.output(name)
    ros.stop(node)
    messages = None
    if sub is not None:
        counts = re.findall(r"messages (\d+)", ros.output(name + "_sub"))
        messages = int(counts[-1]) if counts else 0
        ros.stop(sub)
    rtfs = [float(x) for x in re.findall(r"real-time factor ([0-9.]+),", log)]
    if not rtfs:
        raise RuntimeError(f"no status lines from the node; its output:\n{log[-3000:]}")
    steady = rtfs[1:] if len(rtfs) > 2 else rtfs  # the first interval includes start-up
    return {"median": statistics.median(steady), "all": rtfs, "messages_received": messages}


def bench_node(map_dir: Path, reps: int, seconds: float, status_period: float) -> dict:
    sys.path.insert(0, str(REPO))  # the fixtures module is part of the tests package
    conftest = importlib.import_module("tests.ros.conftest")
    out = {case: [] for case in CASES}
    with tempfile.TemporaryDirectory() as tmp, conftest.ros_master(Path(tmp) / "ros") as ros:
        world = world_yaml(map_dir, Path(tmp))
        for _ in range(reps):
            for case in CASES:
                out[case].append(node_rtf(ros, world, case, seconds, status_period))
    for case in CASES:
        out[case + "_median"] = statistics.median(r["median"] for r in out[case])
    return out


# --- report -------------------------------------------------------------------------------------


def machine() -> dict:
    cpu = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    commit = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip() or "unknown"
    dirty = subprocess.run(["git", "-C", str(REPO), "status", "--porcelain", "--untracked-files=no"],
                           capture_output=True, text=True).stdout.strip()
    return {"cpu": cpu, "cores": os.cpu_count(), "load": os.getloadavg(),
            "python": platform.python_version(), "commit": commit + (" (dirty tree)" if dirty else ""),
            "date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")}


def report(laser: dict, node: dict | None, m: dict, args) -> str:
    lines = [
        "# Simulator speed (benchmarks/bench_world.py)",
        "",
        f"Date {m['date']}, commit {m['commit']}. Machine: {m['cpu']}, {m['cores']} cores, "
        f"load average at start {m['load'][0]:.2f} / {m['load'][1]:.2f} / {m['load'][2]:.2f}, "
        f"Python {m['python']}.",
        "",
        f"World: patrolling_sim cumberland imported from `{args.map}` (map_server image, "
        f"0.075 m cells), {N_ROBOTS} TurtleBot3 Burger-like robots at the map's start vertices, "
        "LDS-01-like lasers (360 beams, 0.12-3.5 m), laser at 10 Hz, odom/ground truth/tf at 10 Hz, "
        "/clock at 100 Hz, physics step 0.01 s.",
        "",
        "| figure | median | target |",
        "|---|---|---|",
        f"| core laser, rays/s on one core (thread CPU time), no noise | "
        f"{laser['exact']['cpu_median'] / 1e6:.1f} M | >= 20 M |",
        f"| core laser, best repetition (least disturbed by other load), no noise | "
        f"{max(laser['exact']['cpu_all']) / 1e6:.1f} M | |",
        f"| core laser, rays/s on one core (thread CPU time), 0.01 m noise | "
        f"{laser['noise']['cpu_median'] / 1e6:.1f} M | |",
        f"| core laser, rays/s by wall clock (shared machine), no noise | "
        f"{laser['exact']['wall_median'] / 1e6:.1f} M | |",
        f"| core physics, 12-robot steps/s (thread CPU time) | "
        f"{laser['physics_steps_per_s']:.0f} | |",
    ]
    if node is not None:
        lines += [
            f"| node, real-time factor, 12 robots, no subscribers | {node['nosubs_median']:.1f}x | "
            ">= 20x |",
            "| node, real-time factor, 12 robots, one raw subscriber per robot topic (+ /tf, "
            f"/clock) | {node['raw_median']:.1f}x | >= 20x |",
            "| node, real-time factor, 12 robots, one typed (deserialising) subscriber per robot "
            f"topic (+ /tf, /clock) | {node['typed_median']:.1f}x | |",
        ]
    lines += [
        "",
        f"Laser: {args.reps} repetitions of {args.seconds:.1f} s CPU time each; "
        f"{laser['exact']['no_return_fraction'] * 100:.0f}% of the beams have no return within "
        "3.5 m. Per repetition (M rays/s, CPU): "
        + ", ".join(f"{r / 1e6:.1f}" for r in laser["exact"]["cpu_all"]) + ".",
    ]
    if node is not None:
        lines += [
            "",
            f"Node: {args.node_reps} runs per case of {args.node_seconds:.0f} s wall time; the "
            f"real-time factor is the node's own status figure (simulated s per wall s over "
            f"{args.status_period:.0f} s windows, the first window dropped), median per run, "
            "then median of runs. Per run: no subscribers "
            + ", ".join(f"{r['median']:.1f}x" for r in node["nosubs"])
            + "; raw subscribers "
            + ", ".join(f"{r['median']:.1f}x" for r in node["raw"])
            + "; typed subscribers "
            + ", ".join(f"{r['median']:.1f}x" for r in node["typed"])
            + ". Subscribers: one rospy process (in a separate process, on the same 2 cores) "
            "subscribing to odom, base_pose_ground_truth and base_scan of every robot, /tf and "
            "/clock; raw = rospy.AnyMsg (no deserialisation, as `rosbag record` subscribes), "
            "typed = the message classes (messages received per run: raw "
            + ", ".join(str(r["messages_received"]) for r in node["raw"]) + "; typed "
            + ", ".join(str(r["messages_received"]) for r in node["typed"]) + ").",
        ]
    return "\n".join(lines) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--map", type=Path, default=CUMBERLAND, help="patrolling_sim map folder")
    ap.add_argument("--quick", action="store_true", help="fewer, shorter repetitions")
    ap.add_argument("--no-node", action="store_true", help="core figures only (no ROS)")
    ap.add_argument("--out", type=Path, default=REPO / "benchmarks/results/world.md")
    args = ap.parse_args()
    args.reps, args.seconds = (3, 0.5) if args.quick else (9, 1.0)
    args.node_reps, args.node_seconds = (1, 12.0) if args.quick else (3, 24.0)
    args.status_period = 3.0
    m = machine()
    print(f"laser: {args.reps} x {args.seconds} s ...", flush=True)
    laser = bench_laser(args.map, args.reps, args.seconds)
    print(f"  rays/s (CPU): exact {laser['exact']['cpu_median'] / 1e6:.1f} M, "
          f"with noise {laser['noise']['cpu_median'] / 1e6:.1f} M; wall "
          f"{laser['exact']['wall_median'] / 1e6:.1f} M", flush=True)
    node = None
    if not args.no_node:
        print(f"node: {args.node_reps} x {args.node_seconds} s per case ...", flush=True)
        node = bench_node(args.map, args.node_reps, args.node_seconds, args.status_period)
        print(f"  real-time factor, 12 robots: no subscribers {node['nosubs_median']:.1f}x, "
              f"raw subscribers {node['raw_median']:.1f}x, typed subscribers "
              f"{node['typed_median']:.1f}x", flush=True)
    text = report(laser, node, m, args)
    write(args.out.resolve(), text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
