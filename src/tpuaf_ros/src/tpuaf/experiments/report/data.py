"""The inputs of a report: DIR/results.csv (rebuilt from DIR/runs/ first when present),
DIR/samples.csv.gz, DIR/reference.csv, DIR/sweep.json, and the paper's figures and best-known
tours beside the repository (../shared/reference/)."""

from __future__ import annotations

import csv
import gzip
import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from tpuaf.experiments.report.common import (
    NOMINAL,
    ReportError,
    Stat,
    _map_order,
    _strategy_order,
    stat,
)


def _float(text: str | None) -> float:
    try:
        return float(text) if text not in (None, "") else math.nan
    except ValueError:
        return math.nan


@dataclass
class Progress:
    """How far the folder's last sweep got (DIR/plan.json, the folder's writer lock)."""

    planned: int | None  # runs the last sweep planned (None: no plan.json, an older folder)
    finished: int  # of those, finished (summary.json) ...
    failed: int  # ... failed (error.txt) ...
    missing: list[str]  # ... and neither: not run yet, running, or lost (run folders)
    state: str  # "complete", "running", "interrupted"
    writer: str | None = None  # pid of the process writing the folder now

    @property
    def complete(self) -> bool:
        return self.state == "complete"

    def line(self) -> str:
        """One sentence for the report's header."""
        if self.planned is None:
            return ("The sweep is still running (pid " + str(self.writer) + "): figures may "
                    "change." if self.state == "running" else "")
        done = (f"{self.finished} of {self.planned} planned runs finished, {self.failed} "
                f"failed, {len(self.missing)} missing")
        if self.complete:
            return f"Sweep complete: {done}."
        why = (f"the sweep is still running (pid {self.writer})" if self.state == "running"
               else "the sweep was interrupted (re-run the same `tpuaf compare` to finish it)")
        return (f"**Sweep incomplete: {done}; {why}. Every verdict and table below is "
                "provisional.**")


def sweep_progress(root: Path, writer: str | None) -> Progress:
    """Progress of the last sweep into `root`; `writer`: the pid holding its lock, if any."""
    import json

    plan_path = root / "plan.json"
    try:
        plan = json.loads(plan_path.read_text()) if plan_path.is_file() else None
        planned = [str(p) for p in plan["planned"]] if plan else None
    except (OSError, ValueError, KeyError, TypeError):
        raise ReportError(f"{plan_path}: unreadable (not the plan `tpuaf compare` writes); "
                          "delete it to report without it") from None
    if planned is None:
        return Progress(None, 0, 0, [], "running" if writer else "complete", writer)
    finished = failed = 0
    missing = []
    for rel in planned:
        folder = root / rel
        if (folder / "summary.json").is_file():
            finished += 1
        elif (folder / "error.txt").is_file():
            failed += 1
        else:
            missing.append(rel)
    if writer:
        state = "running"
    elif missing or not plan.get("ended") or plan.get("interrupted"):
        state = "interrupted"
    else:
        state = "complete"
    return Progress(len(planned), finished, failed, missing, state, writer)


@dataclass
class Data:
    rows: list[dict[str, Any]]  # finished runs
    failed: list[dict[str, Any]]
    reference: dict[tuple[str, int], dict[str, float]]
    samples: dict[tuple[str, str, int], np.ndarray]
    paper: dict[tuple[str, int, str, str], float]
    paper_path: Path | None
    sweep: dict[str, Any]
    bounds: dict[tuple[str, int], dict[str, float]] = field(default_factory=dict)
    bounds_path: Path | None = None
    progress: Progress | None = None  # the last sweep's (None: not known)

    def subset(self, scenario: str) -> Data:
        """The runs of one scenario (samples are kept for the nominal one only)."""
        return Data([r for r in self.rows if r["scenario"] == scenario],
                    [r for r in self.failed if r["scenario"] == scenario], self.reference,
                    self.samples if scenario == NOMINAL else {}, self.paper, self.paper_path,
                    self.sweep, self.bounds, self.bounds_path, self.progress)

    def scenarios(self) -> list[str]:
        names = {r["scenario"] for r in self.rows}
        return sorted(names, key=lambda s: (s != NOMINAL, s))

    def maps(self) -> list[str]:
        return _map_order(r["map"] for r in self.rows)

    def strategies(self, map_name: str | None = None) -> list[str]:
        return _strategy_order(r["strategy"] for r in self.rows
                               if map_name is None or r["map"] == map_name)

    def robots(self, map_name: str | None = None) -> list[int]:
        return sorted({r["robots"] for r in self.rows if map_name is None or r["map"] == map_name})

    def stat(self, map_name: str, strategy: str, n: int, column: str) -> Stat:
        return stat(r[column] for r in self.rows
                    if r["map"] == map_name and r["strategy"] == strategy and r["robots"] == n)

    def per_seed(self, map_name: str, strategy: str, n: int, column: str) -> dict[int, float]:
        return {r["seed"]: r[column] for r in self.rows
                if r["map"] == map_name and r["strategy"] == strategy and r["robots"] == n}


def default_paper_path(name: str = "paper_tables.csv") -> Path | None:
    """../shared/reference/<name> beside the repository holding this package."""
    here = Path(__file__).resolve()
    for parent in here.parents:
        if (parent / ".git").exists() or (parent / "launch_scripts").is_dir():
            candidate = parent.parent / "shared" / "reference" / name
            return candidate if candidate.is_file() else None
    return None


