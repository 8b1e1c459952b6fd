"""Issue 12 probes: every user error is one line naming the problem, exit code 2, no traceback;
results folders are never overwritten silently nor mixed. In-process through tpuaf.cli.main
(the same code as the entry point), with tiny durations."""

from __future__ import annotations

import json
import os
import re

import pytest
from tpuaf.cli import main
from tpuaf.errors import CliError, MapError, TpuafError
from tpuaf.params import AgentParams, MonitorParams, NodeParamError, parse
from tpuaf.policies import REGISTRY, ParameterError


def cli(capsys, *argv: str) -> tuple[int, str, str]:
    """Run `tpuaf argv...` in-process: (exit code, stdout, stderr)."""
    try:
        code = main(list(argv))
    except SystemExit as exc:  # argparse
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line_error(code: int, err: str, *needles: str) -> None:
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2, err
    assert len(lines) == 1, err
    assert "Traceback" not in err and "error:" in lines[0]
    for needle in needles:
        assert needle in lines[0], lines[0]


# ---------------------------------------------------------------------------------------------
# command-line options


@pytest.mark.parametrize("argv,needle", [
    (["--seed", "-5"], "--seed"),
    (["--seed", "abc"], "--seed"),
    (["--seed", str(2**40)], "--seed"),
    (["--robots", "0"], "--robots"),
    (["--robots", "2147483647"], "--robots"),  # used to allocate until the OOM killer came
    (["--duration", "nan"], "--duration"),
    (["--duration", "inf"], "--duration"),
    (["--delay", "-1"], "--delay"),
    (["--loss", "1.5"], "--loss"),
    (["--no-such-option"], "unrecognized arguments"),
], ids=lambda v: " ".join(v) if isinstance(v, list) else None)
def test_run_options_are_one_line_errors(capsys, argv, needle):
    code, _, err = cli(capsys, "run", "--duration", "5", "--quiet", *argv)
    assert_one_line_error(code, err, needle)


@pytest.mark.parametrize("strategy,param,value", [
    ("gbs", "g1", "abc"), ("gbs", "g1", "nan"), ("gbs", "g2", "inf"), ("gbs", "g2", ".inf"),
    ("sebs", "g1", "abc"), ("sebs", "g1", "nan"), ("sebs", "g2", "inf"), ("sebs", "g2", "-inf"),
    ("gbs", "g1", "[1, 2]"), ("gbs", "g1", "true"), ("tpuaf", "utility", "{a: 1}"),
    ("tpuaf", "intention_timeout_s", "nan"), ("dtag", "w_path", "~"),
])
def test_param_values_are_one_line_errors(capsys, strategy, param, value):
    """Check functions used to raise TypeError on strings (g1=abc, g1=nan) and accept inf."""
    code, _, err = cli(capsys, "run", "--strategy", strategy, "--duration", "5", "--quiet",
                       "--param", f"{param}={value}")
    assert_one_line_error(code, err, f"'{param}'", f"'{strategy}'")


@pytest.mark.parametrize("item", ["=3", "noequals", "a=[", "utility=eq11 --param utility=eq14"])
def test_malformed_param_items(capsys, item):
    argv = []
    for part in item.split(" --param "):
        argv += ["--param", part]
    code, _, err = cli(capsys, "run", "--duration", "5", "--quiet", *argv)
    assert_one_line_error(code, err, "param")


def test_policy_checks_never_raise():
    """Every strategy parameter, given values of every kind: ParameterError or accepted."""
    odd = ["abc", float("nan"), float("inf"), -float("inf"), None, True, [1], {"a": 1}, -1e308,
           10**30, ""]
    for name in REGISTRY.names():
        cls = REGISTRY.get(name)
        for key in cls.parameters:
            for value in odd:
                try:
                    cls({key: value})
                except ParameterError as err:
                    assert key in str(err)


def test_out_is_an_existing_file(capsys, tmp_path):
    target = tmp_path / "file.txt"
    target.write_text("mine\n")
    code, _, err = cli(capsys, "run", "--duration", "5", "--quiet", "--out", str(target))
    assert_one_line_error(code, err, str(target), "file")
    assert target.read_text() == "mine\n"


def test_out_is_unwritable(capsys, tmp_path):
    if os.geteuid() == 0:
        target = "/proc/self/tpuaf-results"  # even root cannot create folders in /proc
    else:
        locked = tmp_path / "locked"
        locked.mkdir()
        locked.chmod(0o500)
        target = str(locked / "run")
    code, _, err = cli(capsys, "run", "--duration", "5", "--quiet", "--out", target)
    assert_one_line_error(code, err, target, "cannot write")


# ---------------------------------------------------------------------------------------------
# results folders: never overwritten silently, never mixed


def test_existing_results_folder_is_refused(capsys, tmp_path):
    out = tmp_path / "run"
    assert cli(capsys, "run", "--duration", "30", "--quiet", "--out", str(out))[0] == 0
    before = (out / "summary.json").read_text()
    code, _, err = cli(capsys, "run", "--duration", "60", "--quiet", "--seed", "1",
                       "--out", str(out))
    assert_one_line_error(code, err, "--overwrite", str(out))
    assert (out / "summary.json").read_text() == before


