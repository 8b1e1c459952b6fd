"""Fast robots meeting head-on where two can pass (issue 32/35: 1r5 and ctcv jammed at 1 m/s):
closed-loop on the C++ world with the navigator the physics runtime and the agent node use, its
5 Hz scans motion-compensated as there. Each robot steers away from the other from 2 s off at
its top speed, so they pass at speed instead of swerving late, 1 m apart, and meeting nose to
nose (where both turned in place round each other, for seconds in crowds)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import tpuaf_core
from tpuaf.maps import load_map
from tpuaf.navigation import (
    ControllerConfig,
    Event,
    GraphRoute,
    LocalController,
    Navigator,
    Scan,
    scan_points,
)
from tpuaf.navigation import navigator as navigator_module
from tpuaf.navigation.navigator import keep_right
from tpuaf.navigation.planner import PathPlanner
from tpuaf.navigation.scan import moved_points

from .map_folders import write_map_folder

RES = 0.05  # [m per cell]
RADIUS = 0.165  # [m] the patrolling_sim robot
SPEED = 1.0  # [m/s]
TURN = 1.57  # [rad/s]
DEG = math.radians(1.0)
LENGTH, WIDTH = 8.0, 1.75  # [m] a corridor as 1r5's: two such robots pass with room to spare
AXIS_Y = 0.975  # [m] the corridor's centre line (the middle of its middle row of cells)


def corridor(folder: Path) -> Path:
    """A straight corridor LENGTH x WIDTH; vertices 0 and 1 on its axis, 0.5 m from its ends."""
    w = round(LENGTH / RES) + 2
    h = round(WIDTH / RES) + 2
    occ = np.zeros((h, w), dtype=bool)  # row 0 at the bottom
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = True
    return write_map_folder(folder, occ, [(0.55, AXIS_Y), (LENGTH - 0.45, AXIS_Y)], [(0, 1)],
                            res=RES, settings={"nominal_speed": SPEED, "goal_tolerance": 0.15,
                                               "robot_radius": RADIUS}, name="corridor")


@pytest.fixture(scope="module")
def hall(tmp_path_factory):
    pm = load_map(str(corridor(tmp_path_factory.mktemp("corridor") / "corridor")))
    return pm, PathPlanner(pm, RADIUS)


def head_on(pm, planner):
    """Robot 0 at vertex 0 bound for vertex 1, robot 1 the other way, on the same line."""
    occ = pm.occupancy_grid()
    world = tpuaf_core.World(occ.occupied, occ.resolution, occ.origin, 0)
    spec = tpuaf_core.RobotSpec()
    spec.radius_m, spec.max_linear_speed, spec.max_angular_speed = RADIUS, SPEED, TURN
    spec.max_linear_accel = spec.max_angular_accel = math.inf  # as the preset
    pos = pm.positions
    world.add_robot((pos[0][0], AXIS_Y, 0.0), spec)
    world.add_robot((pos[1][0], AXIS_Y, math.pi), spec)
    navs = []
    for i in range(2):
        config = ControllerConfig(max_linear_speed=SPEED, max_angular_speed=TURN,
                                  robot_radius=RADIUS, retry_wait_s=0.5 + 0.5 * i)
        nav = Navigator(LocalController(config), goal_tolerance=0.15, planner=planner,
                        robot_index=i)
        nav.set_route(GraphRoute(pm.graph, pos, i, 1 - i), 0.0)
        navs.append(nav)
    return world, navs


def drive(world, navs, t_end: float):
    """10 Hz control, scans at 5 Hz (every other tick, moved to the pose of each tick, as the
    physics runtime), until both routes are done or t_end [s]: (arrivals {robot: t [s]},
    robot-seconds standing and turning in place)."""
    arrived, turning, t, tick = {}, 0.0, 0.0, 0
    scans: list = [None, None]
    while t < t_end and any(n.route is not None for n in navs):
        poses = world.poses()
        if tick % 2 == 0:
            scans = [(scan_points(Scan(world.scan(i), 0.0, DEG, 0.12, 3.5)), tuple(poses[i]))
                     for i in range(len(navs))]
        tick += 1
        for i, nav in enumerate(navs):
            if nav.route is None:
                world.set_command(i, 0.0, 0.0)
                continue
            points = moved_points(scans[i][0], scans[i][1], tuple(poses[i]))
            cmd, event, _ = nav.step(t, tuple(poses[i]), points)
            if event == Event.ARRIVED:
                arrived[i] = t
            turning += 0.1 * (cmd.v == 0.0 and abs(cmd.w) > 0.0)
            world.set_command(i, cmd.v, cmd.w)
        for _ in range(2):
            world.step(0.05)
        t = round(t + 0.1, 6)
    return arrived, turning


def test_two_fast_robots_meeting_head_on_pass_each_other_without_stopping(hall):
    """Two 1 m/s robots on the same line in a 1.75 m corridor, head-on: both keep right from
    2 m off and pass at speed, arriving when they would alone (7 m at 1 m/s: 7.4 s), without
    touching and without standing to turn round each other. Before, they swerved only 1 m
    apart, stood to turn round each other (0.2 robot-seconds) and arrived at 7.9 and 8.1 s."""
    world, navs = head_on(*hall)
    arrived, turning = drive(world, navs, 60.0)
    assert sorted(arrived) == [0, 1]
    assert max(arrived.values()) < 7.7, arrived
    assert turning == 0.0, turning  # robot-seconds turning in place
    assert sum(world.contact_counts()) == 0
    assert sum(n.give_ways for n in navs) == 0 and sum(n.controller.retries for n in navs) == 0


def test_the_robot_steers_away_from_another_in_its_way_only():
    """Another robot (a mover) in the way, nearer than the target and within 2 s at top speed,
    bends the way: to the right when it is on our left or dead ahead, to the left when on our
    right. A wall (the same points, not movers) or a robot beyond the target does not."""
    controller = LocalController(ControllerConfig(max_linear_speed=SPEED, robot_radius=RADIUS,
                                                  max_angular_speed=TURN))
    controller.set_target((5.0, 0.0), 0.15, 0.0)
    ahead = np.array([[1.5, 0.0], [1.5, 0.1], [1.5, -0.1]])  # another robot 1.5 m ahead
    free = controller.step(0.1, (0.0, 0.0, 0.0), None)
    assert free.w == 0.0
    controller.set_movers(0.2, ahead)
    right = controller.step(0.2, (0.0, 0.0, 0.0), ahead)
    assert right.v > 0.5 and right.w < 0.0  # on, turning right
    wall = controller.step(0.3, (0.0, 0.0, 0.0), ahead)  # the same points, not movers now
    assert wall.w >= 0.0 or abs(wall.w) < abs(right.w)
    on_right = ahead - np.array([0.0, 0.2])
    controller.set_movers(0.35, on_right)
    assert controller.step(0.35, (0.0, 0.0, 0.0), on_right).w > 0.0
    controller.set_target((1.0, 0.0), 0.15, 0.4)  # the target before the other robot
    controller.set_movers(0.4, ahead)
    assert controller.step(0.4, (0.0, 0.0, 0.0), ahead).w == 0.0


def test_legs_keep_right_of_the_planned_path_where_the_walls_leave_room(hall):
    """The corridor's edge path, kept right: its ends stay on the vertices, its inner points
    (one at least every metre) lie the offset to the right of the way in each direction, so
    two robots driving it in opposite directions are twice the offset apart; a corridor too
    narrow for the offset keeps the path where it was."""
    pm, planner = hall
    offset = 0.23  # [m] the navigator's: half the pass clearance of this robot
    room = RADIUS + ControllerConfig().plan_margin
    for u, v, side in ((0, 1, -1.0), (1, 0, 1.0)):  # east: right is -y; west: right is +y
        path = planner.edge_path(u, v)
        kept = keep_right(path, offset, planner, room)
        assert np.allclose(kept[0], path[0]) and np.allclose(kept[-1], path[-1])
        assert len(kept) >= math.ceil(np.hypot(*(path[-1] - path[0])) / 1.0) + 1
        inner = kept[1:-1]
        assert np.allclose(inner[:, 1], AXIS_Y + side * offset, atol=1e-6)
    narrow = keep_right(planner.edge_path(0, 1), offset, planner, 1.0)  # 1 m from walls
    assert np.allclose(narrow[:, 1], AXIS_Y, atol=1e-6)


def test_fast_robots_on_a_tree_keep_right_and_lose_less_time_to_each_other(shared_maps,
                                                                          monkeypatch):
    """1r5 (a 12-vertex tree of 1.4 m corridors), 8 robots at 1 m/s, tpuaf, 200 s, seed 1:
    keeping right of the planned paths, robots driving an edge in opposite directions meet
    side by side instead of nose to nose (where each chose its side from its own bearing, both
    often the same way, and they turned in place round each other). Against the same run
    without it: under 85 % of the robot-time turning in place and no real loss of visits (measured:
    266 against 355 robot-seconds, 333 against 329 visits; 345 against 316 visits before the
    controller drove straight through openings narrower than its wide clearance, which
    helped the run without keeping right most)."""
    from tpuaf.runtimes import agent
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    turning = [0.0]
    tick = agent.AgentRuntime.tick

    def counted(self, t, points, points_pose=None):
        v, w = tick(self, t, points, points_pose)
        turning[0] += 0.1 * (v == 0.0 and w != 0.0)  # [robot-s] one 10 Hz control tick
        return v, w

    monkeypatch.setattr(agent.AgentRuntime, "tick", counted)
    figures = {}
    for share in (0.0, navigator_module.KEEP_RIGHT_SHARE):
        monkeypatch.setattr(navigator_module, "KEEP_RIGHT_SHARE", share)
        turning[0] = 0.0
        summary = PhysicsRun(PhysicsConfig(map=str(shared_maps / "1r5"), strategy="tpuaf",
                                           robots=8, duration_s=200.0, seed=1)).run()
        figures[share] = (summary["visits"], turning[0])
    (visits_off, turning_off), (visits_on, turning_on) = figures.values()
    # no real loss of visits (TPUAF's choices shift with every timing change: 333 against
    # 335 since the turns at vertices entered the learned times)
    assert visits_on >= 0.98 * visits_off, figures
    assert turning_on < 0.85 * turning_off, figures
