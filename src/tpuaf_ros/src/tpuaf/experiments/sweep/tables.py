"""The tidy tables of a results folder, rebuilt from its run folders: results.csv (one row per
run), samples.csv.gz (the fault-free runs' interval idleness samples), reference.csv (reference
tours per map and N)."""

from __future__ import annotations

import csv
import gzip
import io
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from tpuaf.experiments.run_files import incomplete
from tpuaf.experiments.sweep.folders import key_of, load_json, read_samples, run_folders
from tpuaf.experiments.sweep.grid import MapSpec, RunKey
from tpuaf.files import atomic_write

# Columns of results.csv: the run key, its status, then the metrics of the summary.
KEY_COLUMNS = ["map", "strategy", "robots", "seed", "duration_s"]
# The scenario of a run: its name and what it sets (deaths = robots that die, at death_time_s).
SCENARIO_COLUMNS = ["scenario", "runtime", "loss", "delay_s", "deaths", "death_time_s"]
METRIC_COLUMNS = [
    "idleness_avg_s", "idleness_std_s", "idleness_min_s", "idleness_max_s", "idleness_samples",
    "idleness_ins_mean_s", "worst_idleness_s", "uncertainty_mean", "uncertainty_final_mean",
    "interferences", "interference_rate_per_min", "visits", "counted_visits",
    "complete_cycles", "unvisited_vertices",
]
# Recovery after deaths (summary "recovery", one entry per death; H-A's fault injection):
# the slowest recovery, the worst idleness after a death, the N - 1 survivors' ideal, the floor
# no strategy could avoid (metrics.death_floor) from the death and from its detection (the
# teammate timeout later), the dead robots' intentions still honoured (sum) and the deaths
# never recovered from.
RECOVERY_COLUMNS = ["recovery_time_s", "worst_idleness_after_s",
                    "ideal_worst_idleness_survivors_s", "floor_worst_idleness_after_s",
                    "detection_floor_worst_idleness_after_s", "intentions_honoured",
                    "unrecovered"]
RESULT_COLUMNS = KEY_COLUMNS + SCENARIO_COLUMNS + ["status", "error"] + METRIC_COLUMNS + \
    RECOVERY_COLUMNS + ["wall_time_s", "finished_at", "map_source"]
SAMPLE_COLUMNS = ["map", "strategy", "robots", "seed", "scenario", "idleness_s"]
REFERENCE_COLUMNS = [
    "map", "robots", "speed_mps",
    "cyclic_length_m", "cyclic_worst_idleness_s", "cyclic_avg_idleness_time_s",
    "cyclic_avg_idleness_visit_s",
    "partition_parts", "partition_worst_idleness_s", "partition_avg_idleness_time_s",
    "partition_avg_idleness_visit_s", "better",
]



def _scenario_fields(key: RunKey, task: dict[str, Any]) -> dict[str, Any]:
    """The scenario columns of a run (tasks of older sweeps have none: nominal graph runs)."""
    return {"scenario": key.scenario, "runtime": task.get("runtime") or "graph",
            "loss": task.get("loss") or 0.0, "delay_s": task.get("delay_s") or 0.0,
            "deaths": task.get("deaths") or 0, "death_time_s": task.get("death_time_s")}


def _recovery_fields(summary: dict[str, Any]) -> dict[str, Any]:
    entries = [e for e in (summary.get("recovery") or []) if isinstance(e, dict)]
    if not entries:
        return {}

    def values(name):
        return [float(e[name]) for e in entries if isinstance(e.get(name), (int, float))]

    rec, after = values("recovery_time_s"), values("worst_idleness_after_s")
    ideal, honoured = values("ideal_worst_idleness_survivors_s"), values("intentions_honoured")
    floor = values("floor_worst_idleness_after_s")
    detect = [v for v in values("detection_floor_worst_idleness_after_s") if v == v]
    return {"recovery_time_s": max(rec) if rec else None,
            "worst_idleness_after_s": max(after) if after else None,
            "ideal_worst_idleness_survivors_s": max(ideal) if ideal else None,
            "floor_worst_idleness_after_s": max(floor) if floor else None,
            "detection_floor_worst_idleness_after_s": max(detect) if detect else None,
            "intentions_honoured": sum(honoured) if honoured else None,
            "unrecovered": len(entries) - len(rec)}


