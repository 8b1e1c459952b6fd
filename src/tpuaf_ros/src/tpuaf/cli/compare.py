"""`tpuaf compare`: a sweep of batch runs (maps x strategies x N x seeds) on Dask, resumable."""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import sys
from pathlib import Path

from tpuaf.cli.run import (
    MAX_SEED,
    add_map_params,
    add_teammate_timeout,
    map_params,
    non_negative_float,
    positive_float,
    positive_int,
    probability,
    seed_int,
    team_size,
)
from tpuaf.errors import CliError


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--maps", nargs="+", default=["grid"], metavar="MAP",
                   help="built-in map names (grid, lab) or map folder / .graph paths")
    p.add_argument("--strategies", nargs="+", default=["gbs", "dtag", "dtap", "tpuaf"],
                   metavar="STRATEGY", help="strategy names, any case")
    p.add_argument("--robots", nargs="+", type=team_size, default=[4, 8, 12], metavar="N",
                   help="team sizes (include 1 for the acceleration ratio)")
    p.add_argument("--duration", type=positive_float, default=3600.0,
                   help="simulated seconds per run")
    add_teammate_timeout(p)
    add_map_params(p)
    p.add_argument("--seeds", type=positive_int, default=5,
                   help="number of seeds per configuration (seeds first-seed .. first-seed + n - 1)")
    p.add_argument("--first-seed", type=seed_int, default=0, help="first seed")
    p.add_argument("--out", type=Path, required=True,
                   help="results folder; finished runs in it are skipped (resumable)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="an existing Dask scheduler, e.g. tcp://127.0.0.1:8786 "
                        "(default: a local cluster on loopback)")
    p.add_argument("--workers", type=positive_int, default=None,
                   help="local cluster worker processes (default: one per core)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    faults = p.add_argument_group(
        "scenarios", "each value adds one scenario, the other factors at their base (no fault): "
                     "the degradation curves; the fault-free runs are always included")
    faults.add_argument("--loss", nargs="+", type=probability, default=[], metavar="P",
                        help="message loss probabilities, e.g. 0.1 0.3 0.5 0.7 0.9")
    faults.add_argument("--delay", nargs="+", type=non_negative_float, default=[], metavar="S",
                        help="team message delays [s], e.g. 1 5 10 30")
    faults.add_argument("--deaths", nargs="+", default=[], metavar="K",
                        help="robots that die: a count (runs with K >= N are skipped) or a "
                             "fraction of the team, e.g. 1/4 (rounded down)")
    faults.add_argument("--death-time", type=non_negative_float, default=None, metavar="S",
                        help="when they die [s of run time] (default: half the run)")
    faults.add_argument("--runtime", choices=["graph", "physics"], default="graph",
                        help="graph (event-driven, default) or physics (robots with dynamics)")
    faults.add_argument("--robot", default=None, metavar="PRESET",
                        help="robot model in either runtime (burger, waffle, waffle_pi, "
                             "patrolling_sim, auto) as in `tpuaf run --robot`")


# A Dask scheduler address: scheme://host:port or host:port.
_ADDRESS = re.compile(r"^(?:(?:tcp|tls|ws|wss|ucx)://)?(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9.-]+):(\d{1,5})$")


def check_scheduler(address: str | None) -> None:
    """Refuse a --scheduler that is no address before Dask is asked (it raised a traceback)."""
    if address is None:
        return
    m = _ADDRESS.match(address)
    if not m or not 0 < int(m.group(2)) < 65536:
        raise CliError(f"--scheduler {address}: not a scheduler address (expected "
                       "tcp://HOST:PORT or HOST:PORT, e.g. tcp://127.0.0.1:8786)")


def run(args: argparse.Namespace) -> int:
    from tpuaf.cli import limits
    from tpuaf.experiments.sweep.execute import run_sweep
    from tpuaf.experiments.sweep.grid import SweepError, make_scenarios, make_spec

    if args.scheduler and args.workers:
        raise CliError("--workers applies to the local cluster only, not with --scheduler")
    if args.out.exists() and not args.out.is_dir():
        raise CliError(f"--out {args.out}: is an existing file, not a folder")
    if args.first_seed + args.seeds - 1 > MAX_SEED:
        raise CliError(f"--first-seed {args.first_seed} + --seeds {args.seeds} exceeds the "
                       f"largest seed {MAX_SEED}")
    check_scheduler(args.scheduler)
    if args.workers is not None and args.workers > limits.max_workers():
        raise CliError(f"--workers {args.workers}: at most {limits.max_workers()} worker "
                       f"processes fit this machine ({os.cpu_count() or 1} cores, "
                       f"{limits.size_text(limits.budget_bytes())} of memory to give)")
    try:
        scenarios = make_scenarios(args.loss, args.delay, args.deaths, args.death_time,
                                   runtime=args.runtime, robot=args.robot)
        per_seed = (len(set(args.maps)) * len(set(args.strategies)) * len(set(args.robots))
                    * len(scenarios))
        limits.check_runs(per_seed * args.seeds, per_seed, args.seeds)
        spec = make_spec(args.maps, args.strategies, args.robots, args.seeds,
                         duration_s=args.duration, first_seed=args.first_seed,
                         scenarios=scenarios, teammate_timeout_s=args.teammate_timeout,
                         map_params=map_params(args))
    except SweepError as err:
        raise CliError(str(err)) from None
    from tpuaf.experiments.results_folder import lock_folder
    from tpuaf.experiments.run_files import ResultsError

    try:  # a sweep folder is resumed, so it may exist: only check that it can be written
        args.out.mkdir(parents=True, exist_ok=True)
        probe = args.out / ".tpuaf-write-test"
        with contextlib.suppress(FileNotFoundError):
            probe.unlink()
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644))
        probe.unlink()
    except OSError as err:
        raise CliError(f"--out {args.out}: cannot write there: {err.strerror or err}") from None
    try:
        lock_folder(args.out)  # one sweep per folder: a second is refused
    except ResultsError as err:
        raise CliError(str(err)) from None
    total = len(spec.keys())
    print(f"sweep: {len(spec.maps)} maps ({', '.join(m.label for m in spec.maps)}) x "
          f"{len(spec.strategies)} strategies ({', '.join(spec.strategies)}) x "
          f"N = {' '.join(map(str, spec.robots))} x {len(spec.seeds)} seeds x "
          f"{len(spec.scenarios)} scenarios ({', '.join(sc.name for sc in spec.scenarios)}), "
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
