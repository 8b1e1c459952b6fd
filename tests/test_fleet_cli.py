"""`tpuaf fleet` without ROS: options are checked before any ROS process starts, the robot model
is honest, --record builds the bag's topic regex, and the relay model is the batch TeamBus."""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import pytest
from tpuaf.cli.fleet import RECORD_GROUPS, record_regex
from tpuaf.maps import load_map
from tpuaf.robot.model import RobotChoiceError, choose_robot
from tpuaf.team.relay import RelayModel

REPO = Path(__file__).resolve().parents[1]
TPUAF = str(REPO / ".venv" / "bin" / "tpuaf")


@pytest.mark.parametrize("args, message", [
    (["--rtf", "-1"], "--rtf: expected a real-time factor >= 0"),
    (["--rtf", "nan"], "--rtf: expected a real-time factor >= 0"),
    (["--robot", "tank"], "--robot: unknown robot preset 'tank'"),
    (["--fail", "9@10"], "--fail 9@10: robot index not in 0..3"),
    (["--fail", "1@x"], "--fail: expected ROBOT@TIME"),
    (["--stall", "1@999"], "time is not within the run"),
    (["--loss", "1.5"], "--loss: expected a probability in [0, 1]"),
    (["--delay", "-2"], "--delay: expected a finite number >= 0"),
    (["--record", "scanz"], "--record: unknown group(s) scanz"),
    (["--record", "/robot_[0-9+/scan("], "--record: not a topic regex"),
])
def test_bad_fleet_options_are_one_line_before_ros(tmp_path, args, message):
    t0 = time.monotonic()
    proc = subprocess.run([TPUAF, "fleet", "--out", str(tmp_path / "out"), "--duration", "60",
                           *args], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert message in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "Traceback" not in proc.stderr
    assert not (tmp_path / "out" / "ros_home").exists()  # no ROS process was started
    assert time.monotonic() - t0 < 30


def test_robot_is_never_made_faster_than_its_preset():
    grid = load_map("grid").settings  # 1 m/s map
    burger = choose_robot("burger", grid)
    assert burger.speed_mps == 0.22 and "above the burger limit" in burger.note
    auto = choose_robot("auto", grid)  # the 0.33 m, 1 m/s patrolling_sim robot
    assert (auto.preset, auto.radius_m, auto.speed_mps, auto.note) == ("patrolling_sim", 0.165,
                                                                        1.0, "")
    lab = load_map("lab").settings
    assert choose_robot("auto", lab).preset == "burger"
    with pytest.raises(RobotChoiceError, match="unknown robot preset"):
        choose_robot("tank", grid)


def test_patrolling_sim_maps_use_the_presets_radius(shared_maps):
    s = load_map(shared_maps / "cumberland").settings
    assert s.robot_radius == 0.165  # the reference robot is a 0.33 m disc
    assert choose_robot("auto", s).preset == "patrolling_sim"


def test_record_groups_and_regex():
    base = record_regex("")
    assert "base_pose_ground_truth" in base and "scan" not in base
    scans = record_regex("scans,tf")
    assert scans.startswith(base) and RECORD_GROUPS["scans"].format(p="robot_") in scans
    assert "/tf_static" in scans
    assert record_regex("/robot_0/odom") == base + "|/robot_0/odom"
    assert all(RECORD_GROUPS[g].format(p="robot_") in record_regex("all") for g in RECORD_GROUPS)


def test_relay_model_loss_and_delay_follow_the_team_bus():
    model = RelayModel(4, delay_s=2.0, loss=0.0, seed=0)
    model.submit(1, "hello", now=10.0)
    assert model.due(11.9) == []
    assert sorted(r for r, _ in model.due(12.0)) == [0, 2, 3]  # everyone but the sender
    lossy = RelayModel(5, delay_s=0.0, loss=0.25, seed=3)
    for k in range(2000):
        lossy.submit(k % 5, k, now=float(k))
    delivered = len(lossy.due(1e9))
    assert lossy.stats.sent == 2000 and delivered + lossy.stats.lost == 2000 * 4
    assert lossy.stats.lost / 8000 == pytest.approx(0.25, abs=0.02)
    again = RelayModel(5, delay_s=0.0, loss=0.25, seed=3)
    for k in range(2000):
        again.submit(k % 5, k, now=float(k))
    assert len(again.due(1e9)) == delivered
    assert again.stats.lost == lossy.stats.lost  # seeded
    lossy.submit(9, "foreign", now=0.0)  # not a team member: ignored
    assert lossy.stats.sent == 2000
