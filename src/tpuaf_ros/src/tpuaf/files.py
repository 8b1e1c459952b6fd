"""Atomic file writes: a reader (or a kill, or a power cut) sees the old file or the whole new
one, never half a file.

The data goes to a temporary file in the same folder (`.NAME.PID.tmp`, hidden, same file
system), is flushed and fsynced, renamed over NAME, then the folder is fsynced (the rename
itself survives a crash). On any error, KeyboardInterrupt included, the temporary file is
removed and the old NAME is left as it was.

    atomic_write(path, b"bytes" | "text" | writer)   # writer(f): f is a binary file object
    atomic_write_text(path, text)
    with atomic_file(path) as f: fig.savefig(f, format="png")   # or "w" for text (csv)
    with atomic_path(path, ".mp4") as tmp: ...                 # writers that need a file name
    with open_fresh(path, "w", newline="") as f: ...            # a streamed file, created anew

No write follows a symbolic link: temporary files are created with O_EXCL | O_NOFOLLOW, a
rename replaces a link itself (never its target), and `open_fresh` removes whatever NAME was
(a link included) before creating it.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

from tpuaf_core import yamlfile

from tpuaf.errors import TpuafError


def _temp_path(path: Path, suffix: str = "") -> Path:
    """`.NAME.PID.tmp[suffix]` beside `path` (the pid keeps concurrent writers apart)."""
    return path.with_name(f".{path.name}.{os.getpid()}.tmp{suffix}")


def _fsync_folder(folder: Path) -> None:
    """fsync a folder so that a rename in it is on disk; skipped where the OS refuses."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        with contextlib.suppress(OSError):  # e.g. EINVAL on some network file systems
            os.fsync(fd)
    finally:
        os.close(fd)


@contextlib.contextmanager
def _temporary(path: Path, suffix: str) -> Iterator[Path]:
    """A temporary path beside `path`, removed if the block raises (any BaseException)."""
    tmp = _temp_path(path, suffix)
    try:
        yield tmp
    except BaseException as err:
        with contextlib.suppress(OSError):
            tmp.unlink()
        if isinstance(err, OSError) and err.filename is None and err.errno is not None:
            # e.g. ENOSPC from a write: the message names the file being written
            raise OSError(err.errno, err.strerror or str(err), str(path)) from None
        raise


_NEW_FILE_FLAGS = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC


def _create(path: Path, mode: str, encoding: str | None, newline: str | None) -> IO[Any]:
    """A new file at `path` (any earlier entry of that name, a link included, is removed
    first); never follows a link."""
    with contextlib.suppress(FileNotFoundError):
        os.unlink(path)
    fd = os.open(path, _NEW_FILE_FLAGS, 0o644)
    try:
        return open(fd, mode, encoding=encoding, newline=newline)  # noqa: SIM115
    except BaseException:
        os.close(fd)
        raise


def open_fresh(path: str | Path, mode: str = "w", *, encoding: str | None = None,
               newline: str | None = None) -> IO[Any]:
    """`open(path, mode)` for a file written from scratch ("w" or "wb"), created anew: a link
    (or anything else) at `path` is removed, not followed."""
    if mode not in ("w", "wb"):
        raise ValueError(f"open_fresh: mode '{mode}' (expected 'w' or 'wb')")
    return _create(Path(path), mode, encoding, newline)


def _commit(tmp: Path, path: Path) -> None:
    os.replace(tmp, path)
    _fsync_folder(path.parent)


@contextlib.contextmanager
def atomic_file(path: str | Path, mode: str = "wb", *, encoding: str | None = None,
                newline: str | None = None) -> Iterator[IO[Any]]:
    """A file object (open(tmp, mode, ...)) whose contents replace `path` when the block ends
    without an error. `mode` is "wb" or "w" (text: `encoding` and `newline` as for open())."""
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_file: mode '{mode}' (expected 'w' or 'wb')")
    path = Path(path)
    with _temporary(path, "") as tmp:
        with _create(tmp, mode, encoding, newline) as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        _commit(tmp, path)


@contextlib.contextmanager
def atomic_path(path: str | Path, suffix: str = "") -> Iterator[Path]:
    """A temporary file name ending in `suffix` (e.g. ".mp4" for ffmpeg, which picks the format
    by the name) for a writer that opens the file itself; it replaces `path` when the block
    ends without an error."""
    path = Path(path)
    with _temporary(path, suffix) as tmp:
        yield tmp
        fd = os.open(tmp, os.O_RDONLY)  # the writer closed it: fsync through a new descriptor
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        _commit(tmp, path)


def atomic_write(path: str | Path, data: bytes | str | Callable[[IO[bytes]], object], *,
                 encoding: str | None = None) -> None:
    """Replace `path` with `data`: bytes as they are, text in `encoding` (default: open()'s)
    with no newline translation, or a writer called with the open binary file."""
    if isinstance(data, bytes | bytearray | memoryview):
        with atomic_file(path, "wb") as f:
            f.write(data)
    elif isinstance(data, str):
        with atomic_file(path, "w", encoding=encoding, newline="") as f:
            f.write(data)
    elif callable(data):
        with atomic_file(path, "wb") as f:
            data(f)
    else:
        raise TypeError(f"atomic_write: data is {type(data).__name__} (expected bytes, str or "
                        "a writer callable)")


def atomic_write_text(path: str | Path, text: str, *, encoding: str | None = None) -> None:
    """atomic_write of a str (written as given: no newline translation)."""
    if not isinstance(text, str):
        raise TypeError(f"atomic_write_text: text is {type(text).__name__}, not str")
    atomic_write(path, text, encoding=encoding)


def available_bytes() -> int:
    """Memory this machine can still give [B]: MemAvailable of /proc/meminfo (Linux), else the
    physical memory, else 4 GiB. For the estimates made before allocating (cli/limits.py, map
    images)."""
    try:
        with open("/proc/meminfo", "rb") as f:
            for line in f:
                if line.startswith(b"MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 4 << 30


class InputFileError(TpuafError):
    """An input file that is no regular file, too large, or unreadable (one line)."""


def read_regular(path: str | Path, *, max_bytes: int, what: str = "file",
                 error_class: type[Exception] = InputFileError) -> bytes:
    """The bytes of the regular file at `path` (never a FIFO, device or link loop; at most
    `max_bytes`), else `error_class` in one line naming the path."""
    return yamlfile.read_regular_bytes(path, error_class, max_bytes=max_bytes, what=what)
