"""What a request will take, estimated before anything is allocated (issue 22).

Every command checks here what it is asked for (robots x vertices, runs of a sweep, frames of
an animation, pixels of a map image) against this machine's available memory and refuses, in
one line, what cannot fit, saying what would. The estimates are upper bounds fitted on
measurements (benchmarks/probe_hostile.py; grid, 2 cores, 24 GB): a request that passes may
still be slow, but it does not take the machine's memory.
"""

from __future__ import annotations

from tpuaf.errors import CliError
from tpuaf.files import available_bytes

BUDGET_FRACTION = 0.75  # of MemAvailable a command may plan to use (the rest: OS and others)
BASE_BYTES = 150 << 20  # the interpreter, numpy, the core and a map: ~60-120 MB measured

# Team memory [B] = BASE + n2 N^2 + n3 N^3 + nv N V + v2 V^2 + nv2 N V^2 (upper bounds of the
# measured peak RSS; N robots, V vertices; benchmarks/bench_limits.py, results/limits.md).
# Knowledge of the teammates' visits and intentions is N^2; the recorder and the strategies'
# per-vertex state N V; dtag, msp and hpcc read the map's all-pairs distances (one V x V
# float64 matrix: 8 B V^2), dtap also its hop counts (int32: 4 B V^2), every robot viewing the
# same matrices (until 2026-12-06 dtap copied them per robot: 1.6 GiB at N = 30, V = 2,500,
# now 0.15 GiB; results/limits_dtap.md). Measured (grid and generated buildings, V = 25-10,000): the C++ loop's strategies
# ~56 B per N^2 and ~42 B per N V with the recorder; tpuaf_plus ~300-450 B per N^2 (no N^3 term
# since its plans moved to the core); Python strategies at most ~500 B per N^2 (cbls; kept at
# 3,300 for the ones not measured).
_TEAM_DEFAULT = {"n2": 3300.0, "n3": 0.0, "nv": 64.0, "v2": 0.0, "nv2": 0.0}
_ALL_PAIRS = 8.5  # [B] per entry of a V x V float64 matrix (and its row views)
_HOPS = 4.5  # [B] per entry of the V x V int32 hop-count matrix
TEAM_COEFFS = {
    "tpuaf": {**_TEAM_DEFAULT, "n2": 40.0},
    "gbs": {**_TEAM_DEFAULT, "n2": 40.0},
    "dtag": {**_TEAM_DEFAULT, "n2": 40.0, "v2": _ALL_PAIRS},
    "tpuaf_plus": {**_TEAM_DEFAULT, "n2": 600.0},
    "msp": {**_TEAM_DEFAULT, "v2": _ALL_PAIRS},
    "hpcc": {**_TEAM_DEFAULT, "v2": _ALL_PAIRS},
    "dtap": {**_TEAM_DEFAULT, "v2": _ALL_PAIRS + _HOPS},
    "recorder": {**_TEAM_DEFAULT, "n2": 0.0},  # tpuaf analyze: the metrics alone
}
RECORDER_BYTES_PER_PAIR = 48.0  # interference pairs: keys, last entries (core recorder.cpp)
SWEEP_BYTES_PER_RUN = 24 << 10  # one run's key, task, future and results row in the driver
WORKER_BYTES = 400 << 20  # one Dask worker process with a run in it
MAX_FRAMES = 5000  # an animation's frames (each held by the GIF / MP4 writer)
IMAGE_BYTES_PER_PIXEL = 12  # a decoded map image: RGB(A) bytes, float grid and free mask


def budget_bytes() -> int:
    """What one command may plan to use [B]."""
    return int(available_bytes() * BUDGET_FRACTION)


def size_text(n_bytes: float) -> str:
    """1.5 GB, 320 MB, 12 kB (decimal units)."""
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n_bytes >= scale:
            return f"{n_bytes / scale:,.1f} {unit}"
    return f"{int(n_bytes)} B"


def team_bytes(strategy: str, robots: int, vertices: int) -> float:
    """Estimated peak memory [B] of a run of `robots` robots of `strategy` on `vertices`."""
    c = TEAM_COEFFS.get(str(strategy).lower(), _TEAM_DEFAULT)
    n, v = float(robots), float(vertices)
    return (BASE_BYTES + c["n2"] * n * n + c["n3"] * n ** 3 + c["nv"] * n * v
            + c["v2"] * v * v + c["nv2"] * n * v * v + RECORDER_BYTES_PER_PAIR * n * n)


def largest(fits, upper: int) -> int:
    """The largest k in 0 .. upper with fits(k) (fits is monotone: true, then false)."""
    lo, hi = 0, upper
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if fits(mid):
            lo = mid
        else:
            hi = mid - 1
    return lo


def check_team(strategy: str, robots: int, vertices: int, option: str = "--robots",
               map_name: str = "") -> None:
    """Refuse a team whose estimated memory exceeds the budget, naming the largest that fits."""
    budget = budget_bytes()
    need = team_bytes(strategy, robots, vertices)
    if need <= budget:
        return
    most = largest(lambda k: team_bytes(strategy, k, vertices) <= budget, robots)
    on = f" on {map_name}" if map_name else ""
    raise CliError(f"{option} {robots}: {strategy} with {robots:,} robots{on} ({vertices:,} "
                   f"vertices) needs about {size_text(need)} of memory, more than the "
                   f"{size_text(budget)} this machine can give; at most {most:,} robots fit")


def check_runs(runs: int, per_seed: int, seeds: int) -> None:
    """Refuse a sweep whose bookkeeping (per run) cannot fit; name the largest --seeds."""
    budget = budget_bytes() - BASE_BYTES
    need = float(runs) * SWEEP_BYTES_PER_RUN
    if need <= budget:
        return
    most = max(0, budget // (SWEEP_BYTES_PER_RUN * max(per_seed, 1)))
    raise CliError(f"--seeds {seeds}: {runs:,} runs need about {size_text(need)} of memory for "
                   f"their bookkeeping alone, more than the {size_text(max(budget, 0))} this "
                   f"machine can give; at most --seeds {most:,} fits"
                   + ("" if most else " (fewer maps, strategies or team sizes)"))


def max_workers() -> int:
    """Local Dask worker processes this machine holds: 4 per core, and their memory."""
    import os

    return max(1, min(4 * (os.cpu_count() or 1), budget_bytes() // WORKER_BYTES))


def check_frames(frames: float, option: str, what_fits: str) -> None:
    """Refuse an animation of more than MAX_FRAMES frames."""
    if frames > MAX_FRAMES:
        raise CliError(f"{option}: {frames:,.0f} frames, more than the {MAX_FRAMES:,} an "
                       f"animation may hold; {what_fits}")
