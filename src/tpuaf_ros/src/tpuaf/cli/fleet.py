"""`tpuaf fleet`: one headless ROS experiment (simulator, N agents, monitor, rosbag) to completion.

This module is the command: its options (all checked before any ROS process starts: one-line
error, exit code 2), the run folder's input files (world, strategy parameters, fleet_config.yaml)
and roslaunch args, and the summary printed at the end. It runs tpuaf_ros/fleet.launch through
the devel or install space under its own roscore (`tpuaf.cli.fleet_supervisor`: the processes,
stopped only by PID, also on Ctrl-C), and shows a progress bar in simulated time from the
monitor's /fleet/metrics (`tpuaf.cli.fleet_ros`, the only rospy code of tpuaf.cli). Then it
checks the bag is closed and prints the monitor's summary.

Stepping (docs/FLEET.md): lock-step by default (the roscpp simulator advances one control tick
only once every live agent has answered the previous one; an agent silent for --lockstep-timeout
wall seconds is unresponsive: its robot stops, the run goes on, the summary counts it), paced
(`--no-lockstep --rtf X`) or free-running (`--no-lockstep --rtf 0`).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import re
import shlex
import shutil
import sys
import time
from pathlib import Path

from tpuaf.cli.fleet_supervisor import (
    free_port,  # noqa: F401 (tests/ros/conftest.py uses it)
    run_file_problems,
    supervise,
    wait_bag_closed,
)
from tpuaf.cli.run import (
    add_lanes,
    add_map_params,
    add_teammate_timeout,
    finite_float,
    format_summary,
    map_params,
    non_negative_float,
    parse_params,
    positive_float,
    probability,
    team_size,
)
from tpuaf.errors import CliError, TpuafError
from tpuaf.paths import catkin_prefix

# numpy, yaml, tpuaf.files and tpuaf.runtimes are imported where used: this module's
# add_arguments (the `tpuaf` parser) needs none of them.

LAUNCH = ("tpuaf_ros", "fleet.launch")  # found by roslaunch through the package
PREFIX = "robot_"

# What a fleet folder holds (the manifest: --overwrite removes these, nothing else); the
# monitor's ResultsWriter adds its own files.
FLEET_FILES = ("world.yaml", "strategy_params.yaml", "fleet_config.yaml", "fleet_timing.json",
               "roslaunch.log", "run.bag", "run.bag.active", "simulator.json",
               "world.resolved.yaml", "world.occupancy.pgm", "ros_home/")

# --record NAMES: topic groups added to the bag (the default bag holds what analysis needs).
RECORD_GROUPS = {
    "scans": r"/{p}[0-9]+/base_scan",
    "odom": r"/{p}[0-9]+/odom",
    "tf": r"/tf|/tf_static",
    "cmd_vel": r"/{p}[0-9]+/cmd_vel(_stamped)?",
    "stalled": r"/{p}[0-9]+/stalled",
    "agents": r"/team_agents/.*",
}
DEFAULT_RECORD = r"/clock|/fleet/.*|/team/.*|/{p}[0-9]+/base_pose_ground_truth"


def fault_spec(text: str) -> tuple[int, float]:
    """An argparse type: ROBOT@TIME (robot index >= 0, run time [s] >= 0), by the runtimes'
    parser (`tpuaf run --fail`), with the CLI's one message."""
    from tpuaf.runtimes.faults import FaultError, parse_fault

    try:
        return parse_fault(text)
    except FaultError:
        raise argparse.ArgumentTypeError(f"expected ROBOT@TIME (robot index >= 0, run time "
                                         f"[s] >= 0), got '{text}'") from None


