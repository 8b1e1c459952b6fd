"""The processes of `tpuaf fleet`: its own roscore on a free port (ROS_HOME under the run folder,
ROS_IP=127.0.0.1), then roslaunch (which starts the simulator, agents, monitor and rosbag), and
their stop by PID only: SIGINT to the process group we created (roslaunch stops its nodes;
rosbag closes the bag), wait, then SIGTERM, then SIGKILL; the same on Ctrl-C. An agent killed
for a fault (`kill_node`) is found by the PID the node itself reports through the master.

No orphans: a watchdog process (`python -m tpuaf.cli.fleet_supervisor --watch`, its own session)
holds the read end of a pipe only `tpuaf fleet` writes to. When `tpuaf fleet` ends in any way,
`kill -9` included, the pipe closes and the watchdog stops every process group we started, in
reverse order, with the same SIGINT, SIGTERM, SIGKILL escalation (so rosbag still closes its
bag). After a normal stop it finds the groups gone and exits.

No rospy here (the master and nodes are asked over XML-RPC): `tpuaf.cli.fleet_ros` follows the
run. Standard library only at import time (the `tpuaf` parser imports tpuaf.cli.fleet).
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import struct
import subprocess
import time
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from tpuaf.errors import CliError

MASTER_START_S = 30.0  # [s of wall time] roscore must answer within this
T = TypeVar("T")


def free_port() -> int:
    while True:
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        if port != 11311:
            return port


def ros_env(port: int, home: Path) -> dict[str, str]:
    env = dict(os.environ)
    env.pop("ROS_HOSTNAME", None)
    env.update({"ROS_MASTER_URI": f"http://127.0.0.1:{port}/", "ROS_HOME": str(home),
                "ROS_LOG_DIR": str(home / "log"), "ROS_IP": "127.0.0.1",
                "PYTHONUNBUFFERED": "1", "PATH": "/usr/bin:/bin:" + env.get("PATH", "")})
    return env


def start(cmd: list[str], env: dict, log: Path) -> subprocess.Popen:
    from tpuaf.files import open_fresh

    f = open_fresh(log, "wb")  # the child keeps it; never through a link
    # SIGINT at its default in the child even when tpuaf runs with it ignored (a background
    # job): `stop` relies on SIGINT to make roslaunch stop its nodes and close the bag.
    return subprocess.Popen(cmd, env=env, stdout=f, stderr=subprocess.STDOUT,
                            stdin=subprocess.DEVNULL, start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def stop(proc: subprocess.Popen, grace_s: float = 20.0) -> None:
    """SIGINT to the process (group we created), wait, then SIGTERM, then SIGKILL."""
    for sig, wait in ((signal.SIGINT, grace_s), (signal.SIGTERM, 5.0), (signal.SIGKILL, 5.0)):
        if proc.poll() is not None:
            return
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, sig)
        try:
            proc.wait(wait)
            return
        except subprocess.TimeoutExpired:
            continue


def master_up(port: int) -> bool:
    import xmlrpc.client

    try:
        code, _, _ = xmlrpc.client.ServerProxy(f"http://127.0.0.1:{port}/").getSystemState("/x")
        return code == 1
    except (OSError, xmlrpc.client.Error):
        return False


def node_pid(master_uri: str, node: str) -> int | None:
    """PID of a node, asked from the node itself (its XML-RPC getPid) via the master."""
    import xmlrpc.client

    try:
        code, _, uri = xmlrpc.client.ServerProxy(master_uri).lookupNode("/tpuaf_fleet", node)
        if code != 1:
            return None
        code, _, pid = xmlrpc.client.ServerProxy(uri).getPid("/tpuaf_fleet")
        return int(pid) if code == 1 else None
    except (OSError, xmlrpc.client.Error, ValueError):
        return None


def kill_node(master_uri: str, node: str) -> int | None:
    """SIGKILL to a node's process (an injected death); its PID, or None if not found."""
    pid = node_pid(master_uri, node)
    if pid is not None:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)
    return pid


def wait_bag_closed(bag: Path, timeout_s: float = 30.0) -> bool:
    """True once run.bag exists and no run.bag.active remains (the recorder closed it)."""
    active = bag.with_name(bag.name + ".active")
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if bag.is_file() and not active.exists():
            return True
        time.sleep(0.2)
    return False


BAG_MAGIC = b"#ROSBAG V2.0\n"
# the files of a fleet run folder the monitor writes (ResultsWriter), each never empty
MONITOR_FILES = ("config.yaml", "visits.csv", "timeseries.csv", "info.csv", "idleness.csv",
                 "timeresults.csv")


def bag_problem(bag: Path) -> str | None:
    """Why `bag` is not a closed ROS bag (None when it is): missing, empty, not a bag, or its
    header's index_pos still 0 (rosbag writes it when it closes the bag) or past the end."""
    try:
        with open(bag, "rb") as f:
            head = f.read(4096)
            size = os.fstat(f.fileno()).st_size
    except OSError as err:
        return f"{bag.name}: {err.strerror or err}"
    if not head:
        return f"{bag.name} is empty"
    if not head.startswith(BAG_MAGIC):
        return f"{bag.name} is not a ROS bag (v2.0)"
    pos = len(BAG_MAGIC)
    try:
        (header_len,) = struct.unpack_from("<I", head, pos)
        pos, end = pos + 4, pos + 4 + header_len
        while pos < end:
            (n,) = struct.unpack_from("<I", head, pos)
            name, _, value = head[pos + 4:pos + 4 + n].partition(b"=")
            pos += 4 + n
            if name == b"index_pos":
                (index_pos,) = struct.unpack("<Q", value)
                if index_pos == 0 or index_pos > size:
                    return f"{bag.name} was not closed (no index: rosbag did not finish it)"
                return None
    except struct.error:
        pass
    return f"{bag.name}: unreadable bag header"


