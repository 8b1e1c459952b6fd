"""Complete means complete (issue 33 item 5): `tpuaf fleet` on a 500 kB filesystem fails at once
with a one-line error naming the free space (rosbag records nothing below 1 GiB free), before any
ROS process starts, and never leaves a summary.json; the same folder is usable again. A recorder
that dies during a run ends it (fleet.launch: the recorder is required). Needs root for the tmpfs
(skipped with the reason otherwise)."""

from __future__ import annotations

import os
from pathlib import Path
from xml.etree import ElementTree

import pytest

from ..conftest import run_cli

REPO = Path(__file__).resolve().parents[2]
TPUAF = str(REPO / ".venv" / "bin" / "tpuaf")

pytestmark = [pytest.mark.ros]


def test_a_full_disk_is_refused_before_the_fleet_starts(small_disk):
    out = small_disk / "run"
    env = {k: v for k, v in os.environ.items() if not k.startswith("ROS_")}
    for _ in range(2):  # the refused folder does not block a second try
        run = run_cli([TPUAF, "fleet", "--map", "grid", "--robots", "2", "--duration", "60",
                       "--rtf", "10", "--quiet", "--out", str(out)], timeout=120, env=env,
                      cwd=REPO)
        assert run.returncode == 2, run.stdout + run.stderr
        assert "Traceback" not in run.stderr, run.stderr
        lines = run.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("tpuaf fleet: error: only "), run.stderr
        assert "MiB free" in lines[0] and "--no-record" in lines[0], run.stderr
        assert not (out / "summary.json").exists()
        assert not (out / "roslaunch.log").exists()  # no ROS process was started


def test_the_recorder_is_required_in_the_fleet_launch():
    launch = ElementTree.parse(REPO / "src" / "tpuaf_ros" / "launch" / "fleet.launch")
    recorders = [n for n in launch.getroot().iter("node") if n.get("pkg") == "rosbag"]
    assert recorders and all(n.get("required") == "true" for n in recorders)
