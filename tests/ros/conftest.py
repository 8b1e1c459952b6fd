"""Shared fixtures for ROS integration tests: a private roscore per test (or module) and helpers
to start nodes, launch files and probe scripts with the test's environment.

Rules (docs/DEVELOPING.md): own master on a free port (never 11311), ROS_HOME in a temp dir,
ROS_IP=127.0.0.1, processes stopped by PID (SIGINT, then SIGKILL of the process group we created).

rospy can be initialised once per process and binds to one master, so test-side ROS clients run
in subprocesses too: `RosEnv.run_python(code)` runs a snippet and returns its stdout.

Usage:
    def test_x(roscore):                       # function-scoped master
        node = roscore.start(["rosrun", "pkg", "node", "_param:=1"], name="node")
        out = roscore.run_python("import rospy; ...", timeout=30)
    ros_master(tmp_dir) is the same as a context manager (for module fixtures and scripts).
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
import xmlrpc.client
from collections.abc import Iterator
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import pytest
from tpuaf.cli.fleet import free_port  # a free loopback port, never 11311

from ..conftest import default_sigint

REPO = Path(__file__).resolve().parents[2]
VENV_PYTHON = REPO / ".venv" / "bin" / "python"


@lru_cache(maxsize=1)
def workspace_env() -> dict[str, str]:
    """os.environ plus what `source devel/setup.bash` sets (PATH, PYTHONPATH, ROS_PACKAGE_PATH)."""
    setup = REPO / "devel" / "setup.bash"
    if not setup.is_file():
        pytest.skip("catkin workspace not built (run launch_scripts/setup.sh)")
    out = subprocess.run(["bash", "-c", f"source '{setup}' && env -0"], capture_output=True,
                         check=True, env={**os.environ, "PATH": "/usr/bin:/bin:" + os.environ.get(
                             "PATH", "")}).stdout
    env = dict(item.split("=", 1) for item in out.decode().split("\0") if "=" in item)
    return env


def stop_process(proc: subprocess.Popen, timeout: float = 10.0) -> int | None:
    """SIGINT to the process group we created (start_new_session), then SIGKILL."""
    if proc.poll() is not None:
        return proc.returncode
    with contextlib.suppress(ProcessLookupError):
        os.killpg(proc.pid, signal.SIGINT)
    try:
        return proc.wait(timeout)
    except subprocess.TimeoutExpired:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        return proc.wait(5.0)


@dataclass
class RosEnv:
    port: int
    home: Path
    env: dict[str, str]
    procs: list[subprocess.Popen] = field(default_factory=list)

    @property
    def uri(self) -> str:
        return f"http://127.0.0.1:{self.port}/"

    def start(self, cmd: list[str], name: str = "proc", **env_extra: str) -> subprocess.Popen:
        """Start a node, launch file or script with the test's environment; stdout/stderr go to
        <home>/<name>.out / .err (see `output`). Stopped with the master."""
        out = open(self.home / f"{name}.out", "wb")  # noqa: SIM115 - closed by the child's exit
        err = open(self.home / f"{name}.err", "wb")  # noqa: SIM115
        proc = subprocess.Popen(cmd, env={**self.env, **env_extra}, stdout=out, stderr=err,
                                stdin=subprocess.DEVNULL, start_new_session=True, cwd=self.home,
                                preexec_fn=default_sigint)  # SIGINT stops it, even if ignored here
        proc.log_name = name
        self.procs.append(proc)
        return proc

    def output(self, name: str) -> str:
        """What process `name` wrote so far (stdout + stderr)."""
        text = ""
        for suffix in (".out", ".err"):
            p = self.home / f"{name}{suffix}"
            if p.is_file():
                text += p.read_text(errors="replace")
        return text

    def run_python(self, code: str, timeout: float = 60.0, args: list[str] | None = None,
                   name: str = "probe") -> subprocess.CompletedProcess:
        """Run a Python snippet (Debian python with the workspace, like the nodes)."""
        script = self.home / f"{name}.py"
        script.write_text(code)
        return subprocess.run([str(VENV_PYTHON), str(script), *(args or [])], env=self.env,
                              capture_output=True, text=True, timeout=timeout, cwd=self.home)

    def master_up(self) -> bool:
        try:
            code, _, _ = xmlrpc.client.ServerProxy(self.uri).getSystemState("/probe")
            return code == 1
        except (OSError, xmlrpc.client.Error):
            return False

    def stop(self, proc: subprocess.Popen, timeout: float = 10.0) -> int | None:
        return stop_process(proc, timeout)

    def stop_all(self) -> None:
        for proc in reversed(self.procs):
            stop_process(proc)


@contextlib.contextmanager
def ros_master(home: Path, startup_timeout: float = 30.0) -> Iterator[RosEnv]:
    """A roscore on a free port with ROS_HOME=home; everything started through it is stopped
    (by PID / process group) on exit."""
    home = Path(home)
    home.mkdir(parents=True, exist_ok=True)
    base = dict(workspace_env())
    base.pop("ROS_HOSTNAME", None)
    for attempt in range(3):
        port = free_port()
        env = {**base, "ROS_MASTER_URI": f"http://127.0.0.1:{port}/", "ROS_HOME": str(home),
               "ROS_LOG_DIR": str(home / "log"), "ROS_IP": "127.0.0.1", "PYTHONUNBUFFERED": "1"}
        ros = RosEnv(port, home, env)
        core = ros.start(["roscore", "-p", str(port)], name=f"roscore{attempt}")
        deadline = time.monotonic() + startup_timeout
        while time.monotonic() < deadline and core.poll() is None and not ros.master_up():
            time.sleep(0.1)
        if ros.master_up():
            break
        stop_process(core)
    else:
        raise RuntimeError(f"roscore did not start; see {home}/roscore*.err")
    try:
        yield ros
    finally:
        ros.stop_all()


@pytest.fixture
def roscore(tmp_path) -> Iterator[RosEnv]:
    """A private roscore for one test."""
    with ros_master(tmp_path / "ros") as ros:
        yield ros


@pytest.fixture(scope="module")
def module_roscore(tmp_path_factory) -> Iterator[RosEnv]:
    """A private roscore shared by the tests of one module."""
    with ros_master(tmp_path_factory.mktemp("ros")) as ros:
        yield ros


if __name__ == "__main__":  # manual check: python tests/ros/conftest.py
    with ros_master(Path(sys.argv[1] if len(sys.argv) > 1 else "/tmp/rosenv")) as r:
        print("master up at", r.uri)