def run_file_problems(out: Path, bag: Path | None, bag_closed: bool) -> list[str]:
    """What is missing, empty or unfinished among a fleet run's files (the bag when recorded,
    simulator.json, the monitor's files), one short phrase each; [] when all are there."""
    problems = []
    if bag is not None:
        if not bag_closed:
            problems.append(f"{bag.name} not closed ({bag.name}.active remains)")
        else:
            why = bag_problem(bag)
            if why:
                problems.append(why)
    sim = out / "simulator.json"
    try:
        json.loads(sim.read_text())
    except FileNotFoundError:
        problems.append("simulator.json missing")
    except (OSError, ValueError):
        problems.append("simulator.json empty, cut short or unreadable")
    for name in MONITOR_FILES:
        path = out / name
        if not path.is_file():
            problems.append(f"{name} missing")
        elif path.stat().st_size == 0:
            problems.append(f"{name} empty")
    return problems


def stop_group(pgid: int, grace_s: float = 20.0) -> None:
    """`stop` for a process group we did not start from this process (the watchdog's)."""
    for sig, wait in ((signal.SIGINT, grace_s), (signal.SIGTERM, 5.0), (signal.SIGKILL, 5.0)):
        try:
            os.killpg(pgid, sig)
        except ProcessLookupError:
            return
        deadline = time.monotonic() + wait
        while time.monotonic() < deadline:
            try:
                os.killpg(pgid, 0)
            except ProcessLookupError:
                return
            time.sleep(0.1)


class Watchdog:
    """The process that stops our process groups if `tpuaf fleet` dies (module docstring)."""

    def __init__(self) -> None:
        import sys

        self.proc = subprocess.Popen(
            [sys.executable, "-m", "tpuaf.cli.fleet_supervisor", "--watch"],
            stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            start_new_session=True, env=dict(os.environ, PYTHONPATH=_package_path()))

    def guard(self, pgid: int) -> None:
        """Stop group `pgid` if we die (groups are stopped in the reverse order of guard)."""
        with contextlib.suppress(BrokenPipeError):
            self.proc.stdin.write(f"{pgid}\n".encode())
            self.proc.stdin.flush()

    def close(self) -> None:
        """Our own stop is done: the watchdog finds nothing left and exits."""
        with contextlib.suppress(BrokenPipeError, OSError):
            self.proc.stdin.close()
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(10.0)


def _package_path() -> str:
    """PYTHONPATH that imports this `tpuaf` package first (source, devel or install space)."""
    here = Path(__file__).resolve().parents[2]
    return os.pathsep.join(p for p in (str(here), os.environ.get("PYTHONPATH", "")) if p)


def watch(stream) -> None:
    """The watchdog's loop: read PGIDs until EOF (the parent is gone), then stop them."""
    for sig in (signal.SIGINT, signal.SIGHUP, signal.SIGTERM):
        signal.signal(sig, signal.SIG_IGN)  # only the pipe's end stops the watchdog
    groups = [int(line) for line in iter(stream.readline, b"") if line.strip().isdigit()]
    for pgid in reversed(groups):
        stop_group(pgid)


def supervise(ros_env_sh: Path, cmd: list[str], home: Path, launch_log: Path,
              follow: Callable[[dict, subprocess.Popen], T]) -> tuple[T | None, bool]:
    """roscore on a free port, then `cmd` (roslaunch) through `ros_env_sh`, both logged;
    `follow(env, launch)` while they run; then both stopped by PID, also on Ctrl-C (or
    SIGTERM/SIGHUP: tpuaf.cli.signals). Returns (what follow returned, None when interrupted;
    interrupted). CliError when roscore does not start."""
    port = free_port()
    env = ros_env(port, home)
    procs: list[subprocess.Popen] = []
    watchdog = Watchdog()
    try:
        core = start([str(ros_env_sh), "roscore", "-p", str(port)], env, home / "roscore.log")
        procs.append(core)
        watchdog.guard(core.pid)
        deadline = time.monotonic() + MASTER_START_S
        while not master_up(port):
            if core.poll() is not None or time.monotonic() > deadline:
                raise CliError(f"roscore did not start (log: {home / 'roscore.log'})")
            time.sleep(0.1)
        launch = start([str(ros_env_sh), *cmd], env, launch_log)
        procs.append(launch)
        watchdog.guard(launch.pid)
        return follow(env, launch), False
    except KeyboardInterrupt:
        return None, True
    finally:
        for proc in reversed(procs):
            stop(proc)
        watchdog.close()


if __name__ == "__main__":
    import sys

    if sys.argv[1:] == ["--watch"]:
        watch(sys.stdin.buffer)
