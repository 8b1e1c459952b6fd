"""Benchmark of what a user pays around a run (issue 21): loading a large map file, drawing
summary.png, and the whole `tpuaf run ... --out DIR` process.

Run: .venv/bin/python benchmarks/bench_results.py [--repeats K] [--label before|after]
Writes benchmarks/results/results_speed.md and keeps every label's figures in
benchmarks/results/results_speed.json (so a "before" measured on the old code stays beside the
"after"). The map is bench_batch.py's generated `grid1000` (40 x 25 lattice at 5.7 m, 1,000
vertices, 1,794 edges) written in our map format (map.yaml + graph.yaml) to a temporary folder.

Figures (medians over `--repeats`, each in a fresh interpreter unless said otherwise):
- map load: `tpuaf.maps.load_map(folder)` in this process (imports done), split into the two
  YAML files read and checked (`load_map_folder` without the graph), the graph build (all-pairs
  shortest paths, C++) and the generated corridor image;
- summary.png: `plots.summary_png` of a results folder of that map (N = 100, 1 h): the first
  call in a fresh interpreter (matplotlib's import included, what `tpuaf run` pays) and the
  repeated calls in that process (a sweep worker drawing the same map again); peak RSS;
- whole process: `tpuaf run --map <folder> --robots 100 --duration 3600 --out DIR`, wall and
  CPU (user + system) time of the child.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import RESULTS, header, write

REPO = Path(__file__).resolve().parents[1]
TPUAF = REPO / ".venv" / "bin" / "tpuaf"
ROBOTS, DURATION_S = 100, 3600.0


def make_map_folder(root: Path) -> Path:
    """bench_batch's grid1000 written as one of our map folders."""
    from bench_batch import make_grid1000
    from tpuaf.maps.mapfile import save_map_folder

    return save_map_folder(make_grid1000(), root / "grid1000")


def uptime() -> str:
    try:
        return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    except OSError:
        return "unknown"


def load_average() -> float:
    return os.getloadavg()[0]


def map_load(folder: Path, repeats: int) -> dict:
    """Medians [s] of load_map and of its parts, in this process."""
    from tpuaf.maps import load_map
    from tpuaf.maps.mapfile import load_map_folder
    from tpuaf.maps.occupancy import corridors_from_graph

    load_map(folder)  # imports, caches of the interpreter
    rows = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        pm = load_map(folder)
        t1 = time.perf_counter()
        load_map_folder(folder)  # the two YAML files read and checked, and the graph built
        t2 = time.perf_counter()
        pm.__dict__.pop("graph", None)  # a cached_property: build it again
        pm.graph  # noqa: B018
        t3 = time.perf_counter()
        corridors_from_graph(pm)
        t4 = time.perf_counter()
        rows.append({"load_map_s": t1 - t0, "yaml_s": (t2 - t1) - (t3 - t2), "graph_s": t3 - t2,
                     "corridors_s": t4 - t3})
    return {k: statistics.median(r[k] for r in rows) for k in rows[0]}


def one_summary(map_folder: str, results: str, repeats: int) -> dict:
    """In a fresh interpreter: the first summary_png (matplotlib import included) and the
    median of `repeats` more, of the results folder `results`, written to a scratch file."""
    from tpuaf.maps import load_map

    pm = load_map(map_folder)
    summary = json.loads((Path(results) / "summary.json").read_text())
    out = Path(tempfile.mkdtemp()) / "summary.png"
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    t0, c0 = time.perf_counter(), time.process_time()
    from tpuaf.experiments import plots

    plots.summary_png(Path(results), pm, summary, path=out)
    first, first_cpu = time.perf_counter() - t0, time.process_time() - c0
    again = []
    for _ in range(repeats):
        t = time.perf_counter()
        plots.summary_png(Path(results), pm, summary, path=out)
        again.append(time.perf_counter() - t)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return {"first_s": first, "first_cpu_s": first_cpu, "again_s": statistics.median(again),
            "rss_mb": rss, "rss_before_mb": rss0, "png_bytes": out.stat().st_size}


def summary_picture(map_folder: Path, results: Path, repeats: int) -> dict:
    runs = []
    for _ in range(repeats):
        out = subprocess.run([sys.executable, __file__, "--one-summary", str(map_folder),
                              str(results)], capture_output=True, text=True, check=True, cwd=REPO)
        runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
    return {k: statistics.median(r[k] for r in runs) for k in runs[0]}


