"""Hardware rehearsal on a map whose edges cross walls (tests/ros/hardware.py): three Burgers on
patrolling_sim's `example` keep visiting for 150 s of wall time."""

from __future__ import annotations

import re
import time

import pytest

from .conftest import ros_master
from .hardware import (
    FAILED,
    events,
    max_gap,
    reached,
    start_robot,
    start_world,
    wait_started,
)

pytestmark = [pytest.mark.ros, pytest.mark.slow]

# --- rehearsal on a map whose edges cross walls (issue 18) -----------------------------------

WALLS_RUN_S = 150.0
QUIET_S = 60.0  # [s] no robot goes this long without a visit or a stuck report...
BURGER_MPS = 0.22  # ...unless one edge alone takes longer at a Burger's speed (example: 15.6 m)


def test_three_burgers_keep_visiting_where_edges_cross_walls(tmp_path, shared_maps):
    """docs/HARDWARE.md's rehearsal (robot.launch, tf localisation, wall clock, a plain bag) on
    patrolling_sim's `example`, 5 of whose 34 edges run straight through a wall: the built-in
    navigator plans round them. Every robot keeps visiting, and none goes QUIET_S without a
    visit or a stuck report (or 1.2 x its longest edge's driving time, where one edge takes
    longer than that)."""
    from tpuaf.maps import load_map
    from tpuaf.navigation.planner import PathPlanner

    patrol_map = str(shared_maps / "example")
    longest_m = max(c.planned_m for c in PathPlanner(load_map(patrol_map), 0.105).check_edges())
    quiet_s = max(QUIET_S, 1.2 * longest_m / BURGER_MPS)
    with ros_master(tmp_path / "walls") as ros:
        start_world(ros, patrol_map, 3)
        ros.start(["rosbag", "record", "-O", str(ros.home / "run.bag"), "/tf", "/tf_static",
                   "/team/visits", "/team/intentions", "/fleet/agent_events", "/fleet/start"],
                  name="rosbag")
        for i in range(3):
            start_robot(ros, patrol_map, 3, i)
        start = wait_started(ros, 3, timeout=90.0)
        time.sleep(max(0.0, WALLS_RUN_S - (time.time() - start)))
        rows = events(ros)
        logs = [ros.output(f"tb3_{i}") for i in range(3)]
        ros.stop_all()
    for i in range(3):
        visits = reached(rows, i, start)
        failed = [t for t, r, e, _ in rows if r == i and e == FAILED and t >= start]
        stuck = [start + float(m) for m in re.findall(r"stuck on the way to vertex \d+ at run "
                                                       r"time ([0-9.]+) s", logs[i])]
        news = sorted([start] + [t for t, _ in visits] + failed + stuck + [start + WALLS_RUN_S])
        print(f"walls rehearsal tb3_{i}: {len(visits)} visits, {len(failed)} failed goals, "
              f"{len(stuck)} stuck reports in {WALLS_RUN_S:g} s; longest quiet "
              f"{max_gap(news):.1f} s")
        assert len(visits) >= 2, (i, visits, logs[i][-3000:])
        assert visits[-1][0] > start + 0.5 * WALLS_RUN_S, (i, visits)
        assert max_gap(news) < quiet_s, (i, quiet_s, news, logs[i][-3000:])
        assert "localisation tf map" in logs[i] and "wall clock" in logs[i]
    assert (tmp_path / "walls" / "run.bag").is_file()
