"""The install space works on its own: `cmake --install` of the workspace into a fresh temporary
root, then, with only that install space sourced (no devel space, no source tree on any path),
`tpuaf run --map grid`, `patrol_agent --help` and a short `tpuaf fleet` (roslaunch tpuaf_ros
fleet.launch) run from it."""

from __future__ import annotations

import json
import os
import re
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
BUILD = REPO / "build"
VENV_PYTHON = REPO / ".venv" / "bin" / "python"

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def configured_prefix() -> Path:
    cache = BUILD / "CMakeCache.txt"
    if not cache.is_file():
        pytest.skip("catkin workspace not built (run launch_scripts/setup.sh)")
    match = re.search(r"^CMAKE_INSTALL_PREFIX:PATH=(.*)$", cache.read_text(), re.M)
    assert match, "CMAKE_INSTALL_PREFIX missing from the CMake cache"
    return Path(match.group(1))


@pytest.fixture(scope="module")
def install_space(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("destdir")
    proc = subprocess.run(["cmake", "--install", str(BUILD)], env={**os.environ, "DESTDIR": str(root)},
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    prefix = root / configured_prefix().relative_to("/")
    assert (prefix / "setup.bash").is_file()
    return prefix


def in_install_space(prefix: Path, command: str, tmp: Path, timeout: float = 300):
    """Run `command` in bash with only the install space sourced: the devel space and the source
    tree are on no search path (ROS_PACKAGE_PATH, CMAKE_PREFIX_PATH, PYTHONPATH)."""
    env = {"PATH": "/usr/bin:/bin", "HOME": str(tmp), "ROS_HOME": str(tmp / "ros_home"),
           "ROS_IP": "127.0.0.1", "LANG": "C.UTF-8"}
    script = f"set -e; source '{prefix}/setup.bash'; cd '{tmp}'; {command}"
    return subprocess.run(["bash", "-c", script], env=env, capture_output=True, text=True,
                          timeout=timeout, start_new_session=True)


def test_install_space_holds_package_data(install_space):
    share = install_space / "share" / "tpuaf_ros"
    for launch in ("fleet.launch", "robots.launch", "robot.launch"):
        assert (share / "launch" / launch).is_file(), launch
    site = install_space / "lib" / "python3" / "dist-packages"
    assert (site / "tpuaf" / "data" / "maps" / "grid" / "map.yaml").is_file()
    assert (site / "tpuaf_core").is_dir() and list((site / "tpuaf_core").glob("_core*.so"))
    assert (install_space / "lib" / "tpuaf_ros" / "patrol_agent").is_file()
    assert (install_space / "lib" / "tpuaf_stage" / "tpuaf_stage").is_file()
    assert (install_space / "bin" / "tpuaf").is_file()


def test_tpuaf_run_from_the_install_space(install_space, tmp_path):
    # The venv's interpreter (PyPI dependencies); the install space comes first on PYTHONPATH.
    command = (f"'{VENV_PYTHON}' -c 'import tpuaf, tpuaf_core; print(tpuaf.__path__[0]); "
               f"print(tpuaf_core.__file__)'; "
               f"'{VENV_PYTHON}' '{install_space}/bin/tpuaf' run --map grid --robots 2 "
               f"--duration 120 --seed 1 --out run1")
    proc = in_install_space(install_space, command, tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    first, second = proc.stdout.splitlines()[:2]
    assert first.startswith(str(install_space)), first
    assert second.startswith(str(install_space)), second
    summary = json.loads((tmp_path / "run1" / "summary.json").read_text())
    assert summary["visits"] > 0


def test_nodes_answer_help_from_the_install_space(install_space, tmp_path):
    proc = in_install_space(install_space, "rosrun tpuaf_ros patrol_agent --help", tmp_path, 60)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "~robot_index" in proc.stdout and "~strategy" in proc.stdout
    proc = in_install_space(install_space, "rosrun tpuaf_ros rviz_view --help", tmp_path, 60)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "--map" in proc.stdout and "--template" in proc.stdout  # rviz.launch's framing node


def test_fleet_runs_from_the_install_space(install_space, tmp_path):
    command = (f"'{VENV_PYTHON}' '{install_space}/bin/tpuaf' fleet --map grid --robots 2 "
               f"--duration 30 --seed 1 --out fleet1 --quiet")
    proc = in_install_space(install_space, command, tmp_path, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    out = tmp_path / "fleet1"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["complete"] is True
    assert summary["visits"] > 0
    # The launch file came from the install space, not the source tree.
    log = (out / "roslaunch.log").read_text(errors="replace")
    assert str(REPO / "src") not in log