rtf_float = finite_float(lambda v: v >= 0, "a real-time factor >= 0 (0 = as fast as possible)")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--map", default="grid", help="built-in map name or map folder path")
    p.add_argument("--strategy", default="tpuaf", help="strategy name (see tpuaf run --list)")
    p.add_argument("--robots", type=team_size, default=4, help="team size N")
    p.add_argument("--duration", type=positive_float, default=600.0,
                   help="simulated run time [s] (default 600)")
    p.add_argument("--seed", type=int, default=0, help="random seed")
    p.add_argument("--out", type=Path, required=True, help="run folder (results, bag, logs)")
    p.add_argument("--overwrite", action="store_true",
                   help="reuse a non-empty --out: remove the files tpuaf wrote there first")
    p.add_argument("--allow-occupied-vertices", action="store_true",
                   help="a vertex outside the image's free space is a warning, not an error")
    p.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                   help="strategy parameter (repeatable)")
    p.add_argument("--no-lockstep", dest="lockstep", action="store_false",
                   help="do not step in lock-step with the agents (paced with --rtf X, or "
                        "free-running with --rtf 0; results then depend on the machine's load)")
    p.add_argument("--lockstep-timeout", type=positive_float, default=5.0,
                   help="[s of wall time] an agent silent this long on a tick is unresponsive: "
                        "its robot stops, the run goes on (default 5: a 2 s limit was reached "
                        "once with 12 agents, a CPU hog and a load average of 19)")
    p.add_argument("--rtf", type=rtf_float, default=None,
                   help="pace the simulator at this real-time factor (0 = as fast as possible; "
                        "default: 0 in lock-step, 10 without)")
    p.add_argument("--robot", default="auto",
                   help="simulated robot preset: burger, waffle_pi, patrolling_sim, or auto "
                        "(default: a preset that drives the map's nominal speed, of the radius "
                        "closest to the map's; e.g. the 0.33 m, 1 m/s patrolling_sim robot for "
                        "1 m/s maps). A map speed above the preset's limit is capped at the "
                        "limit, and said so; a robot is never made faster than its preset")
    p.add_argument("--record", default="",
                   help="more topics in the bag: comma-separated groups (" +
                        ", ".join(RECORD_GROUPS) + ") or a topic regex (default: poses, events, "
                        "team messages, /clock)")
    p.add_argument("--no-record", action="store_true", help="no rosbag")
    p.add_argument("--fail", type=fault_spec, action="append", default=[], metavar="ROBOT@TIME",
                   help="kill robot ROBOT's agent process at run time TIME [s] (repeatable)")
    p.add_argument("--fail-random", type=int, default=0, metavar="K",
                   help="kill K random agents at random run times (seeded)")
    p.add_argument("--stall", type=fault_spec, action="append", default=[], metavar="ROBOT@TIME",
                   help="robot ROBOT stops moving at run time TIME [s]; its agent goes on")
    p.add_argument("--delay", type=non_negative_float, default=0.0,
                   help="[s of sim time] team message delay, through a relay (as tpuaf run)")
    p.add_argument("--loss", type=probability, default=0.0,
                   help="team message loss probability per recipient, through a relay")
    add_teammate_timeout(p)
    add_lanes(p, "every agent")
    add_map_params(p)
    p.add_argument("--timeout", type=positive_float, default=None,
                   help="wall-clock limit [s] (default: duration + 300)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--prepare-only", action="store_true",
                   help="write the run folder's input files and print the roslaunch command")


# ---------------------------------------------------------------------------------------------
# Options and the robot model


def record_regex(spec: str, prefix: str = PREFIX) -> str:
    """The rosbag -e regex: the default topics plus --record groups or a regex."""
    base = DEFAULT_RECORD.format(p=prefix)
    spec = spec.strip()
    if not spec:
        return base
    words = [w.strip() for w in spec.split(",") if w.strip()]
    if words and all(re.fullmatch(r"[a-z_]+", w) for w in words):
        unknown = [w for w in words if w not in RECORD_GROUPS and w != "all"]
        if unknown:
            raise CliError(f"--record: unknown group(s) {', '.join(unknown)} (known: all, "
                           f"{', '.join(RECORD_GROUPS)}; or give a topic regex)")
        groups = list(RECORD_GROUPS) if "all" in words else words
        return "|".join([base] + [RECORD_GROUPS[g].format(p=prefix) for g in groups])
    try:
        re.compile(spec)
    except re.error as err:
        raise CliError(f"--record: not a topic regex: '{spec}' ({err})") from None
    if "'" in spec:
        raise CliError("--record: a regex may not contain a single quote")
    return f"{base}|{spec}"