def whole_run(map_folder: Path, out: Path) -> dict:
    """`tpuaf run` as a user types it: wall and CPU [s] of the child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run([str(TPUAF), "run", "--map", str(map_folder), "--robots", str(ROBOTS),
                    "--duration", f"{DURATION_S:g}", "--out", str(out)], capture_output=True,
                   text=True, check=True, cwd=REPO)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    summary = json.loads((out / "summary.json").read_text())
    return {"wall_s": wall, "cpu_s": cpu, "run_wall_s": float(summary["wall_time_s"]),
            "png": (out / "summary.png").is_file()}


def measure(repeats: int) -> dict:
    load_before = load_average()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        folder = make_map_folder(root)
        runs = [whole_run(folder, root / f"run{k}") for k in range(repeats)]
        process = {k: statistics.median(r[k] for r in runs)
                   for k in ("wall_s", "cpu_s", "run_wall_s")}
        process["range"] = (min(r["wall_s"] for r in runs), max(r["wall_s"] for r in runs))
        process["png"] = all(r["png"] for r in runs)
        loads = map_load(folder, repeats)
        picture = summary_picture(folder, root / "run0", repeats)
    return {"when": time.strftime("%Y-%m-%d %H:%M"), "load_before": load_before,
            "load_after": load_average(), "repeats": repeats, "map_load": loads,
            "summary_png": picture, "process": process}


def table(figures: dict) -> list[str]:
    labels = [k for k in ("before", "after") if k in figures] + \
        sorted(k for k in figures if k not in ("before", "after"))
    lines = ["| figure | " + " | ".join(labels) + " |", "|---|" + "---|" * len(labels)]

    def row(name: str, get, fmt: str = "{:.3f}") -> None:
        cells = []
        for label in labels:
            try:
                cells.append(fmt.format(get(figures[label])))
            except (KeyError, TypeError):
                cells.append("-")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")

    row("measured", lambda f: f["when"], "{}")
    row("load average (1 min) before / after", lambda f: f"{f['load_before']:.2f} / "
        f"{f['load_after']:.2f}", "{}")
    row("repeats (median of)", lambda f: f["repeats"], "{}")
    row("map load: `load_map` s", lambda f: f["map_load"]["load_map_s"])
    row("- of which the two YAML files read and checked (`load_map_folder` minus the graph "
        "build) s", lambda f: f["map_load"]["yaml_s"])
    row("- graph build (all-pairs paths, C++) s", lambda f: f["map_load"]["graph_s"])
    row("- generated corridor image s", lambda f: f["map_load"]["corridors_s"])
    row("summary.png, first in a fresh process, wall s", lambda f: f["summary_png"]["first_s"])
    row("summary.png, first in a fresh process, CPU s",
        lambda f: f["summary_png"]["first_cpu_s"])
    row("summary.png, again in that process (same map), wall s",
        lambda f: f["summary_png"]["again_s"])
    row("summary.png process peak RSS MB (before drawing)",
        lambda f: f"{f['summary_png']['rss_mb']:.0f} ({f['summary_png']['rss_before_mb']:.0f})",
        "{}")
    row("summary.png size kB", lambda f: f["summary_png"]["png_bytes"] / 1000.0, "{:.0f}")
    row(f"`tpuaf run` N = {ROBOTS}, {DURATION_S:g} s, --out: wall s (min-max)",
        lambda f: f"{f['process']['wall_s']:.2f} ({f['process']['range'][0]:.2f}-"
        f"{f['process']['range'][1]:.2f})", "{}")
    row("- CPU s (user + system)", lambda f: f["process"]["cpu_s"], "{:.2f}")
    row("- of which the run itself (summary.json wall_time_s) s",
        lambda f: f["process"]["run_wall_s"], "{:.2f}")
    return lines


NOTES = """
*before* = the code before issue 21 (measured with this script before the change); *after* =
map and graph files parsed by libyaml (`tpuaf_core.yamlfile.read_yaml_fast`; the line-tracking
parser only re-reads a folder that fails a check, for the message's line), and summary.png
drawn with matplotlib's object-oriented API (no pyplot), the map as one subsampled image and
one LineCollection of the edges (`plots.map_background`, cached per map content) instead of
one artist per edge over the full 4,500 x 2,800-cell grid. The graph build and the corridor
image are the rest of `load_map` (not YAML)."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--label", default="after",
                        help="name of this measurement's column (before, after, ...)")
    parser.add_argument("--one-summary", nargs=2, metavar=("MAP", "RESULTS"),
                        help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one_summary:
        print(json.dumps(one_summary(*args.one_summary, 3)))
        return
    store = RESULTS / "results_speed.json"
    figures = json.loads(store.read_text()) if store.is_file() else {}
    print(f"machine: `{uptime()}`", flush=True)
    figures[args.label] = measure(args.repeats)
    store.parent.mkdir(parents=True, exist_ok=True)
    store.write_text(json.dumps(figures, indent=2) + "\n")
    lines = [header("Results-folder costs: map load, summary.png, whole `tpuaf run` "
                    "(benchmarks/bench_results.py)")]
    lines.append(
        "Map: bench_batch.py's generated grid1000 (1,000 vertices, 1,794 edges) saved in our "
        "format (graph.yaml 1,000 vertex and 1,794 edge lines). 2 cores shared with other jobs: "
        "the load average is given per column; CPU times are what a quiet machine's wall time "
        "would be. Map load: in-process medians after a warm-up call. summary.png: medians "
        "over fresh interpreters (the first call includes importing matplotlib, as in `tpuaf "
        "run`). Whole process: the `tpuaf` console script as a user types it.\n")
    lines += table(figures)
    lines.append(NOTES)
    lines.append(f"\nReproduce: `.venv/bin/python benchmarks/bench_results.py --label after` "
                 f"(a few minutes); figures of every label are kept in `{store.name}`.\n")
    write("results_speed.md", "\n".join(lines) + "\n")


if __name__ == "__main__":
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    main()
