"""The `tpuaf` command line. Each subcommand lives in its own module and registers here."""

from __future__ import annotations

import os
import signal
import sys


def _stopped_early(signum: int, _frame) -> None:
    """A stop signal before a subcommand runs (imports, option parsing): nothing is written
    yet, so one line and exit 128 + n at once (no KeyboardInterrupt traceback)."""
    name = signal.Signals(signum).name
    os.write(2, f"tpuaf: interrupted ({name})\n".encode())
    os._exit(128 + signum)


_PROGRAM = False  # running as the `tpuaf` program (not imported by tests)


def install_early_handlers() -> None:
    """SIGINT, SIGTERM and SIGHUP handled from the first instruction of the `tpuaf` program
    (before any heavy import); signals inherited as ignored stay ignored. `main` replaces
    these with `signals.stop_signals` while a subcommand runs."""
    global _PROGRAM
    _PROGRAM = True
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        try:
            if signal.getsignal(sig) != signal.SIG_IGN:
                signal.signal(sig, _stopped_early)
        except ValueError:  # not the main thread
            return


if os.path.basename(sys.argv[0] if sys.argv else "") == "tpuaf":  # the program, not a test
    install_early_handlers()

import argparse  # noqa: E402
import importlib  # noqa: E402

from tpuaf import __version__  # noqa: E402

# (name, module, help): modules define add_arguments(parser) and run(args) -> int.
SUBCOMMANDS: list[tuple[str, str, str]] = [
    ("run", "run", "Run one batch experiment (no ROS) and print its metrics"),
    ("maps", "maps", "Show map statistics"),
    ("graph", "graph", "Generate a patrol graph (map folder + picture) from a ROS occupancy map"),
    ("compare", "compare", "Sweep maps x strategies x N x seeds on Dask (resumable)"),
    ("report", "report", "Markdown report with figures and verdicts of a compare folder"),
    ("fleet", "fleet", "Run one headless ROS fleet experiment (simulator, agents, monitor, bag)"),
    ("analyze", "analyze", "Recompute a ROS run's metrics from its bag (no ROS needed)"),
    ("render", "render", "Animate a run's robots over the map (GIF/MP4), vertices by idleness or X"),
]


from tpuaf.cli import signals  # noqa: E402
from tpuaf.errors import CliError, TpuafError  # noqa: E402,F401 - re-exported for the subcommands


class ArgumentParser(argparse.ArgumentParser):
    """argparse, but a bad option is one line (no usage block) naming the option, exit code 2."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {one_line(message)} (see {self.prog} --help)\n")


class _SubCommands(argparse._SubParsersAction):
    """The subcommands' parsers, each filled in (its module imported, `add_arguments` run)
    only when that subcommand is chosen: `tpuaf run` imports no other subcommand's module."""

    def __call__(self, parser, namespace, values, option_string=None):
        chosen = self._name_parser_map.get(values[0]) if values else None
        if chosen is not None:
            fill_subparser(chosen)
        super().__call__(parser, namespace, values, option_string)


def fill_subparser(p: argparse.ArgumentParser) -> None:
    """Add a subcommand's options and handler to its parser (once)."""
    module = getattr(p, "_tpuaf_module", None)
    if module is None:
        return
    p._tpuaf_module = None
    mod = importlib.import_module(f"tpuaf.cli.{module}")
    mod.add_arguments(p)
    p.set_defaults(_handler=mod.run)


def build_parser(lazy: bool = True) -> argparse.ArgumentParser:
    """The `tpuaf` parser. lazy: each subcommand's options are added when it is chosen (at
    parsing); lazy=False adds every subcommand's options now (same parser, same results)."""
    parser = ArgumentParser(
        prog="tpuaf", description="Multi-robot continuous monitoring: TPUAF and baselines."
    )
    parser.add_argument("--version", action="version", version=f"tpuaf {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", action=_SubCommands)
    for name, module, help_text in SUBCOMMANDS:
        p = sub.add_parser(name, help=help_text, description=help_text)
        p._tpuaf_module = module
        if not lazy:
            fill_subparser(p)
    return parser


# Python packages that come from PyPI (requirements.txt), not from Debian's ROS packages: the
# import name -> the pip requirement. A catkin devel or install space run by /usr/bin/python3
# may lack them.
PYPI_PACKAGES = {"rosbags": "rosbags==0.11.9", "tqdm": "tqdm==4.70.1",
                 "dask": "dask[distributed]==2026.8.0", "distributed": "dask[distributed]==2026.8.0",
                 "matplotlib": "matplotlib==3.8.4", "PIL": "pillow"}
