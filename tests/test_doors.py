"""Doors narrower than the controller's wide clearance (a 0.6 m door; a Burger's disc with the
plan margin is 0.81 m wide). The controller once chose a heading with the wide clearance into
the open room beside the door over the straight one through it, with only the safety margin,
and turned to and fro in front of the door for good (a generated office map, 4 Burgers: one
never got out of its room, and another waited for good for the lane through its door). A heading with the safety margin only now costs
NARROW_COST_RAD more, so the robot drives through."""

from __future__ import annotations

import math

import numpy as np
import pytest
from tpuaf.maps.model import MapSettings
from tpuaf.navigation import LocalController, Status
from tpuaf.robot.model import choose_robot
from tpuaf.runtimes.physics import controller_config

from .map_folders import write_map_folder

RES = 0.05  # [m per cell]
DOOR_M = 0.6  # [m] the door's width


def burger_controller() -> LocalController:
    return LocalController(controller_config(0, choose_robot("burger", MapSettings())))


def test_the_controller_drives_straight_through_a_door_from_an_open_room():
    c = burger_controller()
    c.set_target((2.0, 0.0), 0.15, 0.0)
    # A wall 1 m ahead across the room, with a door 0.6 m wide straight ahead.
    wall = np.array([[1.0, y] for y in np.arange(-2.0, 2.01, 0.025) if abs(y) > DOOR_M / 2])
    cmd = c.step(0.0, (0.0, 0.0, 0.0), wall)
    assert cmd.status == Status.DRIVING
    assert cmd.v > 0.5 * c.config.max_linear_speed and abs(cmd.w) < 0.1
    # Where the door is off to one side, the robot still turns toward it, not away.
    c.set_target((2.0, 1.0), 0.15, 0.0)
    wall = np.array([[1.0, y] for y in np.arange(-2.0, 3.01, 0.025) if abs(y - 0.5) > DOOR_M / 2])
    cmd = c.step(0.1, (0.0, 0.0, 0.0), wall)
    assert cmd.w > 0.0


def two_rooms(folder):
    """Two rooms 3 x 3 m side by side, joined by a door DOOR_M wide in the wall between them;
    a vertex in each room, off the door's axis (the robot meets the wall at an angle)."""
    w, h = round(6.3 / RES), round(3.2 / RES)
    occ = np.zeros((h, w), dtype=bool)  # row 0 at the bottom
    occ[:4, :] = occ[-4:, :] = occ[:, :4] = occ[:, -4:] = True
    wall = slice(round(3.1 / RES) - 2, round(3.1 / RES) + 2)
    door = (round((1.6 - DOOR_M / 2) / RES), round((1.6 + DOOR_M / 2) / RES))
    occ[:door[0], wall] = True
    occ[door[1]:, wall] = True
    return write_map_folder(folder, occ, [(1.2, 0.9), (5.0, 2.4)], [(0, 1)], res=RES,
                            settings={"nominal_speed": 0.22, "goal_tolerance": 0.15,
                                      "robot_radius": 0.105}, name="two_rooms")


def test_a_burger_patrols_two_rooms_through_a_narrow_door(tmp_path):
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    folder = two_rooms(tmp_path / "two_rooms")
    summary = PhysicsRun(PhysicsConfig(map=str(folder), strategy="tpuaf", robots=1,
                                       duration_s=240.0, seed=1, robot="burger")).run()
    # A leg is about 4.3 m: about 19 s at 0.22 m/s with the turns, so 12 visits in 240 s
    # (measured: 13, I_max 38.7 s, no recovery; before, I_max 71.6 s).
    assert summary["goal_failures"] == 0 and summary["recoveries"] == 0
    assert summary["visits"] >= 11
    assert min(summary["visits_per_vertex"].values()) >= 5
    assert math.isfinite(summary["idleness_max_s"]) and summary["idleness_max_s"] < 50.0


# An office 14 x 9 m (free rectangles (x0, y0, x1, y1) [m]): a corridor 1.4 m wide, three
# rooms below it and two above, doors 0.55-0.7 m wide, a pillar in one room.
OFFICE = [(0.5, 4.0, 13.5, 5.4),
          (0.5, 0.5, 4.0, 3.5), (1.8, 3.5, 2.5, 4.0),
          (5.0, 0.5, 9.0, 3.5), (6.5, 3.5, 7.1, 4.0),
          (10.0, 0.5, 13.5, 3.5), (11.0, 3.5, 12.2, 4.0),
          (0.5, 5.9, 6.5, 8.5), (3.0, 5.4, 3.8, 5.9),
          (7.5, 5.9, 10.0, 8.5), (10.6, 5.9, 13.5, 8.5), (10.0, 5.9, 10.6, 7.0),
          (10.0, 7.6, 10.6, 8.5), (8.0, 5.4, 8.55, 5.9)]


@pytest.fixture(scope="module")
def office(tmp_path_factory):
    """The office's map folder as `tpuaf graph` writes it for a Burger."""
    from tpuaf.cli import main

    from .map_folders import write_map_server

    tmp = tmp_path_factory.mktemp("office")
    source = write_map_server(tmp / "src", OFFICE, (14.0, 9.0), "office", origin=(-1.0, -2.0))
    folder = tmp / "office"
    assert main(["graph", str(source), "--robot", "burger", "--out", str(folder)]) == 0
    return folder


def test_the_generated_office_has_no_vertex_in_a_doorway(office):
    """`tpuaf graph` counts half the cells a candidate target in a doorway sees
    (maps/generate.py NARROW_GAIN_SHARE): no vertex of the office is where two Burgers cannot
    stand side by side, so the only lanes are edges through a door, not the corridor's edges
    (before: a vertex in the doorway of the middle room, and every edge from it, along the
    corridor too, a lane)."""
    from tpuaf.maps import load_map
    from tpuaf.navigation.lanes import find_lanes
    from tpuaf.navigation.planner import PathPlanner

    pm = load_map(str(office))
    lanes = find_lanes(PathPlanner(pm, choose_robot("burger", pm.settings).radius_m), pm)
    assert not lanes.narrow_vertices
    corridor_y = (2.0, 3.4)  # [m] (OFFICE, map frame)
    for lane in lanes.lanes:
        for u, v in lane.edges:  # one end in a room: the edge passes a door
            ys = (pm.positions[u][1], pm.positions[v][1])
            assert not all(corridor_y[0] <= y <= corridor_y[1] for y in ys), (u, v)


def test_four_burgers_patrol_a_generated_office_through_its_doors(office):
    """As a user would: an office's occupancy map, `tpuaf graph` for a Burger, then
    tpuaf_plus with 4 Burgers in physics (lanes auto), 400 s. Every vertex keeps being visited
    (measured: at least 7 visits each, worst idleness 68.2 s, no failed goal; before the
    controller's door rule 4, 198.0 s and 3 failed goals)."""
    from tpuaf.maps import load_map
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    pm = load_map(str(office))
    summary = PhysicsRun(PhysicsConfig(map="office", strategy="tpuaf_plus", robots=4,
                                       duration_s=400.0, seed=1, robot="burger"), pm).run()
    assert min(summary["visits_per_vertex"].values()) >= 6, summary["visits_per_vertex"]
    assert summary["worst_idleness_s"] < 100.0 and summary["goal_failures"] == 0
