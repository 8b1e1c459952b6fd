"""The `tpuaf` command starts light: its parser imports no subcommand's module until that
subcommand is chosen, and no subcommand's options need numpy, yaml, tqdm, the plots or Dask
(`tpuaf run` pays only for what it runs). Checked in a fresh interpreter (sys.modules), so
that an eager import added anywhere fails here."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import tpuaf
from tpuaf.cli import SUBCOMMANDS, build_parser

# Imported by some subcommands only, or at run time: never by building the parser.
HEAVY = ("numpy", "yaml", "tqdm", "matplotlib", "dask", "distributed", "rosbags", "PIL",
         "logging", "importlib.metadata", "tpuaf.maps", "tpuaf.measure",
         "tpuaf.policies", "tpuaf.runtimes", "tpuaf.experiments", "tpuaf.navigation",
         "tpuaf.files")


def imported_after(code: str) -> list[str]:
    """The modules a fresh interpreter (this `tpuaf` package first on its path) holds after
    running `code`."""
    script = f"{code}\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"
    path = [str(Path(tpuaf.__file__).resolve().parents[1]), os.environ.get("PYTHONPATH", "")]
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=120, env=dict(os.environ, PYTHONPATH=os.pathsep.join(path)))
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.splitlines()[-1])


def heavy(modules: list[str]) -> list[str]:
    return [m for m in modules if any(m == h or m.startswith(h + ".") for h in HEAVY)]


def test_building_the_parser_imports_no_subcommand_and_nothing_heavy():
    modules = imported_after("import tpuaf.cli\ntpuaf.cli.build_parser()")
    assert heavy(modules) == []
    assert [m for m in modules if m.startswith("tpuaf.cli.")] == ["tpuaf.cli.signals"]


def test_every_subcommands_options_import_nothing_heavy():
    modules = imported_after("import tpuaf.cli\ntpuaf.cli.build_parser(lazy=False)")
    assert heavy(modules) == []
    assert {f"tpuaf.cli.{module}" for _, module, _ in SUBCOMMANDS} <= set(modules)


def test_parsing_run_imports_the_run_subcommand_only():
    modules = imported_after(
        "import tpuaf.cli\n"
        "args = tpuaf.cli.build_parser().parse_args(['run', '--robots', '3', '--fail', '0@5'])\n"
        "assert args.robots == 3 and args._handler.__module__ == 'tpuaf.cli.run'")
    assert heavy(modules) == []
    assert {m for m in modules if m.startswith("tpuaf.cli.")} == {"tpuaf.cli.run",
                                                                  "tpuaf.cli.signals"}


def _subparser(parser, name: str):
    action = next(a for a in parser._actions if a.dest == "command")
    return action.choices[name]


@pytest.mark.parametrize("name", [name for name, _, _ in SUBCOMMANDS])
def test_a_chosen_subcommand_has_the_options_and_help_of_the_full_parser(name, capsys):
    full = build_parser(lazy=False)
    lazy = build_parser()
    assert lazy.format_help() == full.format_help()
    with pytest.raises(SystemExit) as lazy_exit:
        lazy.parse_args([name, "--help"])
    lazy_help = capsys.readouterr().out
    with pytest.raises(SystemExit) as full_exit:
        full.parse_args([name, "--help"])
    assert lazy_exit.value.code == full_exit.value.code == 0
    assert lazy_help == capsys.readouterr().out == _subparser(full, name).format_help()
    errors = []
    for parser in (build_parser(), build_parser(lazy=False)):
        with pytest.raises(SystemExit) as bad:
            parser.parse_args([name, "x", "--no-such-option"])
        assert bad.value.code == 2
        errors.append(capsys.readouterr().err)
    assert errors[0] == errors[1] and errors[0].startswith("tpuaf")  # same words, same code
