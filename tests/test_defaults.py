"""One source per default (issue 31): the liveness defaults are declared once
(`tpuaf.params.LIVENESS_DEFAULTS`) and read everywhere; every launch-file arg that sets a node
parameter defaults to the parameter's declared default; `--teammate-timeout` of `tpuaf run`,
`compare` and `fleet` reaches the runs (RunConfig, the sweep's tasks, fleet.launch's args) and
their config.yaml; a bad value is a one-line error with exit code 2."""

from __future__ import annotations

import inspect
import json
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from dataclasses import MISSING, fields
from pathlib import Path

import pytest
from tpuaf.params import LIVENESS_DEFAULTS, AgentParams, MonitorParams, parse_monitor

REPO = Path(__file__).resolve().parents[1]
LAUNCH_DIR = REPO / "src/tpuaf_ros/launch"
PACKAGE = REPO / "src/tpuaf_ros/src/tpuaf"
TPUAF = str(REPO / ".venv" / "bin" / "tpuaf")
L = LIVENESS_DEFAULTS

# The node types whose private parameters are declared in tpuaf.params.
NODE_PARAMS = {"patrol_agent": AgentParams, "monitor": MonitorParams}
# Launch-file defaults that differ from the node's on purpose: (file, arg, field) -> why.
DELIBERATE = {
    ("fleet.launch", "duration", "MonitorParams.duration"):
        "a simulated fleet is a 600 s demonstration (as `tpuaf fleet --duration`); the "
        "monitor node alone measures an hour, as the paper",
    ("fleet.launch", "lockstep", "AgentParams.lockstep"):
        "the fleet's simulator steps in lock-step with its agents; a robot's agent does not",
    ("fleet.launch", "strategy", "MonitorParams.strategy"):
        "the monitor's ~strategy only labels config.yaml (empty = not said); the agents' is "
        "the default strategy",
}
ARG_REF = re.compile(r"^\$\(arg (\w+)\)$")


# ---------------------------------------------------------------------------------------------
# Launch files: which node parameters each arg sets, through includes


def _root(name: str) -> ET.Element:
    return ET.parse(LAUNCH_DIR / name).getroot()


def arg_targets(name: str, seen: frozenset = frozenset()) -> dict[str, set[str]]:
    """{arg: {"AgentParams.field", ...}}: the declared node parameters each arg of launch file
    `name` sets, directly (<param value="$(arg A)"> of a patrol_agent or monitor node), through
    an include (<arg name="B" value="$(arg A)"> of a launch file of this folder), or through
    another arg whose default is "$(arg A)"."""
    if name in seen:
        return {}  # robots.launch includes itself: its args are already traced
    root = _root(name)
    targets: dict[str, set[str]] = {}
    for node in root.iter("node"):
        cls = NODE_PARAMS.get(node.get("type"))
        for param in node.iter("param") if cls else ():
            ref = ARG_REF.match(param.get("value") or "")
            if ref and param.get("name") in {f.name for f in fields(cls)}:
                targets.setdefault(ref.group(1), set()).add(f"{cls.__name__}.{param.get('name')}")
    for include in root.iter("include"):
        inner = Path(include.get("file").replace("$(dirname)/", "")).name
        inner_targets = arg_targets(inner, seen | {name})
        for arg in include.iter("arg"):
            ref = ARG_REF.match(arg.get("value") or "")
            if ref:
                targets.setdefault(ref.group(1), set()).update(inner_targets.get(arg.get("name"), ()))
    for arg in root.iter("arg"):  # <arg name="B" default="$(arg A)">: A also sets what B sets
        ref = ARG_REF.match(arg.get("default") or "")
        if ref and arg.get("value") is None:
            targets.setdefault(ref.group(1), set()).update(targets.get(arg.get("name"), ()))
    return {a: t for a, t in targets.items() if t}


def arg_defaults(name: str) -> dict[str, str]:
    """{arg: default} of the args a user can set, "$(arg X)" replaced by X's default."""
    out: dict[str, str] = {}
    for arg in _root(name).iter("arg"):
        if arg.get("value") is None and arg.get("default") is not None:
            ref = ARG_REF.match(arg.get("default"))
            out[arg.get("name")] = out[ref.group(1)] if ref else arg.get("default")
    return out


def declared(target: str):
    """(the declared default, required?) of "AgentParams.field"."""
    cls = {c.__name__: c for c in NODE_PARAMS.values()}[target.split(".")[0]]
    f = next(f for f in fields(cls) if f.name == target.split(".")[1])
    default = f.default if f.default is not MISSING else f.default_factory()
    return default, bool(f.metadata.get("required"))


def as_declared(text: str, default):
    """A launch default (text) read as the declared default's type; None if not comparable."""
    if isinstance(default, bool):
        return {"true": True, "false": False}.get(text.strip().lower())
    if isinstance(default, (int, float)):
        try:
            return type(default)(float(text)) if isinstance(default, float) else int(text)
        except ValueError:
            return None
    return text if isinstance(default, str) else None


