"""The `tpuaf` command line. Each subcommand lives in its own module and registers here."""

from __future__ import annotations

import argparse
import sys

from tpuaf import __version__

# (name, module, help): modules define add_arguments(parser) and run(args) -> int.
SUBCOMMANDS: list[tuple[str, str, str]] = [
    ("run", "run", "Run one batch experiment (no ROS) and print its metrics"),
    ("maps", "maps", "Show map statistics"),
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


def build_parser() -> argparse.ArgumentParser:
    parser = ArgumentParser(
        prog="tpuaf", description="Multi-robot continuous monitoring: TPUAF and baselines."
    )
    parser.add_argument("--version", action="version", version=f"tpuaf {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    import importlib

    for name, module, help_text in SUBCOMMANDS:
        mod = importlib.import_module(f"tpuaf.cli.{module}")
        p = sub.add_parser(name, help=help_text, description=help_text)
        mod.add_arguments(p)
        p.set_defaults(_handler=mod.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "_handler", None):
        parser.print_help()
        return 2
    try:
        with signals.stop_signals():
            try:
                return int(args._handler(args) or 0)
            except KeyboardInterrupt:
                print(f"tpuaf {args.command}: interrupted", file=sys.stderr)
                return signals.exit_code()
    except TpuafError as err:  # every user error: one line, no traceback
        print(f"tpuaf {args.command}: error: {one_line(err)}", file=sys.stderr)
        return 2
    except OSError as err:  # e.g. an unwritable results folder or a full disk
        where = f"{err.filename}: " if err.filename else ""
        print(f"tpuaf {args.command}: error: {where}{err.strerror or err}", file=sys.stderr)
        return 2


def one_line(err: Exception | str) -> str:
    """The error's message on one line: continuation lines joined with '; ', other control
    characters (e.g. from a garbled file or option) escaped."""
    text = "; ".join(line.strip() for line in str(err).splitlines() if line.strip())
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


if __name__ == "__main__":
    sys.exit(main())
