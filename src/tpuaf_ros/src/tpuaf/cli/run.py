"""`tpuaf run`: one batch run with a progress bar, a results folder and a summary table."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from tpuaf.errors import CliError

# Imported by tpuaf.cli before the run's stop handling (see _main).
PRELOAD = ("numpy", "tpuaf_core", "tpuaf.maps", "tpuaf.policies", "tpuaf.runtimes.config",
           "tpuaf.runtimes.faults", "tpuaf.runtimes.graph")


def _int_at_least(lowest: int):
    """An argparse type: an integer >= lowest, else 'expected an integer >= lowest'."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected an integer >= {lowest}, got '{text}'") from None
        if value < lowest:
            raise argparse.ArgumentTypeError(f"expected an integer >= {lowest}, got {value}")
        return value

    return parse


positive_int = _int_at_least(1)
non_negative_int = _int_at_least(0)


def finite_float(condition, wanted: str):
    """An argparse type: a finite float for which `condition` holds, else 'expected <wanted>'."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {wanted}, got '{text}'") from None
        if not (math.isfinite(value) and condition(value)):
            raise argparse.ArgumentTypeError(f"expected {wanted}, got {text}")
        return value

    return parse


MAX_SEED = 2**31 - 1  # seeds travel as ROS parameters (XML-RPC int32) in fleets
# Team size: every strategy runs a team of this size on this machine (24 GB; cli/limits.py
# refuses, before allocating, a team whose memory would not fit). The paper's teams: 1-12.
MAX_ROBOTS = 1_000


def team_size(text: str) -> int:
    """An argparse type: a team size 1 .. MAX_ROBOTS."""
    value = positive_int(text)
    if value > MAX_ROBOTS:
        raise argparse.ArgumentTypeError(f"expected a team size in 1 .. {MAX_ROBOTS}, got {value}")
    return value


def seed_int(text: str) -> int:
    """An argparse type: a seed 0 .. 2^31 - 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer seed >= 0, got '{text}'") from None
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"expected a seed in 0 .. {MAX_SEED}, got {value}")
    return value


def folder_path(text: str) -> Path:
    """An argparse type: a non-empty path ('' would be the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a folder path, got ''")
    return Path(text)


positive_float = finite_float(lambda v: v > 0, "a finite number > 0")
non_negative_float = finite_float(lambda v: v >= 0, "a finite number >= 0")
probability = finite_float(lambda v: 0 <= v <= 1, "a probability in [0, 1]")


def add_teammate_timeout(p: argparse.ArgumentParser) -> None:
    """--teammate-timeout SECONDS (`tpuaf run`, `compare`, `fleet`): the one liveness rule's
    timeout, default tpuaf.params.LIVENESS_DEFAULTS (docs/FLEET.md)."""
    from tpuaf.params import LIVENESS_DEFAULTS

    default = LIVENESS_DEFAULTS.teammate_timeout_s
    p.add_argument("--teammate-timeout", type=positive_float, default=default, metavar="SECONDS",
                   help=f"[s] a teammate silent this long (no heartbeat, no message) is lost: "
                        f"the others drop its intentions and share out its work; a fleet's "
                        f"monitor calls it dead then too (default {default:g})")


def add_lanes(p: argparse.ArgumentParser, where: str) -> None:
    """--lanes MODE (`tpuaf run --runtime physics`, `fleet`): the lane layer (docs/LANES.md),
    modes and default from tpuaf.params.LANE_MODES."""
    from tpuaf.params import AUTO_LANES_OFF_STRATEGIES, LANE_DEFAULT, LANE_MODES

    p.add_argument("--lanes", choices=LANE_MODES, default=LANE_DEFAULT,
                   help=f"lane layer for aisles one robot wide ({where}): auto (default: "
                        f"one_way, off for {', '.join(AUTO_LANES_OFF_STRATEGIES)} and for "
                        "the graph runtime without --robot); off; "
                        "locks (a robot enters such a lane only holding its lock, asked for at "
                        "a waiting spot outside it); one_way (the lanes on cycles driven one "
                        "way, the others locked). A map without such aisles runs as off. Shown "
                        "by `tpuaf maps --lanes`")


def add_map_params(p: argparse.ArgumentParser) -> None:
    """--map-param KEY=VALUE (`tpuaf run`, `compare`, `fleet`, `maps`): overrides of the map's
    settings (tpuaf.maps.params, docs/MAPS.md)."""
    from tpuaf.params import MAP_PARAMS

    keys = ", ".join(f"{k} [{u}]" for k, (u, _) in MAP_PARAMS.items())
    p.add_argument("--map-param", action="append", default=[], metavar="KEY=VALUE",
                   help=f"override a map setting (repeatable; over the map file's and the "
                        f"imported defaults), e.g. --map-param sensing_radius=2.0 or "
                        f"--map-param growth_coefficients=1.0,0.6; keys: {keys}")


def map_params(args: argparse.Namespace) -> dict:
    """The checked `--map-param` overrides of `args` (CliError naming the bad one)."""
    from tpuaf.maps import MapError
    from tpuaf.maps.params import CLI, parse_map_params

    try:
        return parse_map_params(getattr(args, "map_param", []) or [], CLI)
    except MapError as err:
        raise CliError(str(err)) from None


def parse_param_value(raw: str):
    """A `--param` value: a YAML scalar (number, boolean, string); words that YAML leaves as
    strings but Python reads as numbers ('nan', 'inf', '1e3') become floats, so that the
    strategy's check refuses them as numbers, not as strings."""
    import yaml

    try:
        value = yaml.safe_load(raw)
    except yaml.YAMLError:
        value = raw
    if isinstance(value, str):
        try:
            value = float(value)
        except ValueError:
            pass
    return value