def launch_checks() -> list[tuple[str, str, str, str]]:
    """(file, arg, its default, target) of every arg default that sets a declared parameter."""
    rows = []
    for path in sorted(LAUNCH_DIR.glob("*.launch")):
        defaults = arg_defaults(path.name)
        for arg, targets in sorted(arg_targets(path.name).items()):
            for target in sorted(targets):
                default, required = declared(target)
                if arg in defaults and not required and not isinstance(default, (list, dict)):
                    rows.append((path.name, arg, defaults[arg], target))
    return rows


def test_the_launch_check_covers_the_liveness_args():
    checked = {(name, arg, target) for name, arg, _, target in launch_checks()}
    for name in ("fleet.launch", "robots.launch", "robot.launch"):
        assert (name, "teammate_timeout", "AgentParams.teammate_timeout") in checked, name
    assert ("fleet.launch", "teammate_timeout", "MonitorParams.teammate_timeout") in checked
    assert ("fleet.launch", "death_timeout", "MonitorParams.death_timeout") in checked
    assert ("robot.launch", "heartbeat_period", "AgentParams.heartbeat_period") in checked
    # one liveness rule: fleet.launch's teammate timeout is also the monitor's death timeout
    assert "MonitorParams.death_timeout" in arg_targets("fleet.launch")["teammate_timeout"]
    assert ("robot.launch", "max_angular_speed", "AgentParams.max_angular_speed") in checked
    assert len(checked) >= 20


@pytest.mark.parametrize("name, arg, text, target", launch_checks(),
                         ids=lambda v: v if isinstance(v, str) else "")
def test_launch_defaults_are_the_declared_defaults(name, arg, text, target):
    default, _ = declared(target)
    if (name, arg, target) in DELIBERATE:
        assert as_declared(text, default) != default, f"{name}: {arg} is no longer an exception"
        return
    assert as_declared(text, default) == default, (
        f"{name}: <arg {arg} default={text!r}> sets {target}, declared {default!r} "
        "(tpuaf.params); write the declared value in the launch file")


def test_the_tracer_follows_params_includes_and_arg_references(tmp_path, monkeypatch):
    """The checker itself, on two launch files written here."""
    (tmp_path / "a.launch").write_text(
        '<launch><arg name="t" default="3.0"/><arg name="d" default="$(arg t)"/>'
        '<include file="$(dirname)/b.launch"><arg name="x" value="$(arg t)"/></include>'
        '<node pkg="p" type="monitor" name="m"><param name="death_timeout" value="$(arg d)"/>'
        '</node></launch>')
    (tmp_path / "b.launch").write_text(
        '<launch><arg name="x"/><node pkg="p" type="patrol_agent" name="a">'
        '<param name="teammate_timeout" value="$(arg x)"/><param name="nope" value="$(arg x)"/>'
        '</node></launch>')
    monkeypatch.setattr(sys.modules[__name__], "LAUNCH_DIR", tmp_path)
    assert arg_targets("a.launch") == {
        "t": {"AgentParams.teammate_timeout", "MonitorParams.death_timeout"},
        "d": {"MonitorParams.death_timeout"}}
    assert arg_defaults("a.launch") == {"t": "3.0", "d": "3.0"}


# ---------------------------------------------------------------------------------------------
# Python: every place reads the declared defaults


def test_liveness_defaults_are_declared_once_and_read_everywhere():
    from tpuaf.measure.monitor import FleetMonitor
    from tpuaf.robot.machine import RobotMachine
    from tpuaf.runtimes.agent import AgentRuntime
    from tpuaf.runtimes.config import PhysicsConfig, RunConfig
    from tpuaf.team.liveness import HEARTBEAT_PERIOD_S, TeammateLiveness, heartbeat_links

    assert (L.teammate_timeout_s, L.heartbeat_period_s, L.death_timeout_s) == (10.0, 1.0, 10.0)
    a, m = AgentParams(), MonitorParams()
    assert (a.teammate_timeout, a.heartbeat_period) == (L.teammate_timeout_s, L.heartbeat_period_s)
    assert (m.teammate_timeout, m.death_timeout) == (L.teammate_timeout_s, L.death_timeout_s)
    assert RunConfig().teammate_timeout_s == PhysicsConfig().teammate_timeout_s == L.teammate_timeout_s
    assert TeammateLiveness(2, 0).timeout_s == L.teammate_timeout_s
    assert HEARTBEAT_PERIOD_S == L.heartbeat_period_s
    for fn, name in ((RobotMachine, "teammate_timeout_s"), (AgentRuntime, "teammate_timeout_s"),
                     (AgentRuntime, "heartbeat_period_s"), (heartbeat_links, "period_s"),
                     (FleetMonitor, "teammate_timeout_s")):
        value = inspect.signature(fn).parameters[name].default
        assert value in (L.teammate_timeout_s, L.heartbeat_period_s) and value == (
            L.heartbeat_period_s if "period" in name else L.teammate_timeout_s), (fn, name)


