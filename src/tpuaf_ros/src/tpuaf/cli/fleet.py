"""`tpuaf fleet`: one headless ROS experiment (simulator, N agents, monitor, rosbag) to completion.

It starts its own roscore on a free port (ROS_HOME under the run folder, ROS_IP=127.0.0.1),
runs launch_scripts/fleet.launch through the devel space, shows a progress bar in simulated time
(from the monitor's /fleet/metrics), and stops only the processes it started, by PID: SIGINT to
roslaunch (which stops its nodes; rosbag closes the bag), wait, then SIGTERM/SIGKILL; the same
on Ctrl-C. Then it checks the bag is closed and prints the monitor's summary.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import yaml

from ..errors import CliError
from ..paths import catkin_prefix
from ..topics import METRICS_TOPIC
from .run import format_summary, parse_params, positive_float, positive_int

LAUNCH = ("tpuaf_ros", "fleet.launch")  # found by roslaunch through the package


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--map", default="grid", help="built-in map name or map folder path")
    p.add_argument("--strategy", default="tpuaf", help="strategy name (see tpuaf run --list)")
    p.add_argument("--robots", type=positive_int, default=4, help="team size N")
    p.add_argument("--duration", type=positive_float, default=600.0,
                   help="simulated run time [s] (default 600)")
    p.add_argument("--seed", type=int, default=0, help="random seed")
    p.add_argument("--out", type=Path, required=True, help="run folder (results, bag, logs)")
    p.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                   help="strategy parameter (repeatable)")
    p.add_argument("--rtf", type=float, default=10.0,
                   help="pace the simulator at this real-time factor (default 10; 0 = as fast as "
                        "possible, which outruns the Python agents: see docs/FLEET.md)")
    p.add_argument("--robot", default="burger",
                   help="simulated robot preset (burger, waffle_pi, patrolling_sim); its speed "
                        "is raised to the map's nominal speed so that batch and fleet compare")
    p.add_argument("--no-record", action="store_true", help="no rosbag")
    p.add_argument("--timeout", type=positive_float, default=None,
                   help="wall-clock limit [s] (default: duration + 300)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--prepare-only", action="store_true",
                   help="write the run folder's input files and print the roslaunch command")


# ---------------------------------------------------------------------------------------------
# Run folder


def prepare(args: argparse.Namespace) -> tuple[list[str], dict]:
    """Write world.yaml, strategy_params.yaml and fleet_config.yaml; the roslaunch args."""
    from ..maps import MapError, builtin_map_names, load_map, start_vertices
    from ..policies import REGISTRY, ParameterError

    try:
        patrol_map = load_map(args.map)
        cls = REGISTRY.get(args.strategy)
        params = cls(parse_params(args.param)).params
    except (MapError, ParameterError) as err:
        raise CliError(str(err)) from None
    except KeyError as err:
        raise CliError(err.args[0]) from None
    out = args.out.expanduser().resolve()
    out.mkdir(parents=True, exist_ok=True)
    map_ref = args.map if args.map in builtin_map_names() else str(Path(args.map).expanduser().resolve())
    s = patrol_map.settings
    world = {
        "patrol_map": map_ref,
        "seed": int(args.seed),
        "robot": {"preset": args.robot, "radius": float(s.robot_radius),
                  "max_linear_speed": float(s.nominal_speed)},
        "laser": {"preset": "lds01"},  # 5 Hz; control runs on the 10 Hz poses
        "robots": int(args.robots),
    }
    (out / "world.yaml").write_text(yaml.safe_dump(world, sort_keys=False))
    given = parse_params(args.param)
    strategy_file = ""
    if given:
        strategy_file = str(out / "strategy_params.yaml")
        Path(strategy_file).write_text(yaml.safe_dump(given, sort_keys=False))
    starts = start_vertices(patrol_map, args.robots)
    config = {
        "runtime": "ros",
        "map": map_ref,
        "map_name": patrol_map.name,
        "strategy": cls.name,
        "robots": int(args.robots),
        "duration_s": float(args.duration),
        "seed": int(args.seed),
        "strategy_params": params,
        "start_vertices": [int(patrol_map.vertex_ids[v]) for v in starts],
        "simulator": {"world": world, "step_s": 0.01, "pose_rate_hz": 10.0,
                      "real_time_factor": args.rtf},
        "navigation_module": "tpuaf.navigation (GraphRoute + LocalController)",
        "bag": None if args.no_record else str(out / "run.bag"),
    }
    (out / "fleet_config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    launch_args = [
        f"map:={map_ref}", f"strategy:={cls.name}", f"robots:={args.robots}",
        f"duration:={args.duration}", f"seed:={args.seed}",
        f"record:={'false' if args.no_record else 'true'}", f"out:={out}",
        f"rtf:={args.rtf}", f"strategy_params:={strategy_file}",
        f"config_file:={out / 'fleet_config.yaml'}",
    ]
    return launch_args, config


# ---------------------------------------------------------------------------------------------
# Processes


def free_port() -> int:
    while True:
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        if port != 11311:
            return port


def ros_env(port: int, home: Path) -> dict[str, str]:
    env = dict(os.environ)
    env.pop("ROS_HOSTNAME", None)
    env.update({"ROS_MASTER_URI": f"http://127.0.0.1:{port}/", "ROS_HOME": str(home),
                "ROS_LOG_DIR": str(home / "log"), "ROS_IP": "127.0.0.1",
                "PYTHONUNBUFFERED": "1", "PATH": "/usr/bin:/bin:" + env.get("PATH", "")})
    return env


def start(cmd: list[str], env: dict, log: Path) -> subprocess.Popen:
    f = open(log, "wb")  # noqa: SIM115 - the child keeps it
    return subprocess.Popen(cmd, env=env, stdout=f, stderr=subprocess.STDOUT,
                            stdin=subprocess.DEVNULL, start_new_session=True)


def stop(proc: subprocess.Popen, grace_s: float = 20.0) -> None:
    """SIGINT to the process (group we created), wait, then SIGTERM, then SIGKILL."""
    for sig, wait in ((signal.SIGINT, grace_s), (signal.SIGTERM, 5.0), (signal.SIGKILL, 5.0)):
        if proc.poll() is not None:
            return
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, sig)
        try:
            proc.wait(wait)
            return
        except subprocess.TimeoutExpired:
            continue


def master_up(port: int) -> bool:
    import xmlrpc.client

    try:
        code, _, _ = xmlrpc.client.ServerProxy(f"http://127.0.0.1:{port}/").getSystemState("/x")
        return code == 1
    except (OSError, xmlrpc.client.Error):
        return False


def wait_bag_closed(bag: Path, timeout_s: float = 30.0) -> bool:
    """True once run.bag exists and no run.bag.active remains (the recorder closed it)."""
    active = bag.with_name(bag.name + ".active")
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if bag.is_file() and not active.exists():
            return True
        time.sleep(0.2)
    return False


# ---------------------------------------------------------------------------------------------


def run(args: argparse.Namespace) -> int:
    launch_args, config = prepare(args)
    out = args.out.expanduser().resolve()
    cmd = ["roslaunch", "--wait", *LAUNCH, *launch_args]
    prefix = catkin_prefix()
    if prefix is None:
        raise CliError("tpuaf is not in a catkin devel or install space: build the workspace "
                       "(bash launch_scripts/setup.sh)")
    ros_env_sh = prefix / "env.sh"
    if args.prepare_only:
        print(f"{ros_env_sh} " + " ".join(cmd))
        return 0
    home = out / "ros_home"
    home.mkdir(exist_ok=True)
    port = free_port()
    env = ros_env(port, home)
    procs: list[subprocess.Popen] = []
    summary_path = out / "summary.json"
    with contextlib.suppress(FileNotFoundError):
        summary_path.unlink()
    # SIGTERM (e.g. from `timeout`) cleans up like Ctrl-C.
    signal.signal(signal.SIGTERM, lambda *_: (_ for _ in ()).throw(KeyboardInterrupt()))
    title = f"{config['strategy']} on {config['map_name']}, N = {args.robots}, {args.duration:g} s"
    wall0 = time.monotonic()
    interrupted = False
    finished = False
    sim_elapsed = 0.0
    try:
        core = start([str(ros_env_sh), "roscore", "-p", str(port)], env, home / "roscore.log")
        procs.append(core)
        deadline = time.monotonic() + 30
        while not master_up(port):
            if core.poll() is not None or time.monotonic() > deadline:
                raise CliError(f"roscore did not start (log: {home / 'roscore.log'})")
            time.sleep(0.1)
        launch = start([str(ros_env_sh), *cmd], env, out / "roslaunch.log")
        procs.append(launch)
        finished, sim_elapsed, wall_run = follow(args, env, launch, out)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        for proc in reversed(procs):
            stop(proc)
    wall = time.monotonic() - wall0
    bag = out / "run.bag"
    bag_ok = args.no_record or wait_bag_closed(bag)
    if not summary_path.is_file():
        raise CliError(f"the monitor wrote no summary (logs: {out / 'roslaunch.log'}, "
                       f"{home / 'log'})")
    summary = json.loads(summary_path.read_text())
    summary["wall_time_s"] = wall
    rtf = summary.get("duration_s", 0.0) / wall_run if finished and wall_run > 0 else None
    state = "finished" if finished else ("interrupted" if interrupted else "stopped early")
    print(f"\n{title} ({state})")
    print(format_summary(summary))
    if rtf:
        print(f"  simulated {summary['duration_s']:,.0f} s in {wall_run:.1f} s wall from the start "
              f"({rtf:.1f}x real time); {wall:.1f} s wall in all")
    print(f"  deaths: {summary.get('deaths', 0)}")
    print(f"  results: {out}" + ("" if args.no_record else f"; bag: {bag}"
                                + ("" if bag_ok else " (NOT closed)")))
    with open(out / "fleet_timing.json", "w") as f:
        json.dump({"wall_total_s": wall, "wall_run_s": wall_run if finished else None,
                   "real_time_factor": rtf, "finished": finished,
                   "sim_elapsed_s": sim_elapsed}, f, indent=2)
    if interrupted:
        return 130
    return 0 if finished and bag_ok else 1


def follow(args, env, launch, out) -> tuple[bool, float, float]:
    """Follow /fleet/metrics with a progress bar until finished, roslaunch died or timeout.
    Returns (finished, elapsed sim s, wall s from the run's start to its end)."""
    os.environ.update({k: env[k] for k in ("ROS_MASTER_URI", "ROS_IP", "ROS_HOME", "ROS_LOG_DIR")})
    import rospy
    from tqdm import tqdm

    from tpuaf_ros.msg import LiveMetrics

    state = {"elapsed": 0.0, "finished": False, "t_first": None, "t_last": None}

    def on_metrics(msg):
        now = time.monotonic()
        if state["t_first"] is None:
            state["t_first"] = now - 0.0
            state["e_first"] = msg.elapsed
        state["elapsed"] = msg.elapsed
        state["t_last"] = now
        if msg.finished:
            state["finished"] = True

    rospy.init_node("tpuaf_fleet_cli", anonymous=True, disable_signals=True)
    rospy.Subscriber(METRICS_TOPIC, LiveMetrics, on_metrics, queue_size=10)
    bar = tqdm(total=args.duration, unit="sim s", disable=args.quiet, desc=args.strategy,
               bar_format="{l_bar}{bar}| {n:.0f}/{total:.0f} sim s [{elapsed}<{remaining}]",
               file=sys.stderr)
    timeout = args.timeout if args.timeout else args.duration + 300.0
    t0 = time.monotonic()
    try:
        while not state["finished"]:
            if launch.poll() is not None:
                break
            if time.monotonic() - t0 > timeout:
                print(f"tpuaf fleet: wall-clock limit of {timeout:g} s reached", file=sys.stderr)
                break
            bar.update(state["elapsed"] - bar.n)
            time.sleep(0.2)
        bar.update(state["elapsed"] - bar.n)
    finally:
        bar.close()
        if state["finished"]:
            time.sleep(1.0)  # let rosbag write the last messages
        rospy.signal_shutdown("tpuaf fleet done")
    wall_run = 0.0
    if state["t_first"] is not None:
        # metrics start at elapsed ~0: wall time per simulated second from first to last message
        span = state["elapsed"] - state["e_first"]
        wall = state["t_last"] - state["t_first"]
        wall_run = wall * args.duration / span if span > 0 else 0.0
    return state["finished"], state["elapsed"], wall_run
