"""`tpuaf report DIR`: the Markdown report (tables, figures, verdicts) of a `tpuaf compare` folder;
a sweep still running or interrupted is said to be incomplete (N of M planned runs finished)
and its verdicts are marked provisional."""

from __future__ import annotations

import argparse
from pathlib import Path

from tpuaf.errors import CliError


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("dir", type=Path, help="a folder written by `tpuaf compare`")
    p.add_argument("--out", type=Path, default=None,
                   help="report folder (default: DIR): report.md and figures/*.png")
    p.add_argument("--paper", type=Path, default=None,
                   help="the paper's figures (default: ../shared/reference/paper_tables.csv "
                        "beside the repository, skipped if absent)")
    p.add_argument("--bounds", type=Path, default=None,
                   help="best-known tours per map and N (default: ../shared/reference/"
                        "patrol_bounds.csv beside the repository, skipped if absent)")
    p.add_argument("--title", default=None, help="report title")


def run(args: argparse.Namespace) -> int:
    from tpuaf.experiments.report import ReportError, write_report

    if not args.dir.is_dir():
        raise CliError(f"{args.dir}: not a folder (give a folder written by `tpuaf compare`)")
    if args.out is not None and args.out.exists() and not args.out.is_dir():
        raise CliError(f"--out {args.out}: is an existing file, not a folder")

    progress: list = []
    try:
        path = write_report(args.dir, out=args.out, paper=args.paper, title=args.title,
                            bounds=args.bounds, progress=progress)
    except ReportError as err:
        raise CliError(str(err)) from None
    print(f"report: {path}")
    if progress and progress[0] is not None and progress[0].line():
        print(f"tpuaf report: {progress[0].line().strip('*')}")
    return 0
