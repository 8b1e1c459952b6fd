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
