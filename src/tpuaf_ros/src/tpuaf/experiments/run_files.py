"""The end of a run's results folder: summary.json written so that it never claims a
complete run beside files that are not (`write_summary`), and why a folder is incomplete, for
its readers (`incomplete`: render, report, analyze). Re-exported by tpuaf.experiments.results."""

from __future__ import annotations

import contextlib
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from tpuaf.errors import TpuafError
from tpuaf.files import atomic_write_text

__all__ = ["ResultsError", "incomplete", "write_summary"]


class ResultsError(TpuafError):
    """A results folder cannot be used (a file, unwritable, holding earlier results, or being
    written by another process), or its files could not all be written (a full disk)."""


def write_summary(out_dir: Path, summary: Mapping[str, Any]) -> None:
    """summary.json (atomic). When it cannot be written (a full disk), a short one saying
    "complete": false takes its place if it fits, else none is left: never a stale or a
    "complete" summary beside files that are not. Raises ResultsError then."""
    path = Path(out_dir) / "summary.json"
    try:
        atomic_write_text(path, json.dumps(summary, indent=2) + "\n")
        return
    except OSError as err:
        why = f"{err.strerror or err} ({err.filename or path})"
    short = {"complete": False, "write_error": why}
    try:
        atomic_write_text(path, json.dumps(short) + "\n")
    except OSError:
        with contextlib.suppress(OSError):
            path.unlink()
    raise ResultsError(f"could not write {path}: {why}")


def incomplete(folder: str | Path) -> str | None:
    """Why a run's results folder is not complete (no summary.json, or "complete": false and
    its reasons), None when it is: for the readers (render, report, analyze)."""
    path = Path(folder) / "summary.json"
    try:
        summary = json.loads(path.read_text())
    except FileNotFoundError:
        return "no summary.json (the run did not end, or its files could not be written)"
    except (OSError, ValueError) as err:
        return f"summary.json unreadable ({err})"
    if not isinstance(summary, dict) or summary.get("complete") is True:
        return None
    reasons = [str(summary[k]) for k in ("incomplete_files", "write_error", "end_files")
               if summary.get(k)]
    if summary.get("interrupted") or not reasons:
        reasons.insert(0, "interrupted")
    return '"complete": false: ' + "; ".join(reasons)
