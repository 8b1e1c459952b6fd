"""The results folder of a run (SPEC section 6, docs/RESULTS.md).

    config.yaml      effective configuration, written at start
    visits.csv       one row per visit, streamed (time_s, robot, vertex_id, vertex_index,
                     interval_idleness_s)
    timeseries.csv   the 1 Hz rows of RunRecorder, streamed
    summary.json     every metric, at the end ("complete": false when interrupted)
    info.csv, idleness.csv, timeresults.csv   patrolling_sim-compatible files (';' separated)

Streamed files are flushed after every batch of rows, so an interrupted run leaves valid CSV
files for what was simulated. The end files (summary.json, config.yaml, the patrolling_sim files)
are written atomically (tpuaf.files: a temporary file beside them, fsynced, then a rename), so
that a reader (or a kill) never sees half a file. The folder's manifest of what tpuaf wrote and
its writer lock: tpuaf.experiments.results_folder.
"""

from __future__ import annotations

import contextlib
import csv
import itertools
import math
import socket
import time
from collections.abc import Callable, Iterable, Iterator, Mapping
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from tpuaf.experiments.results_folder import record_written
from tpuaf.experiments.run_files import ResultsError, write_summary
from tpuaf.files import atomic_file, atomic_write_text, open_fresh
from tpuaf.measure.metrics import TIMESERIES_COLUMNS
from tpuaf.plain import plain

VISIT_COLUMNS = ["time_s", "robot", "vertex_id", "vertex_index", "interval_idleness_s"]
# patrolling_sim monitor's files (monitor.cpp), same columns and separators.
PS_IDLENESS_HEADER = ["Time", "Robot", "Node", "Idleness", "Interferences"]
PS_TIMERESULTS_HEADER = ["Time", "Idleness min", "Idleness avg", "Idleness stddev",
                         "Idleness max", "Interferences"]
PS_INFO_COLUMNS = ["map", "teamsize", "initial_positions", "goal_reached_wait_s",
                   "communication_delay_s", "navigation_module", "algorithm", "algorithm_params",
                   "hostname", "date", "duration_s", "real_duration_s", "interferences",
                   "termination", "idleness_min_s", "idleness_avg_s", "idleness_stddev_s",
                   "idleness_max_s", "interference_rate_per_min", "visits",
                   "avg_visits_per_vertex", "complete_patrol_cycles"]

MAX_PICTURE_ROWS = 2_000_000  # summary.png reads all of timeseries.csv: not for longer runs
VISIT_CHUNK = 20_000  # rows of visits.csv read back at a time (a stop is seen between chunks)


class _Stopped(Exception):
    """A stop signal arrived while the end files were written."""


def _finite_or_empty(column: list) -> list:
    """A column for the csv module: Python numbers (floats written repr-exact), None (an
    empty cell) in place of None, NaN and infinities."""
    try:
        finite = bool(np.isfinite(np.asarray(column, dtype=float)).all())
    except (TypeError, ValueError):
        finite = False
    if finite and all(type(v) in (int, float) for v in column[:1]) and \
            len({type(v) for v in column}) == 1:
        return column  # Python numbers as they are: the fast path of every long run
    return [_cell(v) for v in column]


def _cell(value: Any) -> Any:
    if value is None:
        return None
    if isinstance(value, float | np.floating):
        value = float(value)
        return value if math.isfinite(value) else None
    if isinstance(value, np.integer | np.bool_):
        return int(value)
    return value


class _RunningStats:
    """Min, mean, population std and max of samples added in batches (Chan et al.'s merge of
    means and squared deviations)."""

    def __init__(self) -> None:
        self.n, self.mean, self.m2 = 0, 0.0, 0.0
        self.lo, self.hi = math.inf, -math.inf

    def add(self, values: np.ndarray) -> None:
        if not len(values):
            return
        nb, mb = len(values), float(values.mean())
        m2b = float(((values - mb) ** 2).sum())
        n = self.n + nb
        delta = mb - self.mean
        self.mean += delta * nb / n
        self.m2 += m2b + delta * delta * self.n * nb / n
        self.n = n
        self.lo, self.hi = min(self.lo, float(values.min())), max(self.hi, float(values.max()))

    def row(self) -> tuple[float, float, float, float]:
        if not self.n:
            return (math.nan,) * 4
        return self.lo, self.mean, math.sqrt(max(self.m2, 0.0) / self.n), self.hi


