"""`tpuaf analyze RUN.bag`: recompute a fleet run's metrics from its bag (no ROS needed).

Writes the same results folder as the monitor and batch (default: <bag folder>/analysis), and,
when the monitor's summary.json lies beside the bag, compares the two (docs/FLEET.md states the
tolerance).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import yaml

from ..errors import CliError

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


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("bag", type=Path, help="the run's bag (run.bag of tpuaf fleet)")
    p.add_argument("--map", default=None,
                   help="map name or path (default: from config.yaml beside the bag)")
    p.add_argument("--out", type=Path, default=None,
                   help="results folder (default: <bag folder>/analysis)")
    p.add_argument("--duration", type=float, default=None, help="[s] (default: from the bag)")
    p.add_argument("--death-timeout", type=float, default=None,
                   help="[s] silence that makes an agent dead (default: the run's, else 5)")


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


def run(args: argparse.Namespace) -> int:
    from ..bag import BagError, replay
    from ..maps import MapError, load_map
    from ..results import ResultsWriter
    from .run import format_summary

    bag = args.bag.expanduser().resolve()
    folder = bag.parent
    config: dict = {}
    for name in ("config.yaml", "fleet_config.yaml"):
        if (folder / name).is_file():
            config = yaml.safe_load((folder / name).read_text()) or {}
            break
    map_ref = args.map or config.get("map")
    if not map_ref:
        raise CliError(f"no config.yaml beside {bag}: give --map")
    try:
        patrol_map = load_map(map_ref)
        timeout = args.death_timeout or float(config.get("death_timeout_s", 5.0))
        monitor, info = replay(bag, patrol_map, duration=args.duration, death_timeout_s=timeout)
    except (BagError, MapError) as err:
        raise CliError(str(err)) from None
    summary = monitor.summary()
    out = args.out or folder / "analysis"
    cfg = {**config, "analysis_of": str(bag), "runtime": "bag analysis (tpuaf analyze)",
           "start_time_s": monitor.start_time}
    writer = ResultsWriter(out, cfg)
    writer.finish(summary, monitor.recorder, interrupted=not info.monitor_finished)
    print(f"{bag}: {info.robots} robots, start {monitor.start_time:.2f} s, "
          f"{summary['duration_s']:.0f} s analysed")
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
