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
that a reader (or a kill) never sees half a file. `.tpuaf-files` lists every file tpuaf wrote in the folder:
`prepare_out_dir(..., overwrite=True)` removes those, nothing else. One process writes a folder:
`prepare_out_dir` takes a flock on `.tpuaf-lock` for the process's life, and no file is written
through a link (tpuaf.files).
"""

from __future__ import annotations

import contextlib
import csv
import fcntl
import itertools
import math
import os
import shutil
import socket
import stat
import time
from collections.abc import Callable, Iterable, Iterator, Mapping
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np
import yaml

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


MANIFEST = ".tpuaf-files"  # one name a line: what tpuaf wrote in this folder ("name/": a folder)
LOCK_FILE = ".tpuaf-lock"  # flock'ed by the one process writing the folder (holds its pid)
# Names tpuaf writes in a run folder (batch, fleet, analysis): in folders written before the
# manifest existed, --overwrite removes those of them that are plain files (never a folder:
# it may hold the user's own files).
PRODUCT_FILES = frozenset({
    "config.yaml", "visits.csv", "timeseries.csv", "summary.json", "info.csv", "idleness.csv",
    "timeresults.csv", "comparison.json", "summary.png", "world.yaml", "strategy_params.yaml",
    "fleet_config.yaml", "fleet_timing.json", "roslaunch.log", "run.bag", "run.bag.active",
    "simulator.json", "world.resolved.yaml", "world.occupancy.pgm", MANIFEST,
})
_HOUSEKEEPING = frozenset({LOCK_FILE})
# Folders tpuaf creates whole (a manifest entry "name/" removes them); any other folder may
# hold the user's files and is never removed, whatever a manifest says.
WHOLE_FOLDERS = frozenset({"ros_home"})
_LOCKS: dict[str, int] = {}  # folder (resolved) -> descriptor of its flock'ed lock file


def _manifest_names(out_dir: Path) -> list[str]:
    """The manifest's names, read without following a link (a link is no manifest)."""
    try:
        fd = os.open(out_dir / MANIFEST, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    except OSError:
        return []
    with open(fd, "rb") as f:
        if not stat.S_ISREG(os.fstat(f.fileno()).st_mode):
            return []
        text = f.read(1 << 20).decode("utf-8", "replace")
    return [n for n in text.split("\n") if n]


def record_written(out_dir: str | Path, *names: str) -> None:
    """Add `names` (relative to `out_dir`; "name/" for a folder tpuaf created whole) to the
    folder's manifest of files tpuaf wrote."""
    out_dir = Path(out_dir)
    known = set(_manifest_names(out_dir))
    new = [n for n in dict.fromkeys(names) if n not in known]
    if new:
        fd = os.open(out_dir / MANIFEST,
                     os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o644)
        with open(fd, "a") as f:
            f.write("".join(f"{n}\n" for n in new))


def _plain_name(name: str) -> str | None:
    """A manifest name as one entry of the folder itself ('x', or 'x/' for a folder), else None
    (a path with '..', '/' inside or an absolute path is never followed)."""
    bare = name[:-1] if name.endswith("/") else name
    if not bare or "/" in bare or bare in (".", "..") or "\0" in bare:
        return None
    return bare


def _remove_written(out_dir: Path) -> None:
    """Remove what the manifest lists (plus, without a manifest, the known product files that
    are plain files or links). A link is removed itself, never followed; a folder only when the
    manifest lists it as "name/" (tpuaf created it whole)."""
    listed = _manifest_names(out_dir)
    names: dict[str, bool] = {}  # bare name -> may be a folder
    if not listed:
        names.update((n, False) for n in PRODUCT_FILES)
    for raw in listed:
        bare = _plain_name(raw)
        if bare is not None and bare not in _HOUSEKEEPING:
            names[bare] = names.get(bare, False) or raw.endswith("/")
    names.pop(MANIFEST, None)
    for bare, folder_ok in sorted(names.items()):
        path = out_dir / bare
        try:
            mode = os.lstat(path).st_mode
        except FileNotFoundError:
            continue
        if stat.S_ISDIR(mode):
            if folder_ok and bare in WHOLE_FOLDERS:
                shutil.rmtree(path)
        else:
            path.unlink()
    with contextlib.suppress(FileNotFoundError):
        (out_dir / MANIFEST).unlink()


def _is_results_folder(folder: Path) -> bool:
    """A folder tpuaf wrote: its manifest, or (older runs) config.yaml beside results."""
    if os.path.isfile(folder / MANIFEST) and not os.path.islink(folder / MANIFEST):
        return True
    results = ("summary.json", "visits.csv", "timeseries.csv", "fleet_config.yaml", "run.bag")
    return (folder / "config.yaml").is_file() and any((folder / n).exists() for n in results) \
        or (folder / "fleet_config.yaml").is_file()


def lock_folder(folder: str | Path, option: str = "--out") -> Path:
    """Take the folder's writer lock (flock on LOCK_FILE) for the rest of this process's life;
    ResultsError (one line, naming the holder's pid) when another process holds it. Taking it
    again in the same process is a no-op."""
    folder = Path(folder)
    key = os.path.realpath(folder)
    if key in _LOCKS:
        return folder
    try:
        fd = os.open(folder / LOCK_FILE, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC,
                     0o644)
    except OSError as err:
        raise ResultsError(f"{option} {folder}: cannot create its lock file {LOCK_FILE}: "
                           f"{err.strerror or err}") from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        holder = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
        os.close(fd)
        raise ResultsError(f"{option} {folder}: another tpuaf process"
                           f"{' (pid ' + holder + ')' if holder.isdigit() else ''} is writing "
                           "there: wait for it to end, or choose another folder") from None
    os.ftruncate(fd, 0)
    os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
    _LOCKS[key] = fd
    return folder


@contextlib.contextmanager
def read_lock(folder: str | Path):
    """A reader's shared lock on the folder (flock LOCK_SH on LOCK_FILE) while the block runs;
    yields None, or the pid (text) of a writer holding the lock: the folder is being written
    (then no lock is taken, the reader goes on and says so)."""
    try:
        fd = os.open(Path(folder) / LOCK_FILE, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
    except OSError:
        yield None  # no lock file: nobody ever wrote there with a lock
        return
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError:
            yield os.pread(fd, 32, 0).decode("ascii", "replace").strip() or "?"
            return
        yield None
    finally:
        os.close(fd)


def unlock_folder(folder: str | Path) -> None:
    """Release the lock `lock_folder` took (else it lasts as long as the process)."""
    fd = _LOCKS.pop(os.path.realpath(folder), None)
    if fd is not None:
        os.close(fd)


def _entries(folder: Path) -> list[str]:
    return sorted(n for n in os.listdir(folder) if n not in _HOUSEKEEPING
                  and not n.startswith(".tpuaf-write-test"))


def prepare_out_dir(out_dir: str | Path, overwrite: bool = False, option: str = "--out") -> Path:
    """Check, create and lock a results folder before a run starts.

    Refused (ResultsError, naming the path): an existing file, a place that cannot be created
    or written, a folder another tpuaf process is writing (its lock), and an existing
    non-empty folder unless `overwrite`; then the files its manifest lists are removed, and
    nothing else. The lock is held until the process ends."""
    out = Path(out_dir).expanduser()
    try:
        is_dir = out.is_dir()
        exists = is_dir or out.exists() or out.is_symlink()
    except OSError as err:  # e.g. a link loop, a name too long
        raise ResultsError(f"{option} {out}: {err.strerror or err}") from None
    if exists and not is_dir:
        raise ResultsError(f"{option} {out}: is an existing file, not a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".tpuaf-write-test.{os.getpid()}"
        with contextlib.suppress(FileNotFoundError):
            probe.unlink()
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644))
        probe.unlink()
    except OSError as err:
        raise ResultsError(f"{option} {out}: cannot write there: "
                           f"{err.strerror or err}") from None
    lock_folder(out, option)
    existing = _entries(out)
    if existing and not overwrite:
        raise ResultsError(
            f"{option} {out}: folder exists and is not empty ({len(existing)} entries, e.g. "
            f"{existing[0]}): give --overwrite to replace the results tpuaf wrote there, "
            "or choose a new folder")
    if existing and not _is_results_folder(out):
        raise ResultsError(
            f"{option} {out}: holds no tpuaf results (no {MANIFEST} manifest nor config.yaml "
            "with results): --overwrite only replaces a results folder; choose a new folder")
    if existing:
        _remove_written(out)
    return out


def _num(value: Any) -> str:
    """A CSV cell: empty for None/NaN, repr-exact floats otherwise."""
    if value is None:
        return ""
    if isinstance(value, (float, np.floating)):
        return "" if not math.isfinite(value) else repr(float(value))
    return str(value)


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