def test_overwrite_clears_only_what_tpuaf_wrote(capsys, tmp_path):
    out = tmp_path / "fleet_run"
    out.mkdir()
    # an earlier fleet run's files, and a file of the user's
    (out / "run.bag").write_bytes(b"#ROSBAG V2.0\n")
    (out / "summary.json").write_text(json.dumps({"complete": True, "duration_s": 9999}))
    (out / "world.yaml").write_text("robots: 4\n")
    (out / "config.yaml").write_text("runtime: ros\n")
    (out / "notes.txt").write_text("my notes\n")
    code, _, err = cli(capsys, "run", "--duration", "30", "--quiet", "--overwrite",
                       "--out", str(out))
    assert code == 0, err
    assert not (out / "run.bag").exists() and not (out / "world.yaml").exists()
    assert (out / "notes.txt").read_text() == "my notes\n"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["duration_s"] == pytest.approx(30.0)
    manifest = (out / ".tpuaf-files").read_text().split()
    assert {"summary.json", "visits.csv", "timeseries.csv", "config.yaml"} <= set(manifest)
    assert "notes.txt" not in manifest
    # a second overwrite keeps the user's file again
    assert cli(capsys, "run", "--duration", "20", "--quiet", "--overwrite",
               "--out", str(out))[0] == 0
    assert (out / "notes.txt").is_file()


def test_overwrite_refuses_a_folder_that_holds_no_results(capsys, tmp_path):
    """`--out . --overwrite` in a source or home folder must not delete its config.yaml."""
    out = tmp_path / "project"
    out.mkdir()
    (out / "config.yaml").write_text("mine: true\n")
    (out / "README.md").write_text("# mine\n")
    code, _, err = cli(capsys, "run", "--duration", "5", "--quiet", "--overwrite",
                       "--out", str(out))
    assert_one_line_error(code, err, "holds no tpuaf results")
    assert (out / "config.yaml").read_text() == "mine: true\n"
    code, _, err = cli(capsys, "run", "--duration", "5", "--quiet", "--out", "")
    assert_one_line_error(code, err, "--out")


def test_manifest_cannot_delete_outside_the_folder(tmp_path):
    from tpuaf.experiments.results_folder import prepare_out_dir

    victim = tmp_path / "victim.txt"
    victim.write_text("keep\n")
    out = tmp_path / "run"
    out.mkdir()
    (out / ".tpuaf-files").write_text("../victim.txt\n/etc/hostname\n")
    prepare_out_dir(out, overwrite=True)
    assert victim.read_text() == "keep\n"


def test_writer_never_keeps_an_earlier_summary(tmp_path):
    """A ResultsWriter in a folder with an old summary.json (e.g. the monitor in a reused fleet
    folder) removes it at once: an interruption cannot leave 'complete: true' of another run."""
    from tpuaf.experiments.results import ResultsWriter

    out = tmp_path / "run"
    out.mkdir()
    (out / "summary.json").write_text(json.dumps({"complete": True}))
    writer = ResultsWriter(out, {"map": "grid"})
    assert not (out / "summary.json").exists()
    writer.close()


# ---------------------------------------------------------------------------------------------
# fleet options: refused before any ROS process starts


@pytest.mark.parametrize("argv,needle", [
    (["--rtf", "-1"], "--rtf"),
    (["--robot", "tank"], "tank"),
    (["--seed", "-5"], "--seed"),
    (["--param", "g1=abc", "--strategy", "gbs"], "g1"),
])
def test_fleet_options_checked_before_ros(capsys, tmp_path, argv, needle):
    out = tmp_path / "fleet"
    code, _, err = cli(capsys, "fleet", "--duration", "5", "--out", str(out), "--quiet", *argv)
    assert_one_line_error(code, err, needle)
    assert not (out / "ros_home").exists()  # nothing was started
    assert not out.exists() or not (out / "world.yaml").exists()


# ---------------------------------------------------------------------------------------------
# node parameters and the error classes


@pytest.mark.parametrize("name,value", [
    ("max_linear_speed", -0.5), ("max_angular_speed", -1.0), ("safety_margin", -0.01),
    ("plan_margin", -1.0), ("max_retries", -1), ("stuck_timeout", 0.0), ("backoff_time", -1.0),
    ("waypoint_tolerance", 0.0), ("heartbeat_period", -1.0), ("robots", 0), ("robot_index", -3),
])
def test_agent_node_ranges(name, value):
    values = {"map": "grid", "robot_index": 0, "robots": 2, name: value}
    with pytest.raises(NodeParamError, match=rf"~{name} must be >=? -?\d"):
        parse(AgentParams, values, "patrol_agent")


@pytest.mark.parametrize("name,value", [("duration", 0.0), ("death_timeout", -1.0),
                                        ("robots", 0), ("start_delay", -2.0)])
