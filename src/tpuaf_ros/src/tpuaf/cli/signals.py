"""SIGINT, SIGTERM and SIGHUP stop every `tpuaf` command the same way: KeyboardInterrupt.

SIGTERM is what `timeout`, job schedulers and `docker stop` send; SIGHUP what a closed terminal
sends. `tpuaf.cli.main` runs each subcommand inside `stop_signals()`, so a subcommand handles one
exception (KeyboardInterrupt) and writes its results as for Ctrl-C. Only the first signal
interrupts; later ones are counted and ignored so that the results are written in full. Work
that must not be cut (writing the end files) runs inside `shielded()`: a signal arriving there
is only recorded (`received()`). A signal the process
inherited as ignored (`nohup`, a background job of a non-interactive shell) stays ignored.
The exit code of an interrupted command is 128 + the signal number (130 for SIGINT).
"""

from __future__ import annotations

import contextlib
import signal
from collections.abc import Iterator

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

_received: list[int] = []  # signal numbers received inside stop_signals()
_shield_depth = 0


def _handler(signum: int, _frame) -> None:
    first = not _received
    _received.append(signum)
    if first and not _shield_depth:  # later signals: already stopping, let results be written
        raise KeyboardInterrupt(signal.Signals(signum).name)


def received() -> int | None:
    """The first stop signal received inside `stop_signals()`, or None."""
    return _received[0] if _received else None


def count() -> int:
    """How many stop signals arrived inside `stop_signals()` so far."""
    return len(_received)


def exit_code() -> int:
    """128 + the first signal received (130 when none was: Ctrl-C seen by Python itself)."""
    return 128 + (_received[0] if _received else signal.SIGINT)


@contextlib.contextmanager
def stop_signals() -> Iterator[None]:
    """Inside: SIGINT, SIGTERM and SIGHUP raise KeyboardInterrupt once (not those inherited as
    ignored); the previous handlers are restored on exit."""
    global _shield_depth
    _received.clear()
    _shield_depth = 0
    previous = {}
    try:
        for sig in STOP_SIGNALS:
            old = signal.getsignal(sig)
            if old == signal.SIG_IGN:
                continue
            previous[sig] = old
            signal.signal(sig, _handler)
    except ValueError:  # not the main thread: signals cannot be handled here
        pass
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old if old is not None else signal.SIG_DFL)


@contextlib.contextmanager
def shielded() -> Iterator[None]:
    """A stop signal arriving inside the block is recorded, not raised."""
    global _shield_depth
    _shield_depth += 1
    try:
        yield
    finally:
        _shield_depth -= 1