def check_options(args: argparse.Namespace) -> None:
    """Everything that can be checked before any ROS process starts (CliError, exit 2)."""
    if args.seed < 0 or args.seed > 2**31 - 1:
        raise CliError(f"--seed: expected an integer in 0 .. {2**31 - 1}, got {args.seed}")
    if args.rtf is None:
        args.rtf = 0.0 if args.lockstep else 10.0
    if args.fail_random < 0 or args.fail_random > args.robots:
        raise CliError(f"--fail-random: expected 0 .. {args.robots} robots, got "
                       f"{args.fail_random}")
    for option, items in (("--fail", args.fail), ("--stall", args.stall)):
        for robot, when in items:
            if robot >= args.robots:
                raise CliError(f"{option} {robot}@{when:g}: robot index not in 0..{args.robots - 1}")
            if when >= args.duration:
                raise CliError(f"{option} {robot}@{when:g}: time is not within the run "
                               f"(--duration {args.duration:g} s)")
    robots = [r for r, _ in args.fail]
    if len(set(robots)) != len(robots):
        raise CliError("--fail: each robot can die once")
    record_regex(args.record)


def fault_plan(args: argparse.Namespace) -> list[dict]:
    """Deaths and stalls in run-time order; --fail-random draws robots and times (seeded)."""
    faults = [{"kind": "death", "robot": r, "time_s": t} for r, t in args.fail]
    if args.fail_random:
        import numpy as np

        rng = np.random.default_rng([int(args.seed), 7])
        taken = {r for r, _ in args.fail}
        free = [r for r in range(args.robots) if r not in taken]
        k = min(args.fail_random, len(free))
        for r in rng.choice(free, size=k, replace=False):
            faults.append({"kind": "death", "robot": int(r),
                           "time_s": float(rng.uniform(0.1, 0.9) * args.duration)})
    faults += [{"kind": "stall", "robot": r, "time_s": t} for r, t in args.stall]
    return sorted(faults, key=lambda f: (f["time_s"], f["robot"]))


# ---------------------------------------------------------------------------------------------
# Run folder


def prepare(args: argparse.Namespace) -> tuple[list[str], dict]:
    """Write world.yaml (+ its resolved form for the simulator), strategy_params.yaml and
    fleet_config.yaml; the roslaunch args."""
    import yaml

    from tpuaf.robot.model import RobotChoiceError, choose_robot

    check_options(args)
    patrol_map, strategy, params = load_inputs(args)
    try:
        robot = choose_robot(args.robot, patrol_map.settings)
    except RobotChoiceError as err:
        raise CliError(str(err)) from None
    faults = fault_plan(args)
    from tpuaf.experiments.results_folder import prepare_out_dir, record_written
    from tpuaf.files import atomic_write_text
    from tpuaf.maps import builtin_map_names

    prepare_out_dir(args.out, overwrite=args.overwrite)  # a file, unwritable, earlier results
    out = args.out.expanduser().resolve()
    if not args.no_record:
        check_bag_space(out)
    record_written(out, *FLEET_FILES)
    map_ref = args.map if args.map in builtin_map_names() else str(Path(args.map).expanduser().resolve())
    world, resolved = write_world(args, out, map_ref, robot)
    given = parse_params(args.param)
    strategy_file = ""
    if given:
        strategy_file = str(out / "strategy_params.yaml")
        atomic_write_text(strategy_file, yaml.safe_dump(given, sort_keys=False))
    config = fleet_config(args, out, patrol_map, map_ref, strategy, params, world, robot, faults)
    atomic_write_text(out / "fleet_config.yaml", yaml.safe_dump(config, sort_keys=False))
    return roslaunch_args(args, out, config, resolved, strategy_file), config


# rosbag record stops recording (and exits 1) below 1 GiB free on the bag's disk.
ROSBAG_MIN_FREE_BYTES = 1 << 30


def check_bag_space(out: Path) -> None:
    """CliError before any ROS process starts when rosbag would refuse the bag's disk."""
    free = shutil.disk_usage(out).free
    if free < ROSBAG_MIN_FREE_BYTES:
        raise CliError(f"only {free / 2**20:.1f} MiB free on the disk of {out}: rosbag records "
                       "nothing with less than 1 GiB free (free some space, choose another "
                       "--out, or run with --no-record)")


def load_inputs(args: argparse.Namespace):
    """(the patrol map, the strategy's name, its parameters with the defaults), or CliError."""
    from tpuaf.maps import MapError, load_map
    from tpuaf.maps.params import CLI
    from tpuaf.policies import REGISTRY, ParameterError

    overrides = map_params(args)
    try:
        patrol_map = load_map(args.map, allow_occupied_vertices=args.allow_occupied_vertices,
                              params=overrides, params_origin=CLI)
        cls = REGISTRY.get(args.strategy)
        params = cls(parse_params(args.param)).params
    except (MapError, ParameterError) as err:
        raise CliError(str(err)) from None
    except KeyError as err:
        raise CliError(err.args[0]) from None
    return patrol_map, cls.name, params