def parse_params(items: list[str]) -> dict:
    """`key=value` pairs (see parse_param_value); a repeated key is refused."""
    params = {}
    for item in items:
        key, sep, raw = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise CliError(f"--param expects key=value, got '{item}'")
        if key in params:
            raise CliError(f"--param {key} is given twice")
        params[key] = parse_param_value(raw)
    return params


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--map", default="grid", help="built-in map name (grid, lab) or a map folder path"
    )
    p.add_argument("--strategy", default="tpuaf", help="strategy name, any case (see --list)")
    p.add_argument("--robots", type=team_size, default=4, help=f"team size N (1 .. {MAX_ROBOTS})")
    p.add_argument("--duration", type=positive_float, default=3600.0, help="simulated seconds")
    p.add_argument("--seed", type=seed_int, default=0,
                   help=f"random seed 0 .. {MAX_SEED} (runs are deterministic)")
    p.add_argument("--out", type=folder_path, default=None,
                   help="results folder (default: none written)")
    p.add_argument("--overwrite", action="store_true",
                   help="reuse a non-empty --out: remove the files tpuaf wrote there first")
    p.add_argument("--allow-occupied-vertices", action="store_true",
                   help="a vertex outside the image's free space is a warning, not an error")
    p.add_argument("--delay", type=non_negative_float, default=0.0, help="team message delay [s]")
    p.add_argument("--loss", type=probability, default=0.0, help="message loss probability")
    add_teammate_timeout(p)
    add_map_params(p)
    p.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="strategy parameter (repeatable), e.g. --param utility=eq14",
    )
    add_runtime_arguments(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--no-plots", action="store_true",
                   help="no summary.png in the --out folder (scripted sweeps of many runs)")
    p.add_argument("--list", action="store_true", help="list strategies and maps, then exit")


def add_runtime_arguments(p: argparse.ArgumentParser) -> None:
    """--runtime, --robot and the fault options (docs/RUNTIMES.md)."""
    from tpuaf.robot.model import TRAVELS

    p.add_argument("--runtime", choices=("graph", "physics"), default="graph",
                   help="graph: robots on graph edges at nominal speed (default); physics: the "
                        "C++ world with laser, differential drive, collisions and the agents' "
                        "navigator (as the ROS fleet, without ROS)")
    p.add_argument("--robot", default=None,
                   help="robot model, in every runtime: a preset (burger, waffle, waffle_pi, "
                        "patrolling_sim) or auto (TURTLEBOT3_MODEL if set, else a preset that "
                        "drives the map's nominal speed). Strategies, motion and metrics use its "
                        "speed and travel times. Default: none in the graph runtime (the map's "
                        "nominal speed and edge lengths, as published comparisons), auto in "
                        "physics")
    p.add_argument("--travel", choices=TRAVELS, default=None,
                   help="edge travel the strategies plan with and the graph runtime drives: "
                        "declared (the map's edge lengths), planned (collision-free path lengths "
                        "for the robot's footprint) or timed (the robot's modelled travel time "
                        "per edge: planned path, accelerations, turns, slow zones). Default: "
                        "declared without --robot, timed with a robot (physics always has one)")
    p.add_argument("--fail", action="append", default=[], metavar="ROBOT@TIME",
                   help="robot ROBOT (index) dies at TIME [s] (repeatable)")
    p.add_argument("--fail-random", type=non_negative_int, default=0, metavar="K",
                   help="K robots die at seeded random times in [duration/10, duration/2]")
    p.add_argument("--stall", action="append", default=[], metavar="ROBOT@TIME",
                   help="robot ROBOT stops moving at TIME [s] but keeps talking (repeatable)")
    add_lanes(p, "one_way in every runtime; locks in physics only: the graph runtime models no "
                 "widths")


