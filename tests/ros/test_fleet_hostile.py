"""Hostile team traffic cannot silently corrupt the monitor (issue 33 item 6).

A short lock-step fleet (grid, 3 robots, 60 s at 2x real time) runs twice with the same seed:
clean, and with a rogue node that, once the run started, publishes as robot 1 at 50 msg/s for
15 s of wall time (agent events: GOALs of every vertex, REACHED, heartbeats; Visit team
messages) and then a rogue /fleet/start 50 s before the real one. The monitor refuses the
rogue's events (sender: not robot 1's node) and the start, counts them in summary.json, says
the traffic is suspect; the agents refuse the rogue's Visit messages and events too (the same
sender rule), and their counts reach the summary (`rejected_by_agents`); the figures equal the
clean run's within 2 % (no death; the lock-step run is reproducible); `tpuaf analyze` of the
bag counts the same refusals. About 2 min of wall time.
"""

from __future__ import annotations

import json
import shlex
import subprocess
import time
from pathlib import Path

import pytest

from .conftest import REPO, VENV_PYTHON, ros_master

pytestmark = [pytest.mark.ros, pytest.mark.slow]

TPUAF = str(REPO / ".venv" / "bin" / "tpuaf")
ROBOTS, DURATION, SEED = 3, 60.0, 5
FLOOD_HZ, FLOOD_S = 50.0, 15.0

ROGUE = """
import sys, time
import rospy
from tpuaf.maps import load_map
from tpuaf_ros.msg import AgentEvent, RunStart, Visit

rospy.init_node("rogue")
ids = [int(v) for v in load_map("grid").vertex_ids]
events = rospy.Publisher("/fleet/agent_events", AgentEvent, queue_size=100)
visits = rospy.Publisher("/team/visits", Visit, queue_size=100)
start = rospy.Publisher("/fleet/start", RunStart, queue_size=1, latch=True)
real = rospy.wait_for_message("/fleet/start", RunStart, timeout=120)
time.sleep(2.0)
rate, sent, k = float(sys.argv[1]), 0, 0
end = time.monotonic() + float(sys.argv[2])
while time.monotonic() < end and not rospy.is_shutdown():
    now = rospy.Time.now()
    v = ids[k % len(ids)]
    e = AgentEvent(robot="robot_1", robot_index=1, event=(1, 2, 4)[k % 3], vertex=v,
                   from_vertex=-1)
    e.header.stamp = now
    events.publish(e)
    m = Visit(robot="robot_1", robot_index=1, vertex=v, next_vertex=ids[(k + 1) % len(ids)])
    m.header.stamp = now
    visits.publish(m)
    sent += 1
    k += 1
    time.sleep(1.0 / rate)
fake = RunStart(announcer="/rogue", robots=3, team=["robot_0", "robot_1", "robot_2"])
t = real.header.stamp.to_sec()
fake.header.stamp = rospy.Time.from_sec(t - 50.0 if t > 60.0 else t + 100.0)
start.publish(fake)
time.sleep(3.0)
print(f"rogue sent {sent} events", flush=True)
"""


def fleet(tmp: Path, name: str, rogue: bool) -> tuple[dict, str]:
    """One fleet on a master of our own (roslaunch fleet.launch as `tpuaf fleet` prepares it);
    returns the monitor's summary.json and the rogue's output."""
    out = tmp / name
    prep = subprocess.run([TPUAF, "fleet", "--map", "grid", "--robots", str(ROBOTS),
                           "--duration", str(DURATION), "--seed", str(SEED), "--rtf", "2",
                           "--out", str(out), "--prepare-only"],
                          capture_output=True, text=True, timeout=120)
    assert prep.returncode == 0, prep.stderr
    cmd = shlex.split(prep.stdout.strip().splitlines()[-1])
    with ros_master(tmp / f"ros_{name}") as ros:
        ros.start(cmd, name="fleet")
        if rogue:
            script = ros.home / "rogue.py"
            script.write_text(ROGUE)
            ros.start([str(VENV_PYTHON), str(script), str(FLOOD_HZ), str(FLOOD_S)], name="rogue")
        deadline = time.monotonic() + 300
        summary = out / "summary.json"
        while time.monotonic() < deadline and not summary.is_file():
            time.sleep(1.0)
        assert summary.is_file(), ros.output("fleet")[-4000:]
        time.sleep(3.0)  # the bag closes
        said = ros.output("rogue") if rogue else ""
        ros.stop_all()
    return json.loads(summary.read_text()), said


def test_a_rogue_flood_as_robot_1_is_refused_counted_and_harmless(tmp_path):
    clean, _ = fleet(tmp_path, "clean", rogue=False)
    hostile, said = fleet(tmp_path, "hostile", rogue=True)
    assert "rogue sent" in said, said[-2000:]
    sent = int(said.split("rogue sent ")[1].split()[0])
    assert sent > 0.5 * FLOOD_HZ * FLOOD_S
    assert clean["rejected"]["total"] == 0 and clean["suspect_traffic"] is False
    refused = hostile["rejected"]["by_reason"]
    # every rogue event that reached the monitor (a queue may drop some) is refused
    assert 0.8 * sent <= refused["sender"] <= sent, refused
    assert refused.get("start") == 1, refused
    assert hostile["suspect_traffic"] is True
    assert hostile["deaths"] == clean["deaths"] == 0
    assert abs(hostile["visits"] - clean["visits"]) <= 0.02 * clean["visits"], (
        hostile["visits"], clean["visits"])
    # robots 0 and 2 refused the rogue's Visit messages and events as robot 1 (their counts
    # are in the summary); robot 1 ignores its own index
    agents = hostile["rejected_by_agents"]
    assert agents["by_reason"].get("sender", 0) >= sent, agents
    assert {row["robot"] for row in agents["by_robot"]} == {0, 2}, agents
    assert clean["rejected_by_agents"]["total"] == 0
    # the bag's analysis refuses the same events (the caller ids are in the bag)
    out = tmp_path / "analysis"
    proc = subprocess.run([TPUAF, "analyze", str(tmp_path / "hostile" / "run.bag"), "--out",
                           str(out)], capture_output=True, text=True, timeout=300)
    assert "SUSPECT TRAFFIC" in proc.stdout, proc.stdout + proc.stderr
    bag = json.loads((out / "summary.json").read_text())
    # (a rogue started before the launch set /use_sim_time stamps on the wall clock: in the
    # bag, off its clock)
    by_reason = bag["rejected"]["by_reason"]
    assert by_reason.get("sender", 0) + by_reason.get("clock", 0) >= refused["sender"], by_reason
    assert bag["deaths"] == 0