def load_bounds(path: Path | None) -> dict[tuple[str, int], dict[str, float]]:
    """patrol_bounds.csv: per (map, N) the best-known tour's worst idleness and the bounds [s]."""
    out: dict[tuple[str, int], dict[str, float]] = {}
    if path is None or not Path(path).is_file():
        return out
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        if "best_known_worst_idleness_s" not in (reader.fieldnames or []):
            raise ReportError(f"{path}: not a bounds table (needs best_known_worst_idleness_s)")
        for line, row in enumerate(reader, start=2):
            try:
                out[(row["map"], int(row["N"]))] = {
                    k: float(v) for k, v in row.items() if k not in ("map", "N") and v}
            except (KeyError, ValueError) as err:
                raise ReportError(f"{path}:{line}: malformed row ({err})") from None
    return out


def load_paper(path: Path | None) -> dict[tuple[str, int, str, str], float]:
    out: dict[tuple[str, int, str, str], float] = {}
    if path is None or not Path(path).is_file():
        return out
    with open(path, newline="") as f:
        for line, row in enumerate(csv.DictReader(f), start=2):
            if row.get("table") not in ("2", "3", "4") or not row.get("N"):
                continue
            try:
                out[(row["map"], int(row["N"]), row["strategy"].lower(), row["metric"])] = float(
                    row["value"])
            except (KeyError, ValueError) as err:
                raise ReportError(f"{path}:{line}: malformed row ({err})") from None
    return out


def load(root: Path, paper: Path | None = None, bounds: Path | None = None) -> Data:
    """The report's inputs, read under the folder's reader lock (a sweep writing there holds
    the writer lock: then read anyway, and the progress says the sweep is running)."""
    from tpuaf.experiments.results_folder import read_lock

    root = Path(root)
    if not root.is_dir():
        raise ReportError(f"{root}: no such folder (run `tpuaf compare --out {root}` first)")
    with read_lock(root) as writer:
        data = _load(root, paper, bounds)
        data.progress = sweep_progress(root, writer)
    return data


def _load(root: Path, paper: Path | None, bounds: Path | None) -> Data:
    from tpuaf.experiments.sweep.tables import write_tables

    if (root / "runs").is_dir():
        write_tables(root)
    results = root / "results.csv"
    if not results.is_file():
        raise ReportError(f"{results}: missing (run `tpuaf compare --out {root}` first)")
    rows, failed = [], []
    with open(results, newline="") as f:
        reader = csv.DictReader(f)
        need = {"map", "strategy", "robots", "seed", "status"}
        if not need <= set(reader.fieldnames or []):
            raise ReportError(f"{results}: not a results table (needs columns {sorted(need)})")
        for line, raw in enumerate(reader, start=2):
            try:
                row: dict[str, Any] = {"map": raw["map"], "strategy": raw["strategy"],
                                       "robots": int(raw["robots"]), "seed": int(raw["seed"])}
            except ValueError as err:
                raise ReportError(f"{results}:{line}: {err}") from None
            for key, value in raw.items():
                if key not in row:
                    row[key] = value if key in ("status", "error", "map_source", "finished_at",
                                                "scenario", "runtime") else _float(value)
            row["scenario"] = row.get("scenario") or NOMINAL  # tables of older sweeps
            row["runtime"] = row.get("runtime") or "graph"
            for key in ("loss", "delay_s", "deaths"):
                if not np.isfinite(row.get(key, math.nan)):
                    row[key] = 0.0
            (rows if raw["status"] == "ok" else failed).append(row)
    if not rows:
        raise ReportError(f"{results}: no finished runs")

    reference: dict[tuple[str, int], dict[str, float]] = {}
    ref_path = root / "reference.csv"
    if ref_path.is_file():
        with open(ref_path, newline="") as f:
            for raw in csv.DictReader(f):
                reference[(raw["map"], int(raw["robots"]))] = {
                    k: _float(v) for k, v in raw.items() if k not in ("map", "robots", "better")}

    samples: dict[tuple[str, str, int], list[float]] = defaultdict(list)
    sample_path = root / "samples.csv.gz"
    if sample_path.is_file():
        with gzip.open(sample_path, "rt", newline="") as f:
            reader = csv.reader(f)
            next(reader, None)
            for fields in reader:  # map, strategy, robots, seed[, scenario], idleness_s
                if len(fields) == 6 and fields[4] != NOMINAL:
                    continue
                samples[(fields[0], fields[1], int(fields[2]))].append(float(fields[-1]))
    sweep = {}
    if (root / "sweep.json").is_file():
        import json

        try:
            sweep = json.loads((root / "sweep.json").read_text())
        except ValueError:
            sweep = {}
    paper_path = paper if paper is not None else default_paper_path()
    if paper is not None and not Path(paper).is_file():
        raise ReportError(f"{paper}: no such file (the paper's figures)")
    bounds_path = bounds if bounds is not None else default_paper_path("patrol_bounds.csv")
    if bounds is not None and not Path(bounds).is_file():
        raise ReportError(f"{bounds}: no such file (the best-known tours)")
    return Data(rows, failed, reference,
                {k: np.asarray(v) for k, v in samples.items()},
                load_paper(paper_path), paper_path if paper_path and Path(paper_path).is_file()
                else None, sweep, load_bounds(bounds_path),
                bounds_path if bounds_path and Path(bounds_path).is_file() else None)
