"""The team memory estimate of `tpuaf run` (cli/limits.py `team_bytes`) against the peak RSS of
real runs: its error at a few team sizes N and vertex counts V.

    .venv/bin/python benchmarks/bench_limits.py [--duration 120] [--long 3600]

Each case is one `tpuaf run --strategy S --robots N --duration D --quiet` process on the
built-in grid or a generated building map (bench_bigmaps.write_building, in a temporary folder,
never committed); peak RSS is GNU time's %M (the run's own maximum resident set). The estimate is meant as an
upper bound: the ratio estimate / measured should stay >= 1, and not far above. One case is
repeated at `--long` seconds to show what the run's length adds (visits and 1 Hz rows). Also
fits peak = base + a N^2 + b N V by least squares over the gbs cases. Writes
benchmarks/results/limits.md.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_bigmaps import tpuaf_command, write_building  # noqa: E402
from common import header, write  # noqa: E402

# (strategy, robots, vertices: 0 = the built-in grid, extra arguments)
DEATHS = ("--fail", "0@60", "--fail", "5@60")  # tpuaf_plus plans again for the survivors
CASES = [("gbs", 10, 0, ()), ("gbs", 300, 0, ()), ("gbs", 1000, 0, ()),
         ("gbs", 10, 2500, ()), ("gbs", 100, 2500, ()), ("gbs", 300, 2500, ()),
         ("gbs", 10, 10000, ()), ("gbs", 100, 10000, ()), ("gbs", 300, 10000, ()),
         ("tpuaf", 100, 2500, ()), ("cbls", 300, 2500, ()),
         ("tpuaf_plus", 100, 2500, ()), ("tpuaf_plus", 300, 2500, ()),
         ("tpuaf_plus", 600, 2500, ()), ("tpuaf_plus", 1000, 2500, ()),
         ("tpuaf_plus", 600, 2500, DEATHS),
         ("dtag", 10, 10000, ()), ("msp", 10, 10000, ()), ("hpcc", 100, 2500, ()),
         ("dtap", 10, 2500, ()), ("dtap", 30, 2500, ())]
LONG_CASE = ("gbs", 100, 2500, ())


def run_case(strategy: str, robots: int, folder: str, duration: float, extra=()) -> dict:
    """Peak RSS [MiB] and CPU time [s] of one run, measured by GNU time: a child forked from
    this (large) Python process would count the parent's pages in its ru_maxrss."""
    cmd = tpuaf_command() + ["run", "--map", folder, "--strategy", strategy, "--robots",
                             str(robots), "--duration", f"{duration:g}", "--quiet", *extra]
    with tempfile.NamedTemporaryFile("r") as stats:
        proc = subprocess.run(["/usr/bin/time", "-o", stats.name, "-f", "%M %U %S", *cmd],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                              check=False)
        if proc.returncode != 0:
            print(f"  exit {proc.returncode}: {' '.join(cmd)}\n{proc.stderr[-2000:]}",
                  file=sys.stderr)
        fields = stats.read().split()[-3:]
    peak_kb, user, system = float(fields[0]), float(fields[1]), float(fields[2])
    return {"peak_mb": peak_kb / 1024.0, "cpu_s": user + system, "exit": proc.returncode}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=120.0)
    parser.add_argument("--long", type=float, default=3600.0)
    parser.add_argument("--strategies", default="", help="only these cases (comma-separated; "
                        "no long run), e.g. dtap; default: every case")
    parser.add_argument("--out", default="limits", help="results file stem")
    args = parser.parse_args()
    chosen = [c for c in CASES if not args.strategies or c[0] in args.strategies.split(",")]
    from tpuaf.cli import limits
    from tpuaf.maps import load_map

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        maps = {0: "grid"}
        for v in sorted({c[2] for c in chosen if c[2]}):
            maps[v] = str(write_building(Path(tmp) / f"b{v}", v))
        sizes = {v: load_map(m).num_vertices for v, m in maps.items()}
        cases = [(*c, args.duration) for c in chosen]
        if not args.strategies:
            cases.append((*LONG_CASE, args.long))
        for strategy, n, v, extra, duration in cases:
            r = run_case(strategy, n, maps[v], duration, extra)
            vertices = sizes[v]
            estimate = limits.team_bytes(strategy, n, vertices) / 2**20
            rows.append({"strategy": strategy, "robots": n, "vertices": vertices,
                         "faults": "2 deaths" if extra else "",
                         "duration_s": duration, "peak_mb": r["peak_mb"], "cpu_s": r["cpu_s"],
                         "estimate_mb": estimate, "ratio": estimate / r["peak_mb"],
                         "exit": r["exit"]})
            print(rows[-1], flush=True)
    write(f"{args.out}.md", report(rows, args))


def fit(rows: list[dict], duration: float) -> tuple[float, float, float]:
    """Least squares peak [MiB] = base + a N^2 + b N V over the short gbs runs; a, b in B."""
    use = [r for r in rows if r["strategy"] == "gbs" and r["duration_s"] == duration]
    if len(use) < 3:
        return float("nan"), float("nan"), float("nan")
    n = np.array([r["robots"] for r in use], dtype=float)
    v = np.array([r["vertices"] for r in use], dtype=float)
    y = np.array([r["peak_mb"] for r in use]) * 2**20
    design = np.column_stack((np.ones_like(n), n * n, n * v))
    (base, a, b), *_ = np.linalg.lstsq(design, y, rcond=None)
    return base / 2**20, a, b


def report(rows: list[dict], args: argparse.Namespace) -> str:
    from tpuaf.cli import limits

    out = header("Team memory estimate against measured peak RSS (cli/limits.py)")
    only = f" --strategies {args.strategies} --out {args.out}" if args.strategies else ""
    out += ("`.venv/bin/python benchmarks/bench_limits.py --duration "
            f"{args.duration:g} --long {args.long:g}{only}`: one `tpuaf run --map MAP --strategy S "
            "--robots N --duration D --quiet` process per row (the graph runtime), peak RSS "
            "= GNU time's %M; MAP: the built-in grid or a generated building of V "
            "vertices (bench_bigmaps.write_building). Estimate: `limits.team_bytes` (MiB), "
            "an upper bound by design (ratio >= 1).\n\n")
    out += ("| strategy | N | V | faults | duration [s] | peak RSS [MiB] | estimate [MiB] | "
            "estimate / peak | CPU [s] |\n|---|---:|---:|---|---:|---:|---:|---:|---:|\n")
    for r in rows:
        out += (f"| {r['strategy']} | {r['robots']:,} | {r['vertices']:,} | {r['faults']} | "
                f"{r['duration_s']:g} | {r['peak_mb']:.0f} | {r['estimate_mb']:.0f} | "
                f"{r['ratio']:.2f} | {r['cpu_s']:.1f} |\n")
    base, a, b = fit(rows, args.duration)
    ratios = [r["ratio"] for r in rows]
    out += (f"\nLeast-squares fit over the gbs rows of {args.duration:g} s: peak = "
            f"{base:.0f} MiB + {a:.0f} B N^2 + {b:.1f} B N V. Constants in force: BASE "
            f"{limits.BASE_BYTES / 2**20:.0f} MiB, recorder {limits.RECORDER_BYTES_PER_PAIR:g} "
            f"B N^2, gbs {limits.TEAM_COEFFS['gbs']['n2']:g} B N^2 and "
            f"{limits.TEAM_COEFFS['gbs']['nv']:g} B N V. Estimate / peak: "
            f"{min(ratios):.2f} to {max(ratios):.2f}.\n")
    return out


if __name__ == "__main__":
    main()