def write_world(args: argparse.Namespace, out: Path, map_ref: str, robot) -> tuple[dict, Path]:
    """world.yaml of the simulator and its resolved form (CliError if it is not a world)."""
    import yaml
    from tpuaf_stage.resolve import write_resolved

    from tpuaf.files import atomic_write_text
    from tpuaf.robot.model import world_robot
    from tpuaf_stage.config import WorldError, parse_world

    world = {
        "patrol_map": map_ref,
        "seed": int(args.seed),
        # The preset as it is (radius and limits); only a slower map speed lowers the limit.
        "robot": world_robot(robot),
        "laser": {"preset": "lds01"},  # 5 Hz; control runs on the 10 Hz poses
        "robots": int(args.robots),
    }
    world_file = out / "world.yaml"
    atomic_write_text(world_file, yaml.safe_dump(world, sort_keys=False))
    try:
        return world, write_resolved(parse_world(world, world_file), out)
    except WorldError as err:
        raise CliError(str(err)) from None


def fleet_config(args, out: Path, patrol_map, map_ref: str, strategy: str, params: dict,
                 world: dict, robot, faults: list[dict]) -> dict:
    """fleet_config.yaml: what the monitor merges into the results' config.yaml."""
    from dataclasses import asdict

    from tpuaf.maps import start_vertices
    from tpuaf.maps.params import effective_params
    from tpuaf.params import resolve_lane_mode

    starts = start_vertices(patrol_map, args.robots)
    return {
        "runtime": "ros",
        "map": map_ref,
        "map_name": patrol_map.name,
        # `--map-param`: every node loads the map with them (launch arg map_params)
        "map_params": map_params(args),
        "map_settings": asdict(patrol_map.settings),
        "map_setting_sources": {k: p["source"] for k, p in effective_params(patrol_map).items()},
        "strategy": strategy,
        "robots": int(args.robots),
        "duration_s": float(args.duration),
        "seed": int(args.seed),
        "strategy_params": params,
        "start_vertices": [int(patrol_map.vertex_ids[v]) for v in starts],
        "simulator": {"world": world, "step_s": 0.01, "pose_rate_hz": 10.0,
                      "real_time_factor": args.rtf, "lockstep": bool(args.lockstep),
                      "lockstep_timeout_s": float(args.lockstep_timeout)},
        "robot": {**robot.describe(),
                  "map_nominal_speed_mps": float(patrol_map.settings.nominal_speed)},
        "faults": faults,
        "team_bus": {"delay_s": float(args.delay), "loss": float(args.loss),
                     "relay": uses_relay(args)},
        # agents and monitor alike (the monitor's death timeout follows it: one liveness rule)
        "teammate_timeout_s": float(args.teammate_timeout),
        "lanes": args.lanes,  # the agents' ~lanes; the mode they run (built-in navigation):
        "lane_mode": resolve_lane_mode(args.lanes, strategy),
        "navigation_module": "tpuaf.navigation (GraphRoute + LocalController)",
        "bag": None if args.no_record else str(out / "run.bag"),
        "record_regex": None if args.no_record else record_regex(args.record),
    }


def uses_relay(args: argparse.Namespace) -> bool:
    """Team messages go through the team_relay node when they are delayed or lost."""
    return args.delay > 0 or args.loss > 0


def roslaunch_args(args, out: Path, config: dict, resolved: Path, strategy_file: str) -> list[str]:
    """fleet.launch's args (name:=value) for this run."""
    stalls = ",".join(f"{f['robot']}@{f['time_s']:g}" for f in config["faults"]
                      if f["kind"] == "stall")
    robot = config["robot"]
    return [
        f"map:={config['map']}", f"strategy:={config['strategy']}", f"robots:={args.robots}",
        f"duration:={args.duration}", f"seed:={args.seed}",
        f"record:={'false' if args.no_record else 'true'}", f"out:={out}",
        f"world:={resolved}", f"rtf:={args.rtf}", f"strategy_params:={strategy_file or 'none'}",
        f"config_file:={out / 'fleet_config.yaml'}",
        f"lockstep:={'true' if args.lockstep else 'false'}",
        f"lockstep_timeout:={args.lockstep_timeout}",
        f"robot:={robot['preset']}",
        f"stall:={stalls or 'none'}", f"sim_summary:={out / 'simulator.json'}",
        f"record_regex:={config['record_regex'] or ''}",
        f"relay:={'true' if uses_relay(args) else 'false'}", f"delay:={args.delay}",
        f"loss:={args.loss}", f"teammate_timeout:={args.teammate_timeout}",
        f"lanes:={args.lanes}",
        f"map_params:={json.dumps(config['map_params'], separators=(', ', ': '))}",
    ]


