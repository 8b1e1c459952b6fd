"""ROS fleet runs end to end through `tpuaf fleet` (own roscore, simulator, agents, monitor,
rosbag) and `tpuaf analyze` on the bag. Simulated durations are short and paced at 10x real time
to keep this module at about 3 minutes of wall time."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from ..conftest import default_sigint, run_cli, stop_tree

REPO = Path(__file__).resolve().parents[2]
TPUAF = [str(REPO / ".venv" / "bin" / "tpuaf")]

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def fleet_cmd(out: Path, strategy="tpuaf", robots=4, duration=600.0, seed=0, extra=()):
    return [*TPUAF, "fleet", "--map", "grid", "--strategy", strategy, "--robots", str(robots),
            "--duration", str(duration), "--seed", str(seed), "--out", str(out), "--rtf", "10",
            "--quiet", *extra]


def run_fleet(out: Path, **kw) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ROS_")}
    return run_cli(fleet_cmd(out, **kw), timeout=900, env=env, cwd=REPO)


@pytest.fixture(scope="module")
def tpuaf_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("fleet") / "grid4"
    proc = run_fleet(out, duration=600.0, seed=1)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out, proc


def test_fleet_tpuaf_grid_completes_and_visits_everything(tpuaf_run):
    out, proc = tpuaf_run
    summary = json.loads((out / "summary.json").read_text())
    assert summary["complete"] is True
    assert summary["duration_s"] == pytest.approx(600.0)
    assert summary["unvisited_vertices"] == 0
    assert summary["deaths"] == 0
    assert summary["visits"] > 4 * 25
    for name in ("config.yaml", "visits.csv", "timeseries.csv", "info.csv", "idleness.csv"):
        assert (out / name).is_file(), name
    assert "(finished)" in proc.stdout


def test_bag_is_closed_and_analyze_matches_the_monitor(tpuaf_run):
    out, _ = tpuaf_run
    bag = out / "run.bag"
    assert bag.is_file() and not (out / "run.bag.active").exists()
    from tpuaf.measure.bag import inspect

    info = inspect(bag)
    assert info.robots == 4 and info.monitor_finished
    assert "/robot_0/base_pose_ground_truth" in info.topics
    assert not any("scan" in t for t in info.topics)
    proc = subprocess.run([*TPUAF, "analyze", str(bag)], capture_output=True, text=True,
                          timeout=300, cwd=REPO)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    rows = json.loads((out / "analysis" / "comparison.json").read_text())
    assert all(r["agrees"] for r in rows), rows
    assert (out / "analysis" / "summary.json").is_file()


def test_batch_and_fleet_idleness_within_factor(tpuaf_run):
    from tpuaf.runtimes.config import RunConfig
    from tpuaf.runtimes.graph import GraphRun

    out, _ = tpuaf_run
    fleet = json.loads((out / "summary.json").read_text())["idleness_avg_s"]
    batch = GraphRun(RunConfig(map="grid", strategy="tpuaf", robots=4, duration_s=600.0,
                               seed=1)).run()["idleness_avg_s"]
    factor = fleet / batch
    print(f"I_avg fleet {fleet:.2f} s, batch {batch:.2f} s, factor {factor:.3f}")
    assert 1 / 1.3 <= factor <= 1.3


@pytest.mark.parametrize("strategy", ["gbs", "dtap"])
def test_other_strategies_complete_a_short_run(tmp_path, strategy):
    out = tmp_path / strategy
    proc = run_fleet(out, strategy=strategy, duration=120.0)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["complete"] is True and summary["visits"] > 10


def test_map_params_reach_the_fleets_nodes(tmp_path):
    """`tpuaf fleet --map-param` -> fleet.launch map_params -> every node's ~map_params: the
    monitor measures with the overridden d_if and r, and config.yaml says where they came from;
    `tpuaf analyze` on the bag uses them too."""
    out = tmp_path / "params"
    proc = run_fleet(out, strategy="gbs", robots=2, duration=60.0,
                     extra=("--map-param", "interference_distance=0.75", "--map-param",
                            "sensing_radius=2.5"))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["interference_distance_m"] == 0.75  # grid's own: 2 m
    config = yaml.safe_load((out / "config.yaml").read_text())
    assert config["map_params"] == {"interference_distance": 0.75, "sensing_radius": 2.5}
    assert config["map_setting_sources"]["sensing_radius"] == "--map-param"
    analysis = run_cli([*TPUAF, "analyze", str(out / "run.bag"), "--out", str(out / "a")],
                       timeout=300, cwd=REPO)
    assert analysis.returncode == 0, analysis.stdout + analysis.stderr
    again = json.loads((out / "a" / "summary.json").read_text())
    assert again["interference_distance_m"] == 0.75


def _descendants(pid: int) -> list[int]:
    out = subprocess.run(["ps", "-eo", "pid=,ppid="], capture_output=True, text=True).stdout
    children: dict[int, list[int]] = {}
    for line in out.splitlines():
        p, pp = (int(x) for x in line.split())
        children.setdefault(pp, []).append(p)
    found, todo = [], [pid]
    while todo:
        for c in children.get(todo.pop(), []):
            found.append(c)
            todo.append(c)
    return found


def _agent_pid(root: int, robot: str) -> int | None:
    for pid in _descendants(root):
        try:
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
            env = Path(f"/proc/{pid}/environ").read_bytes().split(b"\0")
        except OSError:
            continue
        if any(c.endswith(b"patrol_agent") for c in cmd) and \
                f"ROS_NAMESPACE=/{robot}".encode() in [e.rstrip(b"/") for e in env]:
            return pid
    return None


def test_killing_one_agent_leaves_the_others_patrolling(tmp_path):
    out = tmp_path / "kill"
    env = {k: v for k, v in os.environ.items() if not k.startswith("ROS_")}
    proc = subprocess.Popen(fleet_cmd(out, duration=180.0), stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, env=env, cwd=REPO,
                            start_new_session=True, preexec_fn=default_sigint)
    try:
        deadline = time.monotonic() + 120
        rows = 0
        while time.monotonic() < deadline and rows < 40:  # 40 s of run time
            ts = out / "timeseries.csv"
            rows = len(ts.read_text().splitlines()) - 1 if ts.is_file() else 0
            time.sleep(0.2)
        assert rows >= 40, "the run did not start"
        pid = _agent_pid(proc.pid, "robot_1")
        assert pid is not None, "robot_1's agent process not found"
        os.kill(pid, signal.SIGKILL)
        stdout, _ = proc.communicate(timeout=300)
    finally:
        stop_tree(proc)  # on failure: SIGTERM (tpuaf fleet stops its ROS processes), SIGKILL
    assert proc.returncode == 0, stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary["deaths"] == 1 and summary["dead_robots"] == [1]
    assert summary["complete"] is True
    import csv

    with open(out / "visits.csv") as f:
        visits = [(float(r["time_s"]), int(r["robot"])) for r in csv.DictReader(f)]
    end = max(t for t, _ in visits)
    late = {r for t, r in visits if t > end - 60}
    assert late == {0, 2, 3}, late  # the others kept patrolling, robot 1 no more


def test_injected_faults_death_stall_and_a_lossy_delayed_relay(tmp_path):
    """--fail kills robot 1's agent by PID, --stall stops robot 2 in the simulator, and the team
    messages pass a relay with 1 s delay and 50 % loss; the lock-step run still finishes."""
    out = tmp_path / "faults"
    proc = run_fleet(out, duration=150.0, extra=("--fail", "1@40", "--stall", "2@30",
                                                 "--delay", "1", "--loss", "0.5"))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["complete"] is True and summary["stepping"] == "lock-step"
    assert summary["deaths"] == 1 and summary["dead_robots"] == [1]
    [killed] = summary["fleet_deaths_injected"]
    assert killed["robot"] == 1 and killed["pid"] > 0 and killed["killed_at_s"] >= 40
    assert summary["unresponsive_events"] == 0  # the killed agent is a death, not a slow agent
    # the recovery's floor at detection, from the agents' teammate timeout (fleet.launch: 10 s)
    [recovery] = summary["recovery"]
    assert recovery["detection_floor_worst_idleness_after_s"] > 0
    assert yaml.safe_load((out / "config.yaml").read_text())["teammate_timeout_s"] == 10.0
    events = summary["simulator_events"]
    assert [e["robot"] for e in events if e["event"] == "stall"] == [2]
    assert 1 in [e["robot"] for e in events if e["event"] in ("gone", "unresponsive")]
    import csv

    with open(out / "visits.csv") as f:
        visits = [(float(r["time_s"]), int(r["robot"])) for r in csv.DictReader(f)]
    end = max(t for t, _ in visits)
    late = {r for t, r in visits if t > end - 60}
    assert late == {0, 3}, late  # robot 1 dead, robot 2 stalled; the others patrol on
    logs = "".join(p.read_text(errors="replace")
                   for p in (out / "ros_home" / "log").rglob("team_relay*.log"))
    import re

    sent, delivered, lost = (int(x) for x in
                             re.findall(r"sent (\d+), delivered (\d+), lost (\d+)", logs)[-1])
    assert sent > 20 and delivered + lost > 0
    assert lost / (delivered + lost) == pytest.approx(0.5, abs=0.15)


if __name__ == "__main__":
    sys.exit(pytest.main([__file__, "-v", "-s"]))
