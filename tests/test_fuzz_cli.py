"""Fuzz (hypothesis, 1,000 cases each): `tpuaf run` argv in-process through tpuaf.cli.main (tiny
durations), and `--param` values for every strategy. A user error is exit code 2 with one line
on stderr; nothing ever raises or prints a traceback."""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from tpuaf.cli import main
from tpuaf.cli.run import parse_param_value
from tpuaf.maps import load_map
from tpuaf.policies import REGISTRY, ParameterError
from tpuaf.runtimes.config import ConfigError, RunConfig
from tpuaf.runtimes.graph import GraphRun

GRID = load_map("grid")
FUZZ_EXAMPLES = int(os.environ.get("TPUAF_FUZZ_EXAMPLES", "1000"))  # fewer while iterating
FUZZ = settings(max_examples=FUZZ_EXAMPLES, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.function_scoped_fixture])

NUMBERS = ["0", "1", "2", "-1", "-5", "0.5", "1e-9", "nan", "inf", "-inf", "1e400", "abc", "",
           "3", "12", " 2", "0x10", "1_0", "2147483647", "2147483648", "99999999999999999999"]
SHORT = ["0.5", "1", "2", "5", "0", "-1", "nan", "inf", "abc", "", "1e-9", "1e400"]
STRATEGIES = [*REGISTRY.names(), "TPUAF", "Gbs", "nope", "", "tpuaf "]
MAPS = ["grid", "lab", "atlantis", "", "GRID", "@file", "@dir", "@nothing", "/dev/null", "."]
PARAMS = ["utility=eq11", "utility=eq99", "g1=0.5", "g1=abc", "g1=nan", "g2=inf", "=", "x",
          "warp=9", "intention_timeout_s=-1", "a=[", "a={", "silence_timeout_s=1e400", "k=v=w"]
OUTS = ["@new", "@new", "@file", "@dir", "@nested/deeper", "@results", "", "relative"]


def option():
    return st.one_of(
        st.tuples(st.just("--map"), st.sampled_from(MAPS)),
        st.tuples(st.just("--strategy"), st.sampled_from(STRATEGIES)),
        st.tuples(st.just("--robots"), st.sampled_from(NUMBERS)),
        st.tuples(st.just("--duration"), st.sampled_from(SHORT)),
        st.tuples(st.just("--seed"), st.sampled_from(NUMBERS)),
        st.tuples(st.just("--delay"), st.sampled_from(NUMBERS)),
        st.tuples(st.just("--loss"), st.sampled_from(NUMBERS)),
        st.tuples(st.just("--param"), st.sampled_from(PARAMS)),
        st.tuples(st.just("--out"), st.sampled_from(OUTS)),
        st.tuples(st.sampled_from(["--overwrite", "--allow-occupied-vertices", "--list",
                                   "--quiet"])),
        st.tuples(st.sampled_from(["--bogus", "-x", "extra", "--robots"])),
        st.tuples(st.just("--param"), st.text(max_size=12)),
        st.tuples(st.sampled_from(["--seed", "--robots", "--duration", "--loss"]),
                  st.text(max_size=8)),
    )


def _resolve(token: str, root: Path) -> str:
    """'@file' etc. name real paths of the case's folder."""
    if not token.startswith("@"):
        return token
    if token == "@file":
        path = root / "a_file.txt"
        path.write_text("x\n")
        return str(path)
    if token == "@dir":
        path = root / "a_dir"
        path.mkdir(exist_ok=True)
        (path / "keep.txt").write_text("mine\n")
        return str(path)
    if token == "@results":  # an earlier run's folder, and a file of the user's in it
        path = root / "a_dir"
        path.mkdir(exist_ok=True)
        (path / "keep.txt").write_text("mine\n")
        (path / "config.yaml").write_text("map: grid\n")
        (path / "summary.json").write_text("{}\n")
        return str(path)
    return str(root / token[1:])


@FUZZ
@given(options=st.lists(option(), max_size=7))
def test_fuzz_run_argv(options, capsys):
    with tempfile.TemporaryDirectory() as tmp, contextlib.chdir(tmp):  # relative --out: here
        root = Path(tmp)
        argv = ["run", "--duration", "2", "--robots", "2", "--quiet"]
        for opt in options:
            argv += [_resolve(t, root) for t in opt]
        # whatever the options, the run stays tiny: at most 5 s of simulated time, 12 robots
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse: --help, or an error already printed
            code = exc.code
        _, err = capsys.readouterr()
        assert "Traceback" not in err
        assert code in (0, 2), (argv, code, err)
        if code == 2:
            lines = [line for line in err.splitlines() if line.strip()
                     and "warning" not in line]
            assert len(lines) == 1 and "error" in lines[0], (argv, err)
        keep = root / "a_dir" / "keep.txt"
        if keep.parent.is_dir():
            assert keep.read_text() == "mine\n"  # a user's file is never removed


@FUZZ
@given(strategy=st.sampled_from(REGISTRY.names()), data=st.data())
def test_fuzz_param_values(strategy, data):
    """Any text for a parameter: refused (ParameterError naming it) or accepted; an accepted
    set of parameters then runs (5 s, 2 robots) without raising."""
    cls = REGISTRY.get(strategy)
    keys = sorted(cls.parameters)
    key = data.draw(st.sampled_from(keys) if keys else st.text(max_size=8), label="key")
    raw = data.draw(st.one_of(
        st.sampled_from(["nan", "inf", "-inf", ".nan", ".inf", "1e400", "-1", "0", "1", "0.5",
                         "true", "no", "null", "~", "[1, 2]", "{a: 1}", "eq11", "eq14", "abc",
                         "", "1e-300", "-0", "2147483648", "'1'"]),
        st.text(max_size=10),
        st.floats(allow_nan=True).map(repr),
        st.integers(-10**12, 10**12).map(str),
    ), label="raw")
    value = parse_param_value(raw)
    try:
        cls({key: value})
    except ParameterError as err:
        assert str(err).strip()
        return
    config = RunConfig(map="grid", strategy=strategy, robots=2, duration_s=5.0,
                       strategy_params={key: value})
    try:
        GraphRun(config, GRID).run()
    except ConfigError:
        pass
