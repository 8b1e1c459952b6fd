"""`tpuaf compare`: a sweep of batch runs (maps x strategies x N x seeds) on Dask, resumable."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import CliError
from .run import positive_float, positive_int


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--maps", nargs="+", default=["grid"], metavar="MAP",
                   help="built-in map names (grid, lab) or map folder / .graph paths")
    p.add_argument("--strategies", nargs="+", default=["gbs", "dtag", "dtap", "tpuaf"],
                   metavar="STRATEGY", help="strategy names, any case")
    p.add_argument("--robots", nargs="+", type=positive_int, default=[4, 8, 12], metavar="N",
                   help="team sizes (include 1 for the acceleration ratio)")
    p.add_argument("--duration", type=positive_float, default=3600.0,
                   help="simulated seconds per run")
    p.add_argument("--seeds", type=positive_int, default=5,
                   help="number of seeds per configuration (seeds first-seed .. first-seed + n - 1)")
    p.add_argument("--first-seed", type=int, default=0, help="first seed")
    p.add_argument("--out", type=Path, required=True,
                   help="results folder; finished runs in it are skipped (resumable)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="an existing Dask scheduler, e.g. tcp://127.0.0.1:8786 "
                        "(default: a local cluster on loopback)")
    p.add_argument("--workers", type=positive_int, default=None,
                   help="local cluster worker processes (default: one per core)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    from ..sweep import SweepError, make_spec, run_sweep

    if args.scheduler and args.workers:
        raise CliError("--workers applies to the local cluster only, not with --scheduler")
    try:
        spec = make_spec(args.maps, args.strategies, args.robots, args.seeds,
                         duration_s=args.duration, first_seed=args.first_seed)
    except SweepError as err:
        raise CliError(str(err)) from None
    total = len(spec.keys())
    print(f"sweep: {len(spec.maps)} maps ({', '.join(m.label for m in spec.maps)}) x "
          f"{len(spec.strategies)} strategies ({', '.join(spec.strategies)}) x "
          f"N = {' '.join(map(str, spec.robots))} x {len(spec.seeds)} seeds, "
          f"{spec.duration_s:g} s each = {total} runs -> {args.out}", file=sys.stderr)
    try:
        outcome = run_sweep(spec, args.out, scheduler=args.scheduler, workers=args.workers,
                            progress=not args.quiet)
    except SweepError as err:
        raise CliError(str(err)) from None
    print(f"{outcome.ran} runs done, {outcome.failed} failed, {outcome.skipped} already finished "
          f"(skipped); wall time {outcome.wall_time_s:.1f} s", file=sys.stderr)
    print(f"results: {Path(args.out) / 'results.csv'}")
    return 1 if outcome.failed else 0
