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
import sys
from pathlib import Path

from tpuaf.cli.run import team_size
from tpuaf.errors import CliError
from tpuaf.params import LIVENESS_DEFAULTS as _L

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
    "start_time_s": (1e-3, 0.0),  # [s] the run's start: the announced one in both
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
                   help="[s] silence that makes an agent dead (default: the run's, else the teammate "
                        "timeout, as the monitor)")
    p.add_argument("--teammate-timeout", type=float, default=None,
                   help="[s] the agents' teammate timeout, for the recovery's floor at "
                        f"detection (default: the run's, else {_L.teammate_timeout_s:g}, the "
                        "agents' default)")
    p.add_argument("--robots", type=team_size, default=None,
                   help="team size (default: config.yaml, else the robots seen in the bag)")
    p.add_argument("--force", action="store_true",
                   help="a bag that does not match the map (vertex ids, team size, positions "
                        "outside it) is a warning, not an error")
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
    if args.teammate_timeout is not None and not (math.isfinite(args.teammate_timeout)
                                                  and args.teammate_timeout > 0):
        raise CliError(f"--teammate-timeout must be a finite number of seconds > 0, got "
                       f"{args.teammate_timeout:g}")
    if args.robots is not None and args.robots < 1:
        raise CliError(f"--robots must be >= 1, got {args.robots}")


class _UnknownIds:
    """Wraps a map's `lookup_index` for one analysis: counts the vertex ids of the bag's reports
    that the map does not have (its readers ignore them silently)."""

    def __init__(self, patrol_map):
        self.map, self.lookup = patrol_map, patrol_map.lookup_index
        self.unknown: dict[int, int] = {}

    def __call__(self, vertex_id: int) -> int | None:
        index = self.lookup(vertex_id)
        if index is None:
            self.unknown[int(vertex_id)] = self.unknown.get(int(vertex_id), 0) + 1
        return index

    def __enter__(self):
        self.map.lookup_index = self  # an instance attribute, removed on exit
        return self

    def __exit__(self, *exc) -> None:
        del self.map.lookup_index


OFF_GRAPH_M = 3.0  # [m] a patrolling robot is on an edge's corridor: farther, another map


def off_the_graph_m(patrol_map, points):
    """Distance [m] of each point (k x 2) to the nearest edge segment of the map."""
    import numpy as np

    xy = np.asarray(patrol_map.positions, dtype=float)
    edges = np.array([(u, v) for u, v, *_ in patrol_map.edges], dtype=int).reshape(-1, 2)
    if not len(edges):
        return np.linalg.norm(points[:, None, :] - xy[None], axis=2).min(axis=1)
    a, b = xy[edges[:, 0]], xy[edges[:, 1]]
    d = b - a
    t = np.einsum("pkj,kj->pk", points[:, None, :] - a[None], d) / np.maximum(
        np.einsum("kj,kj->k", d, d), 1e-12)
    closest = a[None] + np.clip(t, 0.0, 1.0)[..., None] * d[None]
    return np.linalg.norm(closest - points[:, None, :], axis=2).min(axis=1)


def pairing_problems(result, patrol_map, robots: int | None, unknown: dict[int, int],
                     where: str) -> list[str]:
    """Why the bag does not belong to `patrol_map` (or the team size given): vertex ids the
    map lacks, more robots in the bag than the team, last positions outside the map."""
    import numpy as np

    problems = []
    if unknown:
        ids = sorted(unknown)
        shown = ", ".join(str(v) for v in ids[:5]) + (", ..." if len(ids) > 5 else "")
        problems.append(f"{sum(unknown.values())} visit report(s) name {len(ids)} vertex id(s) "
                        f"that map '{patrol_map.name}' does not have ({shown})")
    seen = int(getattr(result.info, "robots", 0) or 0)
    if robots is not None and seen > robots:
        problems.append(f"the bag holds {seen} robots, the team is {robots} ({where})")
    pos = result.recorder.last_positions
    if pos is not None and len(pos):
        p = np.asarray(pos, dtype=float)[:, :2]
        p = p[np.all(np.isfinite(p), axis=1)]
        if len(p):
            far = off_the_graph_m(patrol_map, p)
            limit = max(OFF_GRAPH_M, 2.0 * float(patrol_map.settings.interference_distance))
            outside = np.flatnonzero(far > limit)
            if len(outside):
                i = int(outside[0])
                problems.append(f"{len(outside)} robot(s) end up to {far.max():.1f} m away from "
                                f"every edge of map '{patrol_map.name}' (e.g. at "
                                f"({p[i][0]:.1f}, {p[i][1]:.1f}) m; at most {limit:g} m "
                                "expected)")
    return problems


