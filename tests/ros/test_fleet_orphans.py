"""`kill -9` of `tpuaf fleet` leaves no process behind (issue 33, item 4): its watchdog stops
roscore and roslaunch (simulator, agents, monitor, rosbag), which closes the bag. Processes are
found by process id (the /proc tree under the fleet), never by name."""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

import pytest

from ..conftest import default_sigint, stop_tree

REPO = Path(__file__).resolve().parents[2]
TPUAF = str(REPO / ".venv" / "bin" / "tpuaf")

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def process_table() -> dict[int, tuple[int, str]]:
    """pid -> (parent pid, state) of every process (states: R S D Z ...)."""
    table = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()  # after "pid (comm) "
        table[int(entry.name)] = (int(fields[1]), fields[0])
    return table


def descendants(root: int) -> set[int]:
    table = process_table()
    children: dict[int, list[int]] = {}
    for pid, (ppid, _) in table.items():
        children.setdefault(ppid, []).append(pid)
    out, todo = set(), [root]
    while todo:
        for child in children.get(todo.pop(), []):
            if child not in out:
                out.add(child)
                todo.append(child)
    return out


def alive(pids: set[int]) -> set[int]:
    table = process_table()
    return {p for p in pids if p in table and table[p][1] != "Z"}


def test_kill_9_of_a_fleet_leaves_no_process(tmp_path):
    out = tmp_path / "fleet"
    env = {k: v for k, v in os.environ.items() if not k.startswith("ROS_")}
    cmd = [TPUAF, "fleet", "--map", "grid", "--robots", "2", "--duration", "900", "--rtf", "2",
           "--quiet", "--out", str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env,
                            cwd=REPO, start_new_session=True, preexec_fn=default_sigint)
    seen: set[int] = set()
    try:
        deadline = time.monotonic() + 180
        rows = 0
        while time.monotonic() < deadline and rows < 10:  # 10 s of run time: all nodes up
            seen |= descendants(proc.pid)
            ts = out / "timeseries.csv"
            rows = len(ts.read_text().splitlines()) - 1 if ts.is_file() else 0
            time.sleep(0.3)
        assert rows >= 10, "the run did not start"
        seen |= descendants(proc.pid)
        # roscore, rosmaster, rosout, roslaunch, the simulator, 2 agents, monitor, rosbag
        assert len(alive(seen)) >= 8, sorted(seen)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(30)
        deadline = time.monotonic() + 90
        while alive(seen) and time.monotonic() < deadline:
            time.sleep(0.5)
        left = alive(seen)
        assert not left, {p: Path(f"/proc/{p}/cmdline").read_bytes()[:80] for p in left}
        # rosbag was stopped with SIGINT: the bag is closed, not left .active
        assert (out / "run.bag").is_file() and not (out / "run.bag.active").exists()
    finally:
        stop_tree(proc)
        for pid in alive(seen):  # a failed test leaves nothing running either
            try:
                os.killpg(pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