def test_monitor_node_ranges(name, value):
    with pytest.raises(NodeParamError, match=rf"~{name}"):
        parse(MonitorParams, {"map": "grid", "robots": 2, name: value}, "monitor")


def test_one_error_base_class():
    from tpuaf.experiments.report import ReportError
    from tpuaf.experiments.sweep.grid import SweepError
    from tpuaf.measure.bag import BagError
    from tpuaf.runtimes.config import ConfigError

    from tpuaf_stage import WorldError

    for cls in (CliError, MapError, NodeParamError, ParameterError, ConfigError, WorldError,
                BagError, ReportError, SweepError):
        assert issubclass(cls, TpuafError), cls
    assert issubclass(TpuafError, ValueError)


def test_maps_module_has_no_import_cycle():
    """maps/occupancy.py no longer imports maps/model.py (MapError lives in tpuaf.errors)."""
    from pathlib import Path

    import tpuaf.maps.occupancy as occupancy

    text = Path(occupancy.__file__).read_text()
    assert not re.search(r"^from \.model import", text, re.M)


# ---------------------------------------------------------------------------------------------
# stop signals: one helper for every subcommand (run, compare, fleet, analyze, ...)


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM", "SIGHUP"])
def test_every_subcommand_stops_on_signals_like_ctrl_c(capsys, monkeypatch, sig):
    """main() runs each subcommand with SIGINT, SIGTERM and SIGHUP raising KeyboardInterrupt;
    a second signal while the results are written is only recorded."""
    import signal as signals_module

    import tpuaf.cli.analyze as analyze_cli
    import tpuaf.cli.compare as compare_cli
    from tpuaf.cli import signals

    number = getattr(signals_module, sig)
    seen = {}
    # Not the inherited disposition: a suite run from a background job has SIGINT ignored.
    inherited = signals_module.signal(number, signals_module.default_int_handler
                                      if number == signals_module.SIGINT else signals_module.SIG_DFL)
    request = {"finalizer": lambda: signals_module.signal(number, inherited)}

    def handler(args):
        try:
            os.kill(os.getpid(), number)
            seen["not interrupted"] = True
        except KeyboardInterrupt:
            with signals.shielded():
                os.kill(os.getpid(), number)  # during the end files: recorded, not raised
                seen["shielded"] = True
            raise
        return 0

    for module, argv in ((compare_cli, ["compare", "--out", "x"]),
                         (analyze_cli, ["analyze", "x.bag"])):
        monkeypatch.setattr(module, "run", handler)
        code, _, err = cli(capsys, *argv)
        assert code == 128 + number and "interrupted" in err
        assert seen.pop("shielded") and "not interrupted" not in seen
    # the handlers are restored afterwards
    assert signals_module.getsignal(signals_module.SIGTERM) == signals_module.SIG_DFL
    request["finalizer"]()


def test_an_inherited_ignored_signal_stays_ignored():
    """`nohup` (SIGHUP ignored) and background jobs (SIGINT ignored) keep their meaning."""
    import signal

    from tpuaf.cli import signals

    previous = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        with signals.stop_signals():
            assert signal.getsignal(signal.SIGHUP) == signal.SIG_IGN
            os.kill(os.getpid(), signal.SIGHUP)  # ignored: nothing raised
            assert signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL
    finally:
        signal.signal(signal.SIGHUP, previous)


@pytest.mark.parametrize("name, value, rule", [
    ("skew_warn", 0.0, "> 0"), ("scan_beams", 7, ">= 8"), ("start_wait", -1.0, ">= 0"),
    ("input_timeout", 0.0, "> 0"), ("max_skew", 0.0, "> 0"), ("move_base_timeout", 0.0, "> 0"),
    ("backoff_time", 0.0, "> 0"),
])
def test_agent_limits_are_one_rule_checked_by_the_parser_and_shown_by_help(name, value, rule):
    from tpuaf.params import params_help

    values = {"map": "grid", "robot_index": 0, "robots": 2, name: value}
    with pytest.raises(NodeParamError, match=re.escape(f"patrol_agent: ~{name} must be {rule}, "
                                                       f"got {value!r}")):
        parse(AgentParams, values, "patrol_agent")
    line = next(r for r in params_help(AgentParams).splitlines() if r.split()[0] == f"~{name}")
    assert line.endswith(f"must be {rule}"), line


def test_agent_controller_defaults_are_the_controllers():
    from tpuaf.navigation import ControllerConfig

    c, p = ControllerConfig(), AgentParams()
    assert (p.safety_margin, p.plan_margin, p.stuck_timeout, p.backoff_time,
            p.max_retries) == (c.safety_margin, c.plan_margin, c.stuck_timeout_s, c.backoff_s,
                               c.max_retries)
    # Speed limits and radius default to 0: the robot model's (robot/model.py) decides them.
    assert (p.max_linear_speed, p.max_angular_speed, p.robot_radius) == (0.0, 0.0, 0.0)
