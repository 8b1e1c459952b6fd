"""Corridors one robot wide that meet where a waiting robot would shut others in (a tight
junction, docs/LANES.md): the corridors are one lane, entered from the rooms at their ends, so
four Burgers patrol a T of corridors without meeting in it, and three in a star of dead ends,
where no robot can pass another, keep visiting every vertex."""

from __future__ import annotations

import numpy as np
from tpuaf.maps import load_map
from tpuaf.runtimes.config import PhysicsConfig
from tpuaf.runtimes.physics import PhysicsRun

from .test_lanes import star_map, tee_map


def test_four_burgers_patrol_a_t_of_corridors_one_at_a_time_without_contact(tmp_path):
    # Before, each corridor was a lane and the junction their waiting spot: a robot waiting on
    # it shut in the robot coming out (seed 2: 87 contacts, 2 failed goals, I_max 145.7 s).
    pm = load_map(str(tee_map(tmp_path / "tee")))
    run = PhysicsRun(PhysicsConfig(map=pm.name, strategy="tpuaf", robots=4, seed=2,
                                   duration_s=600.0, robot="burger"), patrol_map=pm)
    inside: list[int] = []

    def count(_t: float) -> None:
        poses = np.asarray(run.world.poses(), dtype=float)[:, :2]
        inside.append(int((run.lane_map.lane_at(poses) >= 0).sum()))

    summary = run.run(count)
    assert summary["collisions"] == 0 and summary["goal_failures"] == 0
    assert summary["unvisited_vertices"] == 0 and summary["idleness_max_s"] < 145.7
    assert max(inside) == 1  # one robot at a time in the corridors
    assert summary["lanes"] == 1 and summary["lane_waits"] > 0


def test_three_burgers_in_a_star_of_dead_ends_keep_visiting_every_vertex(tmp_path):
    # Before, the robot on the junction waited there for good for a corridor whose holder
    # could not come out past it: two vertices were never visited, 19 goals failed in 600 s.
    pm = load_map(str(star_map(tmp_path / "star")))
    run = PhysicsRun(PhysicsConfig(map=pm.name, strategy="tpuaf", robots=3, seed=1,
                                   duration_s=300.0, robot="burger"), patrol_map=pm)
    summary = run.run()
    assert summary["unvisited_vertices"] == 0
    assert min(summary["visits_per_vertex"].values()) >= 5
    assert summary["lanes"] == 1