def test_no_liveness_default_is_written_as_a_number_in_the_package():
    """A second literal default (the old `teammate_timeout_s: float = 10.0`) fails here."""
    pattern = re.compile(r"\b(teammate_timeout|death_timeout|heartbeat_period)\w*"
                         r"\s*(:[^=#]+)?=\s*[\d.]")
    found = [f"{path.relative_to(PACKAGE)}:{k}: {line.strip()}"
             for path in sorted(PACKAGE.rglob("*.py")) if path.name != "params.py"
             for k, line in enumerate(path.read_text().splitlines(), 1)
             if pattern.search(line.split("#")[0])]
    assert found == []


def test_the_monitors_death_timeout_follows_the_teammate_timeout():
    from tpuaf.maps import load_map
    from tpuaf.measure.monitor import FleetMonitor

    base = {"map": "grid", "robots": 2}
    assert parse_monitor(base, "monitor").death_timeout == L.death_timeout_s
    assert parse_monitor({**base, "teammate_timeout": 4.0}, "monitor").death_timeout == 4.0
    given = parse_monitor({**base, "teammate_timeout": 4.0, "death_timeout": 7.0}, "monitor")
    assert (given.teammate_timeout, given.death_timeout) == (4.0, 7.0)
    grid = load_map("grid")
    assert FleetMonitor(grid, 2, 60.0).death_timeout_s == L.death_timeout_s
    assert FleetMonitor(grid, 2, 60.0, teammate_timeout_s=3.0).death_timeout_s == 3.0
    assert FleetMonitor(grid, 2, 60.0, teammate_timeout_s=3.0,
                        death_timeout_s=5.0).death_timeout_s == 5.0


# ---------------------------------------------------------------------------------------------
# --teammate-timeout


def test_run_flag_reaches_run_config_and_config_yaml(tmp_path):
    import yaml

    out = tmp_path / "run"
    proc = subprocess.run([TPUAF, "run", "--robots", "2", "--duration", "120", "--quiet",
                           "--no-plots", "--teammate-timeout", "4.5", "--fail", "1@30",
                           "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    config = yaml.safe_load((out / "config.yaml").read_text())
    assert config["teammate_timeout_s"] == 4.5
    summary = json.loads((out / "summary.json").read_text())
    assert summary["liveness"]["teammate_timeout_s"] == 4.5, summary.get("liveness")


def test_run_flag_default_is_the_declared_one():
    from tpuaf.cli import build_parser

    parser = build_parser(lazy=False)
    for argv in (["run"], ["compare", "--out", "x"], ["fleet", "--out", "x"]):
        assert parser.parse_args(argv).teammate_timeout == L.teammate_timeout_s, argv
    assert parser.parse_args(["run", "--teammate-timeout", "2.5"]).teammate_timeout == 2.5


def test_compare_flag_reaches_every_run(tmp_path):
    from tpuaf.cli import main
    from tpuaf.experiments.sweep.grid import RunKey, make_spec
    from tpuaf.experiments.sweep.worker import run_config

    spec = make_spec(["grid"], ["gbs"], [2], 1, 60.0, teammate_timeout_s=3.0)
    task = spec.task(RunKey("grid", "gbs", 2, 0))
    assert task["teammate_timeout_s"] == 3.0 and run_config(task).teammate_timeout_s == 3.0
    root = tmp_path / "sweep"
    argv = ["compare", "--maps", "grid", "--strategies", "gbs", "--robots", "2", "--duration",
            "60", "--seeds", "1", "--quiet", "--workers", "1", "--out", str(root)]
    assert main([*argv, "--teammate-timeout", "3"]) == 0
    (folder,) = root.glob("runs/grid/gbs/N2/seed0")
    assert json.loads((folder / "config.json").read_text())["config"]["teammate_timeout_s"] == 3.0
    assert json.loads((folder / "summary.json").read_text())["run"]["teammate_timeout_s"] == 3.0
    assert json.loads((root / "sweep.json").read_text())["teammate_timeout_s"] == 3.0
    assert main(argv) == 2  # resumed with another teammate timeout: refused, not mixed


def test_fleet_flag_reaches_the_launch_args_and_fleet_config(tmp_path):
    import yaml

    out = tmp_path / "fleet"
    proc = subprocess.run([TPUAF, "fleet", "--prepare-only", "--duration", "60",
                           "--teammate-timeout", "4", "--out", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "fleet.launch" in proc.stdout and " teammate_timeout:=4.0" in proc.stdout, proc.stdout
    assert "death_timeout:=" not in proc.stdout  # fleet.launch: it follows teammate_timeout
    config = yaml.safe_load((out / "fleet_config.yaml").read_text())
    assert config["teammate_timeout_s"] == 4.0


@pytest.mark.parametrize("command", ["run", "compare", "fleet"])
@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf", "ten"])
def test_bad_teammate_timeouts_are_one_line_errors(tmp_path, command, value):
    out = tmp_path / "out"
    proc = subprocess.run([TPUAF, command, "--out", str(out), "--teammate-timeout", value],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert "--teammate-timeout: expected a finite number > 0" in lines[0], lines[0]
    assert not out.exists()