def _bag_path(path: Path) -> Path:
    """The bag as a resolved path of a regular file (a link loop, FIFO or device refused)."""
    import os
    import stat

    try:
        mode = os.stat(path).st_mode
        resolved = Path(os.path.realpath(path))
    except OSError as err:
        raise CliError(f"{path}: cannot read the bag: {err.strerror or err}") from None
    if stat.S_ISDIR(mode) or not stat.S_ISREG(mode):
        raise CliError(f"{path}: {'a folder' if stat.S_ISDIR(mode) else 'not a regular file'}, "
                       "not a bag")
    return resolved


def _config_beside(folder: Path) -> dict:
    from tpuaf_core import yamlfile

    for name in ("config.yaml", "fleet_config.yaml"):
        path = folder / name
        if path.is_file():
            config = yamlfile.read_yaml_fast(path, CliError)
            return config if isinstance(config, dict) else {}
    return {}


def _config_of(folder: Path) -> dict:
    """The run's config.yaml (or fleet_config.yaml) in `folder`, {} if none (CliError naming
    the line when it is unreadable)."""
    try:
        return _config_beside(folder)
    except CliError:
        try:  # the strict reader's message names the line
            from tpuaf_core import yamlfile

            yamlfile.read_yaml(folder / "config.yaml", CliError)
        except CliError as err:
            raise CliError(f"unreadable configuration beside the bag: {err}") from None
        return {}


def _positive(value) -> float | None:
    """A finite number > 0 from config.yaml (seconds, metres), else None."""
    if isinstance(value, (int, float)) and not isinstance(value, bool) \
            and math.isfinite(value) and value > 0:
        return float(value)
    return None


def _robot_radius(config: dict) -> float | None:
    """[m] the run's robot radius (config.yaml `robot`: a dead robot's body on a vertex, for the
    recovery), else None (the map's)."""
    robot = config.get("robot")
    return _positive(robot.get("radius_m")) if isinstance(robot, dict) else None


def _liveness_timeouts(args: argparse.Namespace, config: dict) -> tuple[float | None, float]:
    """(death timeout, teammate timeout) [s]: the options, else the run's config.yaml; else
    the death timeout is left to tpuaf.measure.bag (None) and the teammate timeout is the
    agents' default (tpuaf.params.LIVENESS_DEFAULTS)."""
    timeout = args.death_timeout
    if timeout is None:
        timeout = _positive(config.get("death_timeout_s"))
    mate_timeout = args.teammate_timeout
    if mate_timeout is None:
        mate_timeout = _positive(config.get("teammate_timeout_s"))
    if mate_timeout is None:
        mate_timeout = _L.teammate_timeout_s
    return timeout, mate_timeout