def _f1(value: float | None) -> str:
    return "nan" if value is None or not math.isfinite(value) else f"{value:.1f}"


class ResultsWriter:
    """Writes one run's results folder; usable as a context manager.

    with ResultsWriter(out_dir, config) as writer:
        ... writer.sync(recorder) from time to time ...
        writer.finish(recorder.summary(end), recorder)
    Leaving the block by an exception (Ctrl-C, crash) without `finish` calls
    `finish(None, recorder_last_synced, interrupted=True)` when a recorder was synced.
    """

    def __init__(self, out_dir: str | Path, config: Mapping[str, Any], plots: bool = True):
        self.plots = plots  # False: no summary.png (`tpuaf run --no-plots`)
        self.out_dir = Path(out_dir)
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self.config = plain(dict(config))
        self._wall_start = time.time()
        self._date = datetime.now().strftime("%Y%m%d_%H%M%S")
        with contextlib.suppress(FileNotFoundError):  # an earlier run's: never mixed with ours
            (self.out_dir / "summary.json").unlink()
        record_written(self.out_dir, "config.yaml", "visits.csv", "timeseries.csv",
                       "summary.json", "info.csv", "idleness.csv", "timeresults.csv")
        atomic_write_text(self.out_dir / "config.yaml",
                          yaml.safe_dump(self.config, sort_keys=False, default_flow_style=False))
        self._visits_f = open_fresh(self.out_dir / "visits.csv", "w", newline="")
        self._visits = csv.writer(self._visits_f)
        self._visits.writerow(VISIT_COLUMNS)
        self._ts_f = open_fresh(self.out_dir / "timeseries.csv", "w", newline="")
        self._ts = csv.writer(self._ts_f)
        self._ts.writerow(TIMESERIES_COLUMNS)
        self._visits_f.flush()
        self._ts_f.flush()
        self._n_visits = 0
        self._n_rows = 0
        self._last_visit_s = -math.inf
        self._recorder: Any = None
        self.finished = False
        self.write_error: str | None = None  # the first failed write (a full disk): incomplete

    # -- streaming --------------------------------------------------------------------------

    def write_visits(self, rows: Iterable[tuple[float, int, int, int, float]]) -> None:
        """Rows (time_s, robot, vertex_id, vertex_index, interval_idleness_s or NaN), written
        column-wise in one call of the csv module."""
        rows = list(rows)
        if not rows:
            return
        t, robot, vid, index, idl = (list(c) for c in zip(*rows, strict=True))
        cols = [_finite_or_empty(t), [int(x) for x in robot], [int(x) for x in vid],
                [int(x) for x in index], _finite_or_empty(idl)]
        self._visits.writerows(zip(*cols, strict=True))
        self._visits_f.flush()
        self._n_visits += len(rows)
        self._last_visit_s = max(self._last_visit_s, float(t[-1]))

    def write_timeseries(self, rows: Iterable[Mapping[str, Any]]) -> None:
        """1 Hz rows (mappings of TIMESERIES_COLUMNS), written column-wise in one call."""
        rows = rows if isinstance(rows, list) else list(rows)
        if not rows:
            return
        cols = [_finite_or_empty([row[c] for row in rows]) for c in TIMESERIES_COLUMNS]
        self._ts.writerows(zip(*cols, strict=True))
        self._ts_f.flush()
        self._n_rows += len(rows)

    def sync(self, recorder: Any) -> None:
        """Write the visits and 1 Hz rows the recorder gained since the last sync. A recorder
        that can forget them (`forget_visits_before`, `forget_timeseries_before`: the C++
        loop's) drops them once written: a long run's memory stays bounded. A failed write (a
        full disk) is remembered, not raised: the run goes on, its summary says "complete":
        false."""
        self._recorder = recorder
        if self.write_error is not None:
            return
        try:
            self._sync(recorder)
        except OSError as err:
            self._failed(err)

    def _failed(self, err: OSError) -> None:
        if self.write_error is None:
            self.write_error = f"{err.strerror or err} ({err.filename or self.out_dir})"

    def _sync(self, recorder: Any) -> None:
        ids = recorder.patrol_map.vertex_ids
        if hasattr(recorder, "visits_since"):
            new_visits, idl = recorder.visits_since(self._n_visits)
        else:
            new_visits = recorder.visits[self._n_visits:]
            idl = recorder.visit_idleness[self._n_visits:]
        self.write_visits(
            (t, r, ids[v], v, i) for (t, r, v), i in zip(new_visits, idl, strict=True)
        )
        if hasattr(recorder, "forget_visits_before"):
            recorder.forget_visits_before(self._n_visits)
        if hasattr(recorder, "forget_timeseries_before"):
            self.write_timeseries(recorder.timeseries_since(self._n_rows))
            recorder.forget_timeseries_before(self._n_rows)
        else:
            self.write_timeseries(recorder.timeseries[self._n_rows:])

    # -- end ----------------------------------------------------------------------------------

    def finish(self, summary: Mapping[str, Any] | None, recorder: Any,
               interrupted: bool = False, timeresults_period_s: float = 900.0,
               should_stop: Callable[[], bool] | None = None) -> None:
        """Write summary.json and the patrolling_sim files; close the streams.

        `summary`: recorder.summary(end_time) (computed here from the recorder's last time when
        None). timeresults.csv gets one row of cumulative global idleness per
        `timeresults_period_s` of run time (patrolling_sim writes one per 900 s). The end files
        are made from the streamed visits.csv, in chunks (linear time, bounded memory);
        `should_stop()` is asked between chunks: when it turns true (a signal while writing),
        the files not yet written are skipped and summary.json says "complete": false."""
        if self.finished:
            return
        stop = should_stop or (lambda: False)
        if recorder is not None:
            self.sync(recorder)
            if summary is None:
                summary = recorder.summary(self._last_time(recorder))
                self.sync(recorder)
        summary = dict(plain(summary or {}))
        summary["real_duration_s"] = time.time() - self._wall_start
        for f in (self._visits_f, self._ts_f):
            try:
                f.close()
            except OSError as err:
                self._failed(err)
        cut = False
        if recorder is not None and self.write_error is None:
            try:
                cut = not self._write_patrolling_sim(summary, recorder, interrupted,
                                                     timeresults_period_s, stop)
            except _Stopped:
                cut = True
            except OSError as err:
                self._failed(err)
            if not cut and not stop() and self.plots and self.write_error is None:
                if interrupted:  # a stopped run ends at once: the picture can come later
                    summary["summary_png"] = ("not drawn: the run was interrupted (`tpuaf "
                                              "render --summary` draws it)")
                elif self._n_rows > MAX_PICTURE_ROWS:
                    summary["summary_png"] = (f"not drawn: {self._n_rows:,} rows of "
                                              f"timeseries.csv (more than {MAX_PICTURE_ROWS:,})")
                else:
                    from tpuaf.experiments.plots import (
                        write_summary_png,  # never raises: a note when it cannot draw
                    )

                    write_summary_png(self.out_dir, recorder.patrol_map, summary)
        if stop():
            cut = True
        summary["complete"] = not interrupted and not cut and self.write_error is None
        if cut:
            summary["end_files"] = "cut short by a stop signal while they were written"
        if self.write_error is not None:
            summary["write_error"] = self.write_error
        summary["real_duration_s"] = time.time() - self._wall_start
        # last: a summary.json means every other file is complete
        self.finished = True
        write_summary(self.out_dir, summary)
        if self.write_error is not None:
            raise ResultsError(f"could not write every results file in {self.out_dir}: "
                               f"{self.write_error}; summary.json says \"complete\": false")

    def _last_time(self, recorder: Any) -> float:
        times = [recorder.start_time, self._last_visit_s]
        if getattr(recorder, "_pos_time", None) is not None:
            times.append(recorder._pos_time)
        return max(times)

    def _visit_chunks(self) -> Iterator[tuple[np.ndarray, np.ndarray, list[str], np.ndarray]]:
        """visits.csv back in chunks of VISIT_CHUNK rows: (time_s, robot, vertex_id (text),
        interval idleness, NaN for a first visit)."""
        with open(self.out_dir / "visits.csv", newline="") as f:
            reader = csv.reader(f)
            next(reader, None)
            while True:
                rows = list(itertools.islice(reader, VISIT_CHUNK))
                if not rows:
                    return
                t = np.array([float(r[0]) for r in rows])
                robot = np.array([int(r[1]) for r in rows])
                idl = np.array([float(r[4]) if r[4] else math.nan for r in rows])
                yield t, robot, [r[2] for r in rows], idl

    def _write_patrolling_sim(self, summary: dict, recorder: Any, interrupted: bool,
                              period_s: float, stop: Callable[[], bool]) -> bool:
        """idleness.csv, timeresults.csv and info.csv; False when `stop()` cut them short."""
        inter_times = np.array([t for t, _, _ in recorder.interferences], dtype=float)
        start = recorder.start_time
        duration = float(summary.get("duration_s") or 0.0)
        k_last = int(math.floor((duration + 1e-9) / period_s)) if period_s > 0 else 0
        stats = _RunningStats()
        timeresults = [";".join(PS_TIMERESULTS_HEADER) + "\n"]
        k = 1

        def emit_until(limit_s: float) -> None:  # rows k .. of the periods ending before limit
            nonlocal k
            while k <= k_last and start + k * period_s < limit_s:
                tk = start + k * period_s
                timeresults.append(f"{k * period_s:.1f};" + ";".join(_f1(x) for x in stats.row())
                                   + f";{int(np.searchsorted(inter_times, tk, side='right'))}\n")
                k += 1

        with atomic_file(self.out_dir / "idleness.csv", "w", newline="") as f:
            f.write(";".join(PS_IDLENESS_HEADER) + "\n")
            for t, robot, vid, idl in self._visit_chunks():
                if stop():
                    raise _Stopped
                keep = ~np.isnan(idl)  # a vertex's first visit has no idleness (patrolling_sim)
                inter = np.searchsorted(inter_times, t, side="right")
                f.write("".join(f"{t[j] - start:.1f};{robot[j]};{vid[j]};{idl[j]:.1f};"
                                f"{inter[j]}\n" for j in np.flatnonzero(keep)))
                ts, vals = t[keep], idl[keep]
                pos = 0
                while pos < len(ts):  # samples up to each period's end, then its row
                    emit_until(float(ts[pos]))
                    tk = start + k * period_s if k <= k_last else math.inf
                    end = int(np.searchsorted(ts, tk, side="right"))
                    stats.add(vals[pos:end])
                    pos = end
            emit_until(math.inf)
        atomic_write_text(self.out_dir / "timeresults.csv", "".join(timeresults))
        self._write_info(summary, recorder, interrupted, duration)
        return True

    def _write_info(self, summary: dict, recorder: Any, interrupted: bool,
                    duration: float) -> None:
        cfg = self.config
        dead = bool(summary.get("deaths"))
        termination = "FAIL" if dead else ("ABORT" if interrupted else "TIMEOUT")
        n = recorder.n_vertices
        counted = int(summary.get("counted_visits") or 0)
        params = cfg.get("strategy_params", cfg.get("params", ""))
        if isinstance(params, dict):
            params = ",".join(f"{k}={v}" for k, v in params.items())
        info = [
            recorder.patrol_map.name,  # the map name, as patrolling_sim (not a path)
            str(cfg.get("n_robots", recorder.n_robots)),
            str(cfg.get("initial_positions", "default")),
            f"{float(cfg.get('goal_reached_wait_s', 0.0)):.1f}",
            f"{float(cfg.get('communication_delay_s', cfg.get('comm_delay_s', 0.0))):.2f}",
            str(cfg.get("navigation_module", cfg.get("runtime", "tpuaf"))),
            str(cfg.get("strategy", "")),
            str(params),
            socket.gethostname(),
            self._date,
            f"{duration:.1f}",
            f"{float(summary.get('real_duration_s') or 0.0):.1f}",
            str(int(summary.get("interferences") or 0)),
            termination,
            _f1(summary.get("idleness_min_s")),
            _f1(summary.get("idleness_avg_s")),
            _f1(summary.get("idleness_std_s")),
            _f1(summary.get("idleness_max_s")),
            f"{float(summary.get('interference_rate_per_min') or 0.0):.2f}",
            str(counted),
            f"{counted / n:.1f}",
            str(int(summary.get("complete_cycles") or 0)),
        ]
        atomic_write_text(self.out_dir / "info.csv",
                          ";".join(x.replace(";", ",") for x in info) + "\n")

    def close(self) -> None:
        """Close the streams without writing the end files (prefer `finish`)."""
        for f in (self._visits_f, self._ts_f):
            if not f.closed:
                f.close()

    def __enter__(self) -> ResultsWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if not self.finished:
            # a failed write (ResultsError) leaves "complete": false or no summary; it does
            # not hide the exception that ended the block
            with contextlib.suppress(*((ResultsError,) if exc_type is not None else ())):
                if self._recorder is not None:
                    self.finish(None, self._recorder, interrupted=True)
                else:
                    with contextlib.suppress(OSError):
                        self.close()
                    self.finished = True
                    write_summary(self.out_dir, {"complete": False})
