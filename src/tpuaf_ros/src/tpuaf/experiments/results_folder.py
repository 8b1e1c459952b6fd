"""A results folder's ownership (docs/RESULTS.md "Results folder").

`.tpuaf-files` lists every file tpuaf wrote in the folder: `prepare_out_dir(..., overwrite=True)`
removes those, nothing else. One process writes a folder: `prepare_out_dir` takes a flock on
`.tpuaf-lock` for the process's life (`lock_folder`; readers take `read_lock`), and no file is
written through a link (tpuaf.files).
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import shutil
import stat
from pathlib import Path

from tpuaf.experiments.run_files import ResultsError

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