def run(args: argparse.Namespace) -> int:
    from tpuaf.cli import limits
    from tpuaf.errors import TpuafError
    from tpuaf.experiments.results import ResultsWriter
    from tpuaf.experiments.results_folder import prepare_out_dir
    from tpuaf.maps import load_map
    from tpuaf.measure.bag import BagError, analyze

    check_options(args)
    if not args.bag.expanduser().exists() and not args.bag.expanduser().is_symlink():
        raise CliError(f"{args.bag}: bag not found")
    bag = _bag_path(args.bag.expanduser())
    folder = bag.parent
    config = _config_of(folder)
    map_ref = args.map or config.get("map")
    if not map_ref or not isinstance(map_ref, str):
        raise CliError(f"no config.yaml naming the map beside {bag}: give --map")
    given = config.get("robots")
    robots = args.robots or (given if isinstance(given, int) and not isinstance(given, bool)
                             and 0 < given <= 1_000 else None)
    robots_from = "--robots" if args.robots else "config.yaml beside the bag"
    timeout, mate_timeout = _liveness_timeouts(args, config)
    out = (args.out or folder / "analysis").expanduser()
    created = not out.exists()
    try:
        # the run's overrides of the map's settings (d_if, r: the metrics), as config.yaml says
        patrol_map = load_map(map_ref, params=config.get("map_params") or None,
                              params_origin=f"{folder / 'config.yaml'}: map_params")
        if robots is not None:
            limits.check_team("recorder", robots, patrol_map.num_vertices, "--robots",
                              patrol_map.name)
        out = prepare_out_dir(out, overwrite=args.overwrite)
    except TpuafError as err:
        raise CliError(str(err)) from None
    try:
        with _UnknownIds(patrol_map) as ids:
            result = analyze(bag, patrol_map, robots=robots, start_offset_s=args.start,
                             duration_s=args.duration, death_timeout_s=timeout,
                             teammate_timeout_s=mate_timeout, robot_radius_m=_robot_radius(config),
                             pose_source=None if args.poses == "auto" else args.poses)
        problems = pairing_problems(result, patrol_map, robots, ids.unknown, robots_from)
        if problems and not args.force:
            raise CliError(f"{bag} does not match map '{patrol_map.name}' ({map_ref}): "
                           + "; ".join(problems) + " (give the right --map, or --force)")
    except (BagError, TpuafError) as err:
        _abandon(out, created)
        raise CliError(str(err)) from None
    except KeyboardInterrupt:
        _interrupted(out, bag)
        raise
    for problem in problems:
        print(f"tpuaf analyze: warning: {problem} (--force)", file=sys.stderr)
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
    complete = info.monitor_finished or not config  # a plain bag: the span is all there is
    try:
        with ResultsWriter(out, cfg) as writer:
            writer.finish(summary, result.recorder, interrupted=not complete)
    except KeyboardInterrupt:
        _interrupted(out, bag)
        raise
    return _report(bag, result, out)


def outage_lines(summary: dict) -> list[str]:
    """One line per outage of a summary (robot, cause, interval in run time [s])."""
    out = []
    for o in summary.get("outages") or []:
        end = ("never heard again (dead)" if o.get("end_s") is None
               else f"heard again at {o['end_s']:.1f} s")
        out.append(f"outage: robot {o['robot']} {o['cause']} from {o['start_s']:.1f} s, {end}")
    return out


def traffic_lines(summary: dict) -> list[str]:
    """The refused agent traffic of a summary (tpuaf.measure.traffic), by reason and robot."""
    refused = summary.get("rejected") or {}
    if not refused.get("total"):
        return []
    robots = "; ".join(
        ("no robot" if row["robot"] < 0 else f"robot {row['robot']}") + ": "
        + ", ".join(f"{k} {v}" for k, v in row.items() if k != "robot")
        for row in refused.get("by_robot") or [])
    out = [f"refused {refused['total']} agent message(s) of {refused['total'] + refused.get('accepted', 0)} "
           f"({robots})"]
    if summary.get("suspect_traffic"):
        out.append("SUSPECT TRAFFIC: many messages refused, the figures may be affected "
                   "(summary.json suspect_traffic; docs/FLEET.md \"Hostile traffic\")")
    return out