def collect(root: Path) -> list[dict[str, Any]]:
    """One row per run folder: finished (summary.json), incomplete (its "complete": false) or
    failed (error.txt)."""
    rows = []
    for folder in run_folders(root):
        key = key_of(folder)
        base = {"map": key.map, "strategy": key.strategy, "robots": key.robots, "seed": key.seed}
        summary_path = folder / "summary.json"
        if summary_path.is_file():
            s = load_json(summary_path)
            run = s.get("run", {})
            # "complete": false (interrupted, a full disk): listed with the failed runs
            why = incomplete(folder) if s.get("complete") is False else None
            row = {**base, "duration_s": run.get("duration_s", s.get("duration_s")),
                   **_scenario_fields(key, run), "status": "incomplete" if why else "ok",
                   "error": why or ""}
            row.update({c: s.get(c) for c in METRIC_COLUMNS})
            row.update(_recovery_fields(s))
            row.update({"wall_time_s": run.get("wall_time_s"), "finished_at": run.get("finished_at"),
                        "map_source": run.get("map_source")})
        elif (folder / "error.txt").is_file():
            meta = load_json(folder / "config.json") if (folder / "config.json").is_file() else {}
            task = meta.get("task", {})
            first = (folder / "error.txt").read_text().strip().splitlines()
            row = {**base, "duration_s": task.get("duration_s"), **_scenario_fields(key, task),
                   "status": "error", "error": first[0] if first else "error",
                   "wall_time_s": meta.get("wall_time_s"), "map_source": task.get("map_source")}
        else:
            continue  # interrupted before anything was written
        rows.append(row)
    return rows


def _csv_text(rows: list[dict], columns: list[str]) -> str:
    out = io.StringIO()
    w = csv.DictWriter(out, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for row in rows:
        w.writerow({c: ("" if row.get(c) is None else row.get(c)) for c in columns})
    return out.getvalue()


def write_tables(root: Path) -> tuple[Path, Path]:
    """Rebuild results.csv and samples.csv.gz from the run folders (atomically)."""
    root = Path(root)
    rows = collect(root)
    results = root / "results.csv"
    atomic_write(results, _csv_text(rows, RESULT_COLUMNS).encode())
    out = io.StringIO()
    out.write(",".join(SAMPLE_COLUMNS) + "\n")
    for row in rows:
        if row["status"] != "ok" or row["loss"] or row["delay_s"] or row["deaths"]:
            continue  # the box plots show fault-free runs only
        samples = read_samples(RunKey(row["map"], row["strategy"], row["robots"],
                                      row["seed"], row["scenario"]).folder(root))
        prefix = f"{row['map']},{row['strategy']},{row['robots']},{row['seed']},{row['scenario']},"
        out.writelines(f"{prefix}{v:.3f}\n" for v in samples)
    buf = io.BytesIO()
    with gzip.GzipFile(fileobj=buf, mode="wb", mtime=0) as gz:
        gz.write(out.getvalue().encode())
    samples_path = root / "samples.csv.gz"
    atomic_write(samples_path, buf.getvalue())
    return results, samples_path


def reference_rows(maps: list[MapSpec], robots: Iterable[int],
                   map_params: dict[str, Any] | None = None) -> list[dict[str, Any]]:
    """Reference tours (tours.py) per (map, N) at the map's nominal speed (after the
    `map_params` overrides)."""
    from tpuaf.maps import load_map
    from tpuaf.maps.tours import reference_tours

    rows = []
    for spec in maps:
        pm = load_map(spec.source, params=map_params, params_origin="--map-param")
        speed = float(pm.settings.nominal_speed)
        for n in sorted(set(robots)):
            r = reference_tours(pm, n, speed)
            c, p = r["cyclic"], r["partition"]
            rows.append({
                "map": spec.label, "robots": n, "speed_mps": speed,
                "cyclic_length_m": c["length_m"], "cyclic_worst_idleness_s": c["worst_idleness_s"],
                "cyclic_avg_idleness_time_s": c["avg_idleness_time_s"],
                "cyclic_avg_idleness_visit_s": c["avg_idleness_visit_s"],
                "partition_parts": len(p["parts"]),
                "partition_worst_idleness_s": p["worst_idleness_s"],
                "partition_avg_idleness_time_s": p["avg_idleness_time_s"],
                "partition_avg_idleness_visit_s": p["avg_idleness_visit_s"],
                "better": r["better"],
            })
    return rows


def write_reference(root: Path, maps: list[MapSpec], robots: Iterable[int],
                    map_params: dict[str, Any] | None = None) -> Path:
    """Merge the reference tours of these (map, N) into DIR/reference.csv."""
    path = Path(root) / "reference.csv"
    old = []
    if path.is_file():
        with open(path, newline="") as f:
            old = list(csv.DictReader(f))
    new = reference_rows(maps, robots, map_params)
    fresh = {(r["map"], int(r["robots"])) for r in new}
    keep = [r for r in old if (r["map"], int(r["robots"])) not in fresh]
    rows = sorted(keep + new, key=lambda r: (r["map"], int(r["robots"])))
    atomic_write(path, _csv_text(rows, REFERENCE_COLUMNS).encode())
    return path
