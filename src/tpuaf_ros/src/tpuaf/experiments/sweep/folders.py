"""A run's folder under DIR/runs/ (the layout in tpuaf.experiments.sweep): written as its result
arrives (summary.json last), its samples and key read back."""

from __future__ import annotations

import gzip
import io
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from tpuaf.experiments.sweep.grid import NOMINAL, RunKey, SweepError
from tpuaf.files import atomic_write
from tpuaf.plain import plain


def json_bytes(obj: Any) -> bytes:
    return (json.dumps(plain(obj), indent=1, allow_nan=False) + "\n").encode()


def write_run(root: Path, result: dict[str, Any]) -> Path:
    """Write one run's folder; summary.json last and atomically (it marks the run finished)."""
    task = result["task"]
    key = RunKey(task["map"], task["strategy"], int(task["robots"]), int(task["seed"]),
                 task.get("scenario") or NOMINAL)
    folder = key.folder(root)
    folder.mkdir(parents=True, exist_ok=True)
    summary_path = folder / "summary.json"
    if summary_path.exists():
        summary_path.unlink()  # recomputed: never leave an old summary beside new files
    meta = {"task": task, "host": result.get("host"), "pid": result.get("pid"),
            "wall_time_s": result.get("wall_time_s")}
    if result.get("error"):
        atomic_write(folder / "config.json", json_bytes({**meta, "config": result.get("config")}))
        atomic_write(folder / "error.txt", result["error"].encode())
        return folder
    (folder / "error.txt").unlink(missing_ok=True)
    atomic_write(folder / "config.json", json_bytes({**meta, "config": result["config"]}))
    buf = io.BytesIO()
    with gzip.GzipFile(fileobj=buf, mode="wb", mtime=0) as gz:
        np.savetxt(gz, np.asarray(result["samples"], dtype=float), fmt="%.3f")
    atomic_write(folder / "idleness.txt.gz", buf.getvalue())
    summary = dict(result["summary"])
    summary["run"] = {**task, "wall_time_s": result.get("wall_time_s"),
                      "finished_at": time.strftime("%Y-%m-%dT%H:%M:%S"),
                      "host": result.get("host")}
    atomic_write(summary_path, json_bytes(summary))
    return folder


def read_samples(folder: Path) -> np.ndarray:
    path = Path(folder) / "idleness.txt.gz"
    if not path.exists():
        return np.zeros(0)
    with gzip.open(path, "rt") as f:
        text = f.read()
    return np.array(text.split(), dtype=float)


def finished(root: Path, key: RunKey) -> bool:
    return (key.folder(root) / "summary.json").is_file()


def run_folders(root: Path) -> list[Path]:
    runs = Path(root) / "runs"
    found = list(runs.glob("*/*/N*/seed*")) + list(runs.glob("*/*/N*/*/seed*"))
    return sorted(p for p in found if p.is_dir())


def key_of(folder: Path) -> RunKey:
    seed = folder.name.removeprefix("seed")
    up = folder.parent
    scenario = NOMINAL
    if not (up.name.startswith("N") and up.name[1:].isdigit()):
        scenario, up = up.name, up.parent
    robots = up.name.removeprefix("N")
    return RunKey(up.parent.parent.name, up.parent.name, int(robots), int(seed), scenario)


def load_json(path: Path) -> dict:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as err:
        raise SweepError(f"{path}: unreadable ({err}); delete the file to recompute the run") from None