# The Debian package (rosdep key) of those Debian packages at a version that works here.
DEBIAN_PACKAGES = {"tqdm": "python3-tqdm", "matplotlib": "python3-matplotlib",
                   "PIL": "python3-pil"}


def missing_package_line(err: ModuleNotFoundError) -> str | None:
    """One line naming a missing PyPI package and the command that installs it, or None."""
    top = (err.name or "").split(".")[0]
    if top not in PYPI_PACKAGES:
        return None
    if top in DEBIAN_PACKAGES and sys.executable.startswith("/usr/bin/"):
        how = f"`sudo apt-get install {DEBIAN_PACKAGES[top]}` (rosdep key {DEBIAN_PACKAGES[top]})"
    elif sys.executable.startswith("/usr/bin/"):  # Debian's Python: pip refuses system-wide
        how = (f"`{sys.executable} -m pip install --user --break-system-packages "
               f"'{PYPI_PACKAGES[top]}'` (PyPI only)")
    else:
        how = f"`{sys.executable} -m pip install '{PYPI_PACKAGES[top]}'`"
    return (f"the Python package '{top}' is missing for {sys.executable}: install it with "
            f"{how}, or use the project's .venv/bin/tpuaf (`bash launch_scripts/setup.sh` "
            "makes it, with every dependency of requirements.txt)")


def _done(code: int) -> None:
    """The command's work is done (files written, exit code known): the `tpuaf` program ends
    here, without the interpreter's teardown, where a late stop signal killed the process
    with -2 and no message after complete results (imported by tests: nothing happens)."""
    if not _PROGRAM:
        return
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    logging = sys.modules.get("logging")  # imported by whoever logged (not by the CLI)
    if logging is not None:
        logging.shutdown()
    os._exit(code)


def main(argv: list[str] | None = None) -> int:
    try:
        code = _main(argv)
        _done(code)
        return code
    except ModuleNotFoundError as err:
        line = missing_package_line(err)
        if line is None:
            raise
        command = next((a for a in (argv if argv is not None else sys.argv[1:])
                        if not a.startswith("-")), "")
        print(f"tpuaf{' ' + command if command else ''}: error: {line}", file=sys.stderr)
        return 2


def _main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "_handler", None):
        parser.print_help()
        return 2
    # The chosen command's heavy imports happen before its stop handling: a stop signal during
    # an import would break that import (the `tpuaf` program exits on it at once, cleanly).
    module = sys.modules.get(getattr(args._handler, "__module__", ""))
    for name in getattr(module, "PRELOAD", ()):
        importlib.import_module(name)
    try:
        with signals.stop_signals():
            try:
                return int(args._handler(args) or 0)
            except KeyboardInterrupt:
                print(f"tpuaf {args.command}: interrupted", file=sys.stderr)
                return signals.exit_code()
            except Exception:
                if signals.received() is None:
                    raise
                # the stop signal's KeyboardInterrupt cut a module import or a library call
                # short, which then failed in its own way (an import right after start)
                print(f"tpuaf {args.command}: interrupted", file=sys.stderr)
                return signals.exit_code()
    except TpuafError as err:  # every user error: one line, no traceback
        print(f"tpuaf {args.command}: error: {one_line(err)}", file=sys.stderr)
        return 2
    except OSError as err:  # e.g. an unwritable results folder or a full disk
        where = f"{err.filename}: " if err.filename else ""
        print(f"tpuaf {args.command}: error: {one_line(f'{where}{err.strerror or err}')}",
              file=sys.stderr)
        return 2


MAX_TOKEN_CHARS = 120  # a longer run of non-space characters is shortened in messages


def one_line(err: Exception | str) -> str:
    """The error's message on one line: continuation lines joined with '; ', other control
    characters (e.g. from a garbled file or option) escaped, and tokens longer than
    MAX_TOKEN_CHARS (a 5 MB option value) cut to their start and length."""
    from tpuaf_core.yamlfile import shorten

    text = str(err)
    if len(text) > 100_000:
        text = text[:100_000]
    text = "; ".join(line.strip() for line in text.splitlines() if line.strip())
    text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)
    return shorten(text, MAX_TOKEN_CHARS)


if __name__ == "__main__":
    sys.exit(main())