def health_lines(summary: dict) -> list[str]:
    """One line per robot of a summary's robot health (counts, time since its last visit, no
    progress spells in run time [s])."""
    out = []
    for h in summary.get("robot_health") or []:
        spells = ", ".join(f"{s['start_s']:.0f}-" + ("end" if s["end_s"] is None
                                                      else f"{s['end_s']:.0f}") + " s"
                           for s in h["no_progress"])
        out.append(f"robot {h['robot']}: {h['stuck_episodes']} stuck episode(s) "
                   f"({h['recoveries']} recoveries), {h['failed_goals']} failed goal(s), "
                   f"{h['give_ways']} give-way(s), {h['since_last_visit_s']:.0f} s since its "
                   "last visit" + (f"; no progress {spells}" if spells else ""))
    return out


def _report(bag: Path, result, out: Path) -> int:
    """Print the analysis; compare it with the monitor's summary.json beside the bag, if any
    (comparison.json): 1 when a metric differs beyond its tolerance, else 0."""
    from tpuaf.cli.run import format_summary

    summary, info, folder = result.summary, result.info, bag.parent
    print(f"{bag}: {result.robots} robots; analysed {result.span_s:.1f} s of the bag's "
          f"{info.span_s:.1f} s (from t = {result.start_s - info.start_s:.1f} s to "
          f"{result.end_s - info.start_s:.1f} s)")
    print(f"  visits from {result.visit_source}: {result.reports} reports in the span")
    for note in result.notes:
        print(f"  note: {note}")
    print(format_summary(summary))
    print(f"  deaths: {summary['deaths']} {summary['dead_robots']}")
    for line in outage_lines(summary) + traffic_lines(summary) + health_lines(summary):
        print(f"  {line}")
    print(f"  results: {out}")
    live = folder / "summary.json"
    if live.is_file():
        from tpuaf.experiments.run_files import incomplete

        why = incomplete(folder)
        if why is not None:  # the live run's files: not all written and closed
            print(f"  note: the run in {folder} is incomplete: {why}")
        rows = compare(json.loads(live.read_text()), summary)
        bad = [r for r in rows if not r[3]]
        print("  against the monitor's summary.json:")
        for key, x, y, ok in rows:
            fx = f"{x:.3f}" if isinstance(x, float) and math.isfinite(x) else str(x)
            fy = f"{y:.3f}" if isinstance(y, float) and math.isfinite(y) else str(y)
            print(f"    {key:<22} monitor {fx:>12}  bag {fy:>12}  {'ok' if ok else 'DIFFERS'}")
        from tpuaf.experiments.results_folder import record_written
        from tpuaf.files import atomic_write_text

        record_written(out, "comparison.json")
        atomic_write_text(out / "comparison.json", json.dumps(
            [{"metric": k, "monitor": x, "bag": y, "agrees": ok} for k, x, y, ok in rows],
            indent=2) + "\n")
        return 1 if bad else 0
    return 0


def _abandon(out: Path, created: bool) -> None:
    """Leave no trace of a folder this command created for an analysis it refused."""
    import contextlib
    import os

    from tpuaf.experiments.results_folder import LOCK_FILE, MANIFEST, unlock_folder

    if not created:
        return
    unlock_folder(out)
    for name in (LOCK_FILE, MANIFEST):
        with contextlib.suppress(OSError):
            os.unlink(out / name)
    with contextlib.suppress(OSError):
        out.rmdir()  # only when empty


def _interrupted(out: Path, bag: Path) -> None:
    """An interrupted analysis: summary.json says so ("complete": false), whatever was
    written before the signal."""
    from tpuaf.experiments.results_folder import record_written
    from tpuaf.files import atomic_write_text

    path = out / "summary.json"
    try:
        done = json.loads(path.read_text()) if path.is_file() else {}
    except (OSError, ValueError):
        done = {}
    if isinstance(done, dict) and done.get("complete") is False:
        return
    record_written(out, "summary.json")
    atomic_write_text(path, json.dumps({"complete": False, "interrupted": True,
                                        "analysis": {"bag": str(bag)}}, indent=2) + "\n")