def make_engine(args: argparse.Namespace, config_kwargs: dict, patrol_map):
    """The run of `args.runtime` (graph or physics) with the fault options of `args`."""
    from tpuaf.runtimes.faults import FaultError, parse_fault

    try:
        fail = [parse_fault(x, "--fail") for x in getattr(args, "fail", [])]
        stall = [parse_fault(x, "--stall") for x in getattr(args, "stall", [])]
    except FaultError as err:
        raise CliError(str(err)) from None
    kwargs = dict(config_kwargs, fail=fail, stall=stall,
                  fail_random=int(getattr(args, "fail_random", 0)),
                  travel=getattr(args, "travel", None), robot=getattr(args, "robot", None))
    if hasattr(args, "lanes"):
        kwargs["lanes"] = args.lanes
    if getattr(args, "runtime", "graph") == "physics":
        from tpuaf.runtimes.config import PhysicsConfig
        from tpuaf.runtimes.physics import PhysicsRun

        return PhysicsRun(PhysicsConfig(**kwargs), patrol_map)
    from tpuaf.runtimes.config import RunConfig
    from tpuaf.runtimes.graph import make_run

    return make_run(RunConfig(**kwargs), patrol_map)


def format_faults(summary: dict) -> str:
    """Deaths, stalls and recovery after each death, next to the survivors' ideal."""
    lines = []
    for f in summary.get("faults") or []:
        lines.append(f"  {f['kind']} of robot {f['robot']} at {f['time_s']:,.1f} s")
    for r in summary.get("recovery") or []:
        def num(key, r=r):
            v = r.get(key)
            return "n/a" if v is None else f"{v:,.1f} s"
        back = r.get("recovery_time_s")
        back = "not by the end" if back is None else f"in {back:,.1f} s"
        reachable = r.get("worst_idleness_after_reachable_s")
        within = ("" if reachable is None else
                  f", {num('worst_idleness_after_reachable_s')} over the vertices still reachable")
        lines.append(
            f"  after robot {r['robot']} died at {r['time_s']:,.1f} s: every vertex visited "
            f"again {back}; worst idleness {num('worst_idleness_after_s')}{within}"
            f" (ideal for the {r['survivors']} survivors "
            f"{num('ideal_worst_idleness_survivors_s')}, unavoidable after this death "
            f"{num('floor_worst_idleness_after_s')}, after its detection "
            f"{num('detection_floor_worst_idleness_after_s')}); intentions honoured "
            f"{r['intentions_honoured']}/{len(r['intentions'])}")
    return "\n".join(lines)


def format_summary(summary: dict) -> str:
    rows = [
        ("interval idleness mean I_avg", "idleness_avg_s", "s"),
        ("interval idleness std I_std", "idleness_std_s", "s"),
        ("interval idleness min I_min", "idleness_min_s", "s"),
        ("interval idleness max I_max", "idleness_max_s", "s"),
        ("instantaneous idleness I_ins (time mean)", "idleness_ins_mean_s", "s"),
        ("worst idleness", "worst_idleness_s", "s"),
        ("uncertainty X (time mean)", "uncertainty_mean", ""),
        ("interferences", "interferences", ""),
        ("interference rate If_rate", "interference_rate_per_min", "1/min"),
        ("visits", "visits", ""),
        ("complete patrol cycles", "complete_cycles", ""),
    ]
    if "one_way_lanes" in summary:  # --lanes one_way
        rows.append(("lanes driven one way", "one_way_lanes", ""))
    if "lane_waits" in summary:  # a run with lane locks (physics --lanes, a fleet)
        rows += [("lane waits", "lane_waits", ""), ("lane wait time", "lane_wait_s", "s")]
    width = max(len(r[0]) for r in rows)
    lines = []
    for label, key, unit in rows:
        value = summary.get(key)
        if value is None:
            text = "n/a"
        elif isinstance(value, float):
            text = f"{value:,.2f}"
        else:
            text = f"{value:,}"
        lines.append(f"  {label:<{width}}  {text:>12} {unit}")
    if summary.get("lane_edges_blocked"):  # a dead robot's body in a lane (docs/LANES.md)
        edges = ", ".join(f"{u}-{v}" for u, v in summary["lane_edges_blocked"])
        lines.append(f"  lane edges blocked by a dead robot's body: {edges}")
    for key, label in (("vertices_under_bodies", "vertices the dead robots' bodies cut off "
                        "(left out of the reachable recovery)"),
                       ("closed_but_reachable", "vertices survivors closed that a robot could "
                        "still reach (counted in every figure)")):
        if summary.get(key):  # navigation/bodies.py, docs/LANES.md
            lines.append(f"  {label}: {', '.join(str(v) for v in summary[key])}")
    faults = format_faults(summary)
    return "\n".join(lines) + ("\n" + faults if faults else "")


