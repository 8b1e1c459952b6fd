"""`tpuaf analyze RUN.bag`: a ROS run's metrics from its bag (no ROS needed).

Reads a `tpuaf fleet` bag or a plain `rosbag record` of a robot run (team topics plus tf, odom or
amcl_pose; no ground truth or monitor topics needed): visits and idleness from the agents' own
reports, X from whatever positions the bag holds (tpuaf.measure.bag says how). Writes the same results
folder as the monitor and batch (default: <bag folder>/analysis), and, when the monitor's
summary.json lies beside the bag, compares the two (docs/FLEET.md states the tolerance).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import yaml

from tpuaf.errors import CliError

# Compared keys and their tolerance: (absolute, relative); a key agrees if within either.
TOLERANCES = {
    "idleness_avg_s": (0.5, 0.02),
    "idleness_max_s": (1.0, 0.02),
    "idleness_ins_mean_s": (0.5, 0.02),
    "worst_idleness_s": (1.0, 0.02),
    "uncertainty_mean": (0.01, 0.02),
    "visits": (2, 0.01),
    "interferences": (1, 0.05),
    "deaths": (0, 0.0),
}
POSE_CHOICES = ("auto", "ground_truth", "tf", "amcl", "odom")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("bag", type=Path, help="the run's bag (run.bag of tpuaf fleet, or any "
                                          "rosbag record with the team topics)")
    p.add_argument("--map", default=None,
                   help="map name or path (default: from config.yaml beside the bag)")
    p.add_argument("--out", type=Path, default=None,
                   help="results folder (default: <bag folder>/analysis)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace the results tpuaf wrote in an existing --out folder")
    p.add_argument("--start", type=float, default=None,
                   help="[s] start this long after the bag's beginning (default: the run's "
                        "announced start, /fleet/start, else the beginning)")
    p.add_argument("--duration", type=float, default=None,
                   help="[s] length of the analysed span, within the bag (default: the "
                        "monitored run's, else up to the bag's end)")
    p.add_argument("--death-timeout", type=float, default=None,
                   help="[s] silence that makes an agent dead (default: the run's, else 5)")
    p.add_argument("--robots", type=int, default=None,
                   help="team size (default: config.yaml, else the robots seen in the bag)")
    p.add_argument("--poses", choices=POSE_CHOICES, default="auto",
                   help="position source for X and interference (default: the best in the "
                        "bag: ground truth, tf, amcl_pose, odom)")


def compare(a: dict, b: dict) -> list[tuple[str, object, object, bool]]:
    rows = []
    for key, (abs_tol, rel_tol) in TOLERANCES.items():
        x, y = a.get(key), b.get(key)
        if x is None or y is None:
            ok = x is None and y is None
        else:
            d = abs(float(x) - float(y))
            ok = d <= abs_tol or d <= rel_tol * max(abs(float(x)), abs(float(y)))
        rows.append((key, x, y, ok))
    return rows


def check_options(args: argparse.Namespace) -> None:
    """Refuse impossible numbers before reading anything (one line, exit 2)."""
    if args.start is not None and not (math.isfinite(args.start) and args.start >= 0):
        raise CliError(f"--start must be a finite number of seconds >= 0, got {args.start:g}")
    if args.duration is not None and not (math.isfinite(args.duration) and args.duration > 0):
        raise CliError(f"--duration must be a finite number of seconds > 0, got "
                       f"{args.duration:g}")
    if args.death_timeout is not None and not (math.isfinite(args.death_timeout)
                                               and args.death_timeout > 0):
        raise CliError(f"--death-timeout must be a finite number of seconds > 0, got "
                       f"{args.death_timeout:g}")
    if args.robots is not None and args.robots < 1:
        raise CliError(f"--robots must be >= 1, got {args.robots}")


def run(args: argparse.Namespace) -> int:
    from tpuaf.cli.run import format_summary
    from tpuaf.errors import TpuafError
    from tpuaf.experiments.results import ResultsWriter, prepare_out_dir
    from tpuaf.maps import load_map
    from tpuaf.measure.bag import BagError, analyze

    check_options(args)
    bag = args.bag.expanduser().resolve()
    if not bag.is_file():
        raise CliError(f"{bag}: bag not found")
    folder = bag.parent
    config: dict = {}
    for name in ("config.yaml", "fleet_config.yaml"):
        if (folder / name).is_file():
            try:
                config = yaml.safe_load((folder / name).read_text()) or {}
            except (OSError, yaml.YAMLError) as err:
                raise CliError(f"{folder / name}: unreadable ({err})") from None
            if not isinstance(config, dict):
                config = {}
            break
    map_ref = args.map or config.get("map")
    if not map_ref:
        raise CliError(f"no config.yaml beside {bag}: give --map")
    robots = args.robots or (int(config["robots"]) if isinstance(config.get("robots"), int)
                             else None)
    timeout = args.death_timeout
    if timeout is None and isinstance(config.get("death_timeout_s"), (int, float)):
        timeout = float(config["death_timeout_s"])
    out = (args.out or folder / "analysis").expanduser()
    try:
        patrol_map = load_map(map_ref)
        result = analyze(bag, patrol_map, robots=robots, start_offset_s=args.start,
                         duration_s=args.duration, death_timeout_s=timeout,
                         pose_source=None if args.poses == "auto" else args.poses)
        out = prepare_out_dir(out, overwrite=args.overwrite)
    except (BagError, TpuafError) as err:
        raise CliError(str(err)) from None
    summary = result.summary
    info = result.info
    summary["analysis"] = {
        "bag": str(bag), "bag_span_s": info.span_s,
        "analysed_from_s": result.start_s - info.start_s,
        "analysed_to_s": result.end_s - info.start_s,
        "visit_source": result.visit_source, "visit_reports": result.reports,
        "pose_source": result.pose_source, "deaths_detected": result.liveness,
        "notes": result.notes,
    }
    cfg = {**config, "map": map_ref, "robots": result.robots, "analysis_of": str(bag),
           "runtime": "bag analysis (tpuaf analyze)", "start_time_s": result.start_s}
    writer = ResultsWriter(out, cfg)
    complete = info.monitor_finished or not config  # a plain bag: the span is all there is
    writer.finish(summary, result.recorder, interrupted=not complete)
    print(f"{bag}: {result.robots} robots; analysed {result.span_s:.1f} s of the bag's "
          f"{info.span_s:.1f} s (from t = {result.start_s - info.start_s:.1f} s to "
          f"{result.end_s - info.start_s:.1f} s)")
    print(f"  visits from {result.visit_source}: {result.reports} reports in the span")
    for note in result.notes:
        print(f"  note: {note}")
    print(format_summary(summary))
    print(f"  deaths: {summary['deaths']} {summary['dead_robots']}")
    print(f"  results: {out}")
    live = folder / "summary.json"
    if live.is_file():
        rows = compare(json.loads(live.read_text()), summary)
        bad = [r for r in rows if not r[3]]
        print("  against the monitor's summary.json:")
        for key, x, y, ok in rows:
            fx = f"{x:.3f}" if isinstance(x, float) and math.isfinite(x) else str(x)
            fy = f"{y:.3f}" if isinstance(y, float) and math.isfinite(y) else str(y)
            print(f"    {key:<22} monitor {fx:>12}  bag {fy:>12}  {'ok' if ok else 'DIFFERS'}")
        (out / "comparison.json").write_text(json.dumps(
            [{"metric": k, "monitor": x, "bag": y, "agrees": ok} for k, x, y, ok in rows],
            indent=2) + "\n")
        return 1 if bad else 0
    return 0
