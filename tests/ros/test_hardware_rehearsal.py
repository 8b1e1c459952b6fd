"""Hardware rehearsal on the wall clock (tests/ros/hardware.py): two Burgers on lab and on grid
(in parallel) keep visiting for 120 s of wall time, recorded in a plain bag."""

from __future__ import annotations

import contextlib
import re
import time

import pytest

from .conftest import ros_master
from .hardware import (
    events,
    max_gap,
    reached,
    start_robot,
    start_world,
    wait_started,
)

pytestmark = [pytest.mark.ros, pytest.mark.slow]

# --- 120 s rehearsal, lab and grid in parallel ----------------------------------------------


RUN_S = 120.0


def test_two_burgers_keep_visiting_on_the_wall_clock(tmp_path):
    maps = ("lab", "grid")
    with contextlib.ExitStack() as stack:
        envs = {m: stack.enter_context(ros_master(tmp_path / m)) for m in maps}
        for m, ros in envs.items():
            start_world(ros, m, 2)
            # What a user records for `tpuaf analyze` (docs/HARDWARE.md): no ground truth.
            ros.start(["rosbag", "record", "-O", str(ros.home / "run.bag"), "/tf", "/tf_static",
                       "/team/visits", "/team/intentions", "/team/idleness",
                       "/team/task_requests", "/team/task_bids", "/fleet/agent_events",
                       "/fleet/start", "/tb3_0/odom", "/tb3_1/odom"], name="rosbag")
            for i in range(2):
                start_robot(ros, m, 2, i)
        t0 = {m: wait_started(ros, 2) for m, ros in envs.items()}
        time.sleep(RUN_S - (time.time() - max(t0.values())))
        rows = {m: events(ros) for m, ros in envs.items()}
        logs = {m: [ros.output(f"tb3_{i}") for i in range(2)] for m, ros in envs.items()}
        topics = {m: ros.run_python(
            "import rospy, rosgraph; m = rosgraph.Master('/t');"
            "print(sorted(t for t, _ in m.getPublishedTopics('')))").stdout for m, ros in envs.items()}
        for ros in envs.values():
            ros.stop_all()
    for m in maps:
        start = t0[m]
        for i in range(2):
            visits = reached(rows[m], i, start)
            beats = [t for t, r, e, _ in rows[m] if r == i and t >= start]
            gap = max_gap([start] + [t for t, _ in visits] + [start + RUN_S])
            print(f"rehearsal {m} tb3_{i}: {len(visits)} visits in {RUN_S:g} s, longest gap "
                  f"{gap:.1f} s, heartbeat gap {max_gap(beats):.1f} s")
            assert len(visits) >= (6 if m == "lab" else 3), (m, i, visits, logs[m][i][-3000:])
            # Still visiting in the last third of the run; heartbeats never stopped.
            assert visits[-1][0] > start + 0.6 * RUN_S, (m, i, visits)
            assert max_gap(beats) < 3.0, (m, i, max_gap(beats))
            assert beats[-1] > start + RUN_S - 5.0
            log = logs[m][i]
            assert "localisation tf map" in log and "wall clock" in log
            assert "robot stopped" not in log, log[-3000:]
        # One run start for the team, announced once on /fleet/start (latched).
        epochs = {re.findall(r"run start (?:\(epoch\) )?(\d+\.\d+) s", log)[-1]
                  for log in logs[m]}
        assert len(epochs) == 1, epochs
        assert "/clock" not in topics[m]
        bag = tmp_path / m / "run.bag"
        assert bag.is_file() and bag.stat().st_size > 10_000
