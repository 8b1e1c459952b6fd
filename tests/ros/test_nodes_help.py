"""Every node answers `--help` with its parameters, without a ROS master."""

from __future__ import annotations

import subprocess

import pytest

from .conftest import REPO, workspace_env

pytestmark = pytest.mark.ros

NODES = {
    "patrol_agent": REPO / "src/tpuaf_ros/nodes/patrol_agent",
    "monitor": REPO / "src/tpuaf_ros/nodes/monitor",
    "patrol_markers": REPO / "src/tpuaf_ros/nodes/patrol_markers",
    "team_relay": REPO / "src/tpuaf_ros/nodes/team_relay",
    "tpuaf_stage": REPO / "devel/lib/tpuaf_stage/tpuaf_stage",
}


@pytest.mark.parametrize("name", sorted(NODES))
def test_node_help_lists_its_parameters_without_a_master(name):
    env = {**workspace_env(), "ROS_MASTER_URI": "http://127.0.0.1:9/"}  # nothing listens there
    proc = subprocess.run([str(NODES[name]), "--help"], env=env, capture_output=True, text=True,
                          timeout=60, start_new_session=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    lines = [line for line in proc.stdout.splitlines() if line.strip().startswith("~")]
    assert len(lines) >= 2, proc.stdout
    assert proc.stdout.startswith(name), proc.stdout[:200]


# A node started with a bad parameter: one error line that names the node once, exit code 2.
# The messages come from the parameter parser (which names the node), from the node's own checks
# and from the map loader (which do not): every path is covered.
BAD_PARAMS = [
    ("patrol_agent", ["_map:=grid", "_robot_index:=0", "_robots:=0"], "~robots must be >= 1"),
    ("patrol_agent", ["_map:=/tmp/nope-xyz", "_robot_index:=0", "_robots:=1"],
     "no such map folder /tmp/nope-xyz"),
    ("monitor", ["_map:=grid", "_robots:=2", "_bogus:=1"], "unknown parameter(s) ~bogus"),
    ("monitor", ["_map:=grid", "_robots:=2", "_pose_source:=gps"], "~pose_source must be one of"),
    ("patrol_markers", ["_map:=grid", "_robots:=2", "_color_by:=red"], "~color_by must be one of"),
    ("patrol_agent", ["_map:=grid", "_robot_index:=0", "_robots:=1",
                      "_map_params:={speed: 1.0}"], "~map_params: unknown map parameter 'speed'"),
    ("patrol_markers", ["_map:=grid", "_robots:=1", "_map_params:={sensing_radius: -1}"],
     "~map_params: sensing_radius must be > 0"),
    ("team_relay", ["_robots:=2", "_loss:=2.0"], "~loss must be in [0, 1]"),
]


@pytest.mark.parametrize("case", range(len(BAD_PARAMS)),
                         ids=[f"{n}-{m.split()[0]}" for n, _, m in BAD_PARAMS])
def test_a_bad_parameter_is_one_error_line_naming_the_node_once(module_roscore, case):
    name, params, message = BAD_PARAMS[case]
    ns = f"/tb3_{case}"  # its own namespace: the parameters of earlier cases stay on the server
    node = f"{ns}/{name}"
    proc = subprocess.run([str(NODES[name]), f"__ns:={ns}", *params], env=module_roscore.env,
                          capture_output=True, text=True, timeout=120, start_new_session=True,
                          cwd=module_roscore.home)
    text = proc.stdout + proc.stderr
    assert proc.returncode == 2, text
    assert "Traceback" not in text, text
    errors = [line for line in text.splitlines() if "FATAL" in line or "ERROR" in line]
    assert len(errors) == 1, text
    assert message in errors[0], errors[0]
    assert errors[0].count(node) == 1 and errors[0].count(name) == 1, errors[0]
    assert f"]: {node}: " in errors[0], errors[0]  # "[FATAL] [time]: /tb3_0/name: problem"