def on_run_clock(summary: dict) -> dict:
    """The summary with the recovery times [s] on the run's clock (from its start), as the
    faults are given (--fail 1@30): the monitor stamps them on the ROS clock (one clock in
    the printed table, not two)."""
    start = summary.get("start_time_s")
    if summary.get("time_base") or not isinstance(start, int | float) or not start:
        return summary
    shown = dict(summary)
    shown["recovery"] = [{**r, "time_s": r["time_s"] - start}
                         if isinstance(r.get("time_s"), int | float) else r
                         for r in summary.get("recovery") or []]
    return shown




def write_json_atomic(path: Path, data: dict) -> None:
    from tpuaf.files import atomic_write

    atomic_write(path, json.dumps(data, indent=2))


# ---------------------------------------------------------------------------------------------
# The command


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
        print(f"{ros_env_sh} " + " ".join(shlex.quote(c) for c in cmd))
        return 0
    if config["robot"]["note"]:
        print(f"tpuaf fleet: note: {config['robot']['note']}", file=sys.stderr)
    home = out / "ros_home"
    home.mkdir(exist_ok=True)
    summary_path = out / "summary.json"
    sim_summary = out / "simulator.json"
    for stale in (summary_path, sim_summary):
        with contextlib.suppress(FileNotFoundError):
            stale.unlink()
    mode = ("lock-step" if args.lockstep else "paced" if args.rtf > 0 else "free-running")
    title = (f"{config['strategy']} on {config['map_name']}, N = {args.robots}, "
             f"{args.duration:g} s, {mode}")
    wall0 = time.monotonic()
    deaths = [f for f in config["faults"] if f["kind"] == "death"]
    deaths_done: list[dict] = []

    def follow(env, launch):
        from tpuaf.cli.fleet_ros import follow

        return follow(args, env, launch, deaths, deaths_done, PREFIX)

    # SIGTERM and SIGHUP (e.g. from `timeout`) clean up like Ctrl-C: tpuaf.cli.signals
    followed, interrupted = supervise(ros_env_sh, cmd, home, out / "roslaunch.log", follow)
    finished, sim_elapsed, wall_run = followed if followed is not None else (False, 0.0, 0.0)
    wall = time.monotonic() - wall0
    from tpuaf.experiments.run_files import write_summary

    bag = out / "run.bag"
    bag_ok = args.no_record or wait_bag_closed(bag)
    problems = run_file_problems(out, None if args.no_record else bag, bag_ok)
    if not summary_path.is_file():
        with contextlib.suppress(OSError, TpuafError):  # never a folder without a verdict
            write_summary(out, {"complete": False, "incomplete_files": [
                "the monitor wrote no summary.json", *problems]})
        raise CliError(f"the monitor wrote no summary (logs: {out / 'roslaunch.log'}, "
                       f"{home / 'log'})" + (f"; {', '.join(problems)}" if problems else ""))
    summary = json.loads(summary_path.read_text())
    rtf = add_fleet_facts(summary, read_simulator_summary(sim_summary), config, deaths_done,
                          mode, wall, wall_run if finished else 0.0)
    state = "finished" if finished else ("interrupted" if interrupted else "stopped early")
    try:
        write_json_atomic(out / "fleet_timing.json",
                          {"wall_total_s": wall, "wall_run_s": wall_run if finished else None,
                           "real_time_factor": rtf, "finished": finished,
                           "sim_elapsed_s": sim_elapsed})
    except OSError as err:
        problems.append(f"fleet_timing.json not written ({err.strerror or err})")
    write_fleet_summary(out, summary, problems)
    print(f"\n{title} ({state})")
    print_outcome(args, summary, config, rtf, wall, wall_run, out, bag, bag_ok)
    if problems:
        print(f"tpuaf fleet: error: the run's files are incomplete: {'; '.join(problems)} "
              "(summary.json says \"complete\": false)", file=sys.stderr)
    if interrupted:
        from tpuaf.cli import signals

        return signals.exit_code()
    if problems:
        return 2
    return 0 if finished and bag_ok else 1


