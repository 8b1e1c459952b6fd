"""The catkin workflow of a ROS user, end to end: `git clone` into a fresh workspace's src/,
`catkin_make` and `catkin_make install` in a clean shell (Debian's Python, no venv, no source
tree or devel space of ours on any path), then from the devel space `tpuaf maps lab`,
`rosrun tpuaf_ros patrol_agent --help` and a 60 s `tpuaf fleet`, and `tpuaf maps` from the
install space. `tpuaf analyze` needs `rosbags` (PyPI only): without it, one line names it and
its install command. The build takes about 3-4 minutes on 2 cores (gtests off:
-DCATKIN_ENABLE_TESTING=OFF)."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

from .conftest import REPO

pytestmark = [pytest.mark.ros, pytest.mark.slow]

CLEAN_PATH = "/usr/bin:/bin"


def shell(ws: Path, command: str, space: str = "devel", timeout: float = 600):
    """`command` in bash with only the workspace's `space` sourced, in a clean environment."""
    env = {"PATH": CLEAN_PATH, "HOME": str(ws), "ROS_HOME": str(ws / "ros_home"),
           "ROS_IP": "127.0.0.1", "LANG": "C.UTF-8"}
    setup = f"source '{ws / space / 'setup.bash'}'; " if space else ""
    return subprocess.run(["bash", "-c", f"set -e; {setup}cd '{ws}'; {command}"], env=env,
                          capture_output=True, text=True, timeout=timeout,
                          start_new_session=True)


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    if not (REPO / ".git").exists() or shutil.which("catkin_make") is None:
        pytest.skip("needs a git checkout and catkin_make (launch_scripts/setup.sh)")
    ws = tmp_path_factory.mktemp("catkin_ws")
    (ws / "src").mkdir()
    clone = subprocess.run(["git", "clone", "--quiet", str(REPO), str(ws / "src" / "tpuaf")],
                           capture_output=True, text=True, timeout=120)
    assert clone.returncode == 0, clone.stderr
    flags = "-DCMAKE_BUILD_TYPE=Release -DCATKIN_ENABLE_TESTING=OFF -j2"
    build = shell(ws, f"catkin_make {flags} > build.log 2>&1 && catkin_make install {flags} "
                  ">> build.log 2>&1", space="", timeout=1500)
    log = (ws / "build.log").read_text(errors="replace") if (ws / "build.log").exists() else ""
    assert build.returncode == 0, log[-4000:] + build.stderr
    return ws


def test_tpuaf_maps_from_the_devel_and_install_spaces(workspace):
    for space in ("devel", "install"):
        proc = shell(workspace, "command -v tpuaf; tpuaf maps lab", space=space)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        assert proc.stdout.splitlines()[0] == str(workspace / space / "bin" / "tpuaf")
        assert "edges of lab" in proc.stdout and "Traceback" not in proc.stderr


def test_rosrun_patrol_agent_help(workspace):
    proc = shell(workspace, "rosrun tpuaf_ros patrol_agent --help", timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "~robot_index" in proc.stdout and "~teammate_timeout" in proc.stdout


def test_a_60_s_fleet_from_the_workspace_and_its_analysis(workspace):
    proc = shell(workspace, "tpuaf fleet --map grid --robots 2 --duration 60 --seed 1 "
                 "--out fleet1 --quiet", timeout=900)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    out = workspace / "fleet1"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["complete"] is True and summary["visits"] > 0
    assert summary["duration_s"] == pytest.approx(60.0, abs=1.0)
    # the launch files and nodes came from the workspace, not from the repository
    log = (out / "roslaunch.log").read_text(errors="replace")
    assert str(REPO / "src") not in log
    proc = shell(workspace, "tpuaf analyze fleet1/run.bag --out fleet1/analysis", timeout=300)
    if proc.returncode != 0:  # Debian's Python without rosbags: one line, exit 2
        lines = [line for line in proc.stderr.splitlines() if line.strip()]
        assert proc.returncode == 2 and len(lines) == 1, proc.stderr
        assert "'rosbags' is missing" in lines[0] and "pip install" in lines[0], lines[0]
    else:
        analysis = json.loads((out / "analysis" / "summary.json").read_text())
        assert analysis["visits"] == summary["visits"]
