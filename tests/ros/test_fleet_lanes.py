"""The lane layer on ROS agents (issue 35, docs/LANES.md): `tpuaf fleet --lanes` on the lab,
whose aisles hold one Burger. The agents exchange LaneClaim messages on /team/lane_claims, the
monitor counts lane waits from their LANE_WAIT / LANE_ENTER events, and the bag holds both.
Two short runs (4 robots, 240 s of sim time at 10x) keep this module near 1.5 min of wall time."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest
import yaml

from ..conftest import run_cli

REPO = Path(__file__).resolve().parents[2]
TPUAF = [str(REPO / ".venv" / "bin" / "tpuaf")]
ROBOTS = 4
DURATION_S = 240.0

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def lanes_fleet(out: Path, mode: str) -> Path:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ROS_")}
    cmd = [*TPUAF, "fleet", "--map", "lab", "--robot", "burger", "--strategy", "tpuaf",
           "--robots", str(ROBOTS), "--duration", str(DURATION_S), "--seed", "1", "--rtf", "10",
           "--lanes", mode, "--out", str(out), "--quiet"]
    proc = run_cli(cmd, timeout=600, env=env, cwd=REPO)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out


@pytest.fixture(scope="module")
def locks_run(tmp_path_factory) -> Path:
    return lanes_fleet(tmp_path_factory.mktemp("lanes") / "locks", "locks")


@pytest.fixture(scope="module")
def one_way_run(tmp_path_factory) -> Path:
    return lanes_fleet(tmp_path_factory.mktemp("lanes") / "one_way", "one_way")


def lane_claims(bag: Path) -> list:
    import rosbag

    with rosbag.Bag(str(bag)) as b:
        return [msg for _, msg, _ in b.read_messages(topics=["/team/lane_claims"])]


def holders_over_time(claims: list) -> list[dict[int, list[int]]]:
    """After each claim in bag order: lane -> the robots whose latest claim holds it."""
    latest: dict[int, object] = {}
    out = []
    for claim in claims:
        latest[claim.robot_index] = claim
        holders: dict[int, list[int]] = {}
        for robot, c in latest.items():
            if c.held and c.lane >= 0:
                holders.setdefault(c.lane, []).append(robot)
        out.append(holders)
    return out


def test_locks_exclude_and_their_waits_are_counted(locks_run):
    summary = json.loads((locks_run / "summary.json").read_text())
    assert summary["complete"] is True
    claims = lane_claims(locks_run / "run.bag")
    assert {c.robot_index for c in claims} == set(range(ROBOTS))
    history = holders_over_time(claims)
    # the lock's guarantee: never two holders of one lane
    assert all(len(robots) == 1 for holders in history for robots in holders.values())
    # lanes were entered holding their lock, by more than one robot
    assert len({r for holders in history for rs in holders.values() for r in rs}) >= 2
    # four robots in one-robot aisles wait for lanes: counted per robot, and in seconds
    assert summary["lane_waits"] >= 1 and summary["lane_wait_s"] > 0
    rows = summary["robot_health"]
    assert sum(r["lane_waits"] for r in rows) == summary["lane_waits"]
    assert sum(r["lane_wait_s"] for r in rows) == pytest.approx(summary["lane_wait_s"], abs=0.01)
    config = yaml.safe_load((locks_run / "fleet_config.yaml").read_text())
    assert config["lanes"] == "locks"


def test_analyze_counts_the_same_lane_waits_from_the_bag(locks_run):
    proc = subprocess.run([*TPUAF, "analyze", str(locks_run / "run.bag")], capture_output=True,
                          text=True, timeout=300, cwd=REPO)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    live = json.loads((locks_run / "summary.json").read_text())
    bag = json.loads((locks_run / "analysis" / "summary.json").read_text())
    assert bag["lane_waits"] == live["lane_waits"]
    assert bag["lane_wait_s"] == pytest.approx(live["lane_wait_s"], abs=0.5)


def test_one_way_lanes_keep_every_robot_visiting_without_waits(one_way_run, locks_run):
    one_way = json.loads((one_way_run / "summary.json").read_text())
    locks = json.loads((locks_run / "summary.json").read_text())
    assert one_way["complete"] is True and one_way["unvisited_vertices"] == 0
    # the lab's lanes all lie on cycles: driven one way, nobody holds or waits for a lock
    assert one_way["lane_waits"] == 0
    claims = lane_claims(one_way_run / "run.bag")
    assert not any(c.lane >= 0 and not c.held for c in claims)  # nobody asked for a lock
    # a robot in a one-way lane announces it (held, no lock) with the edge it drives: where
    # a robot that dies lies (docs/LANES.md)
    inside = [c for c in claims if c.held and c.lane >= 0]
    assert inside and all(c.leg_from >= 0 and c.leg_to >= 0 for c in inside)
    # every robot keeps visiting (no robot blocked in an aisle), and the team does better than
    # with locks alone (physics: docs/LANES.md, benchmarks/results/lanes.md)
    for row in one_way["robot_health"]:
        assert row["since_last_visit_s"] < 60.0, row
    assert one_way["visits"] > locks["visits"]
    assert one_way["idleness_ins_mean_s"] < locks["idleness_ins_mean_s"]