def run(args: argparse.Namespace) -> int:
    from tpuaf.maps import MapError, builtin_map_names, load_map
    from tpuaf.policies import REGISTRY, ParameterError
    from tpuaf.runtimes.config import ConfigError

    if args.list:
        print("strategies:", ", ".join(REGISTRY.names()))
        print("maps:", ", ".join(builtin_map_names()), "(or a path to a map folder)")
        return 0
    config = dict(
        map=args.map,
        strategy=args.strategy,
        robots=args.robots,
        duration_s=args.duration,
        seed=args.seed,
        delay_s=args.delay,
        loss=args.loss,
        teammate_timeout_s=args.teammate_timeout,
        strategy_params=parse_params(args.param),
        map_params=map_params(args),
    )
    from tpuaf.cli import limits
    from tpuaf.maps.params import CLI

    try:
        patrol_map = load_map(args.map, allow_occupied_vertices=args.allow_occupied_vertices,
                              params=config["map_params"], params_origin=CLI)
        limits.check_team(args.strategy, args.robots, patrol_map.num_vertices,
                          map_name=patrol_map.name)
        engine = make_engine(args, config, patrol_map)
    except (MapError, ConfigError, ParameterError) as err:
        raise CliError(str(err)) from None
    for warning in patrol_map.warnings:
        print(f"tpuaf run: warning: {warning}", file=sys.stderr)
    if args.out is not None:
        from tpuaf.experiments.results_folder import prepare_out_dir

        args.out = prepare_out_dir(args.out, overwrite=args.overwrite)
    return execute(engine, args.out, quiet=args.quiet, plots=not args.no_plots)


END_FILES_AFTER_SIGNAL_S = 1.0  # [s] of end-file writing after the signal that stopped a run


class _NoBar:
    """The progress bar of a --quiet run: tqdm(disable=True) without importing tqdm."""

    n = 0

    def update(self, _n: float = 1) -> None:
        pass

    def close(self) -> None:
        pass


def execute(engine, out: Path | None, quiet: bool = False, plots: bool = True) -> int:
    """Run with a progress bar, write the results folder, print the summary table."""
    from tpuaf.cli import signals

    config = engine.config
    title = (
        f"{config.strategy} on {engine.patrol_map.name}, N = {config.robots}, "
        f"{config.duration_s:g} s, seed {config.seed}"
        + ("" if getattr(engine, "runtime", "graph") == "graph" else f", {engine.runtime} runtime")
    )
    writer = None
    if out:
        from tpuaf.experiments.results import ResultsWriter

        writer = ResultsWriter(out, engine.effective_config(), plots=plots)
    if quiet:  # tqdm (~30 ms to import) only for a bar that shows
        bar = _NoBar()
    else:
        from tqdm import tqdm

        bar = tqdm(
            total=config.duration_s,
            unit="sim s",
            desc=config.strategy,
            bar_format="{l_bar}{bar}| {n:.0f}/{total:.0f} sim s [{elapsed}<{remaining}]",
            file=sys.stderr,
        )

    def progress(now: float) -> None:
        bar.update(now - bar.n)
        if writer is not None:
            with signals.shielded():  # rows are written whole and counted once
                writer.sync(engine.recorder)
            if signals.received() is not None:
                raise KeyboardInterrupt(signals.received())

    wall = time.perf_counter()
    interrupted = False
    try:
        summary = engine.run(progress)
    except KeyboardInterrupt:
        interrupted = True
        summary = engine.summary()
    finally:
        bar.close()
    wall = time.perf_counter() - wall
    summary["wall_time_s"] = wall
    if writer is not None:
        seen = signals.count()
        # Stopped (by a signal now, or by the one that interrupted the run, after
        # END_FILES_AFTER_SIGNAL_S): the end files not yet written are skipped, so that the
        # command ends within about 2 s of a signal.
        cutoff = time.monotonic() + (END_FILES_AFTER_SIGNAL_S if interrupted else math.inf)
        with signals.shielded():
            writer.finish(summary, engine.recorder, interrupted=interrupted,
                          should_stop=lambda: signals.count() > seen
                          or time.monotonic() > cutoff)
    print(f"\n{title}{' (interrupted)' if interrupted else ''}")
    print(format_summary(summary))
    print(
        f"  simulated {engine.now:,.0f} s in {wall:.2f} s wall ({engine.now / max(wall, 1e-9):,.0f}x real time)"
    )
    if out:
        print(f"  results: {out}")
    return signals.exit_code() if interrupted else 0