def write_fleet_summary(out: Path, summary: dict, problems: list[str]) -> None:
    """summary.json, last: "complete" only when every file of the run was written and closed
    (else false, with `incomplete_files`); a full disk: one line (CliError, exit 2)."""
    from tpuaf.experiments.run_files import write_summary

    if problems:
        summary["complete"] = False
        summary["incomplete_files"] = problems
    try:
        write_summary(out, summary)
    except TpuafError as err:
        raise CliError(f"{err}" + (f"; the run's files are incomplete: {'; '.join(problems)}"
                                   if problems else "")) from None


def read_simulator_summary(path: Path) -> dict:
    """The simulator's events file ({} if missing or unreadable)."""
    sim = {}
    if path.is_file():
        with contextlib.suppress(ValueError):
            sim = json.loads(path.read_text())
    return sim


def add_fleet_facts(summary: dict, sim: dict, config: dict, deaths_done: list[dict], mode: str,
                    wall: float, wall_run: float) -> float | None:
    """Add to the monitor's summary what only the command knows (wall times, stepping, the
    simulator's unresponsive agents, the deaths injected, the robot model); wall_run: 0 unless
    the run finished. Returns the real-time factor of the run (None if unknown)."""
    summary["wall_time_s"] = wall
    rtf = summary.get("duration_s", 0.0) / wall_run if wall_run > 0 else None
    summary["real_time_factor"] = rtf
    summary["stepping"] = mode
    per_robot, before_start = count_unresponsive(summary, sim, {d["robot"] for d in deaths_done})
    summary["unresponsive_events"] = sum(per_robot)
    summary["unresponsive_per_robot"] = per_robot
    summary["unresponsive_events_before_start"] = before_start
    summary["simulator_events"] = sim.get("events", [])
    summary.setdefault("faults", config["faults"])
    summary["fleet_deaths_injected"] = deaths_done
    summary["robot_model"] = config["robot"]
    return rtf


def count_unresponsive(summary: dict, sim: dict, killed: set[int]) -> tuple[list[int], int]:
    """The simulator's unresponsive-agent events during the run, per robot, and the number
    before its start.

    A killed agent (--fail) goes silent: the simulator reports it unresponsive (roscpp keeps
    retrying its publisher link), but that is the injected death, not a slow agent. Only the
    run counts: a slow first answer while the agents start up (before the run start, e.g.
    under a CPU hog) is listed but not counted."""
    start_s = summary.get("start_time_s")
    end_s = None if start_s is None else start_s + summary.get("duration_s", 0.0)
    per_robot = [0] * len(sim.get("unresponsive_per_robot", []))
    before_start = 0
    for event in sim.get("events", []):
        robot, t = event.get("robot"), event.get("sim_time_s")
        if (event.get("event") != "unresponsive" or robot in killed or t is None
                or not 0 <= robot < len(per_robot)):
            continue
        if start_s is None or t < start_s:
            before_start += 1
        elif t <= end_s:
            per_robot[robot] += 1
    return per_robot, before_start


def print_outcome(args, summary: dict, config: dict, rtf: float | None, wall: float,
                  wall_run: float, out: Path, bag: Path, bag_ok: bool) -> None:
    """The summary table and the run's facts, after the title line."""
    print(format_summary(on_run_clock(summary)))
    if rtf:
        print(f"  simulated {summary['duration_s']:,.0f} s in {wall_run:.1f} s wall from the start "
              f"({rtf:.1f}x real time); {wall:.1f} s wall in all")
    print(f"  deaths: {summary.get('deaths', 0)} {summary.get('dead_robots', [])}")
    from tpuaf.cli.analyze import health_lines, outage_lines

    for line in outage_lines(summary) + health_lines(summary):
        print(f"  {line}")
    if args.lockstep:
        print(f"  lock-step: {summary['unresponsive_events']} unresponsive agent event(s)")
    if config["robot"]["note"]:
        print(f"  robot: {config['robot']['note']}")
    print(f"  results: {out}" + ("" if args.no_record else f"; bag: {bag}"
                                + ("" if bag_ok else " (NOT closed)")))
