"""Navigator (tpuaf.navigation) and the ROS-free agent runtime/monitor, closed-loop on the C++
world (tpuaf_core.World): no ROS needed."""

from __future__ import annotations

import math

import numpy as np
import pytest
import tpuaf_core
from tpuaf.maps import load_map, start_vertices
from tpuaf.measure.monitor import FleetMonitor
from tpuaf.navigation import (
    ControllerConfig,
    Event,
    GraphRoute,
    LocalController,
    Navigator,
    Scan,
    Status,
    scan_points,
)
from tpuaf.params import LIVENESS_DEFAULTS
from tpuaf.policies import REGISTRY
from tpuaf.runtimes.agent import AgentRuntime

DEG = math.radians(1.0)


@pytest.fixture(scope="module")
def grid():
    return load_map("grid")


def world_of(pm, poses, speed=1.0):
    occ = pm.occupancy_grid()
    w = tpuaf_core.World(occ.occupied, occ.resolution, occ.origin, 0)
    spec = tpuaf_core.RobotSpec()
    spec.max_linear_speed = speed
    for p in poses:
        w.add_robot(p, spec)
    return w


def points_of(world, i):
    return scan_points(Scan(world.scan(i), 0.0, DEG, 0.12, 3.5))


# --- GraphRoute ------------------------------------------------------------------------------

def test_route_follows_shortest_path(grid):
    g = grid.graph
    route = GraphRoute(g, grid.positions, 0, 24)
    assert route.waypoints == [int(v) for v in g.path(0, 24)[1:]]
    assert route.waypoints[-1] == 24 and route.goal == 24
    assert route.length() == pytest.approx(g.distance(0, 24))
    seen = []
    while not route.done:
        seen.append(route.next_waypoint)
        route.advance()
    assert seen == route.waypoints and route.next_waypoint is None
    with pytest.raises(IndexError):
        route.advance()


def test_route_to_itself_and_back_to_start(grid):
    assert GraphRoute(grid.graph, grid.positions, 3, 3).waypoints == [3]
    p = grid.positions[0]
    away = GraphRoute(grid.graph, grid.positions, 0, 2, from_position=(p[0] + 2.0, p[1]))
    assert away.waypoints[0] == 0  # drives back to its vertex first
    near = GraphRoute(grid.graph, grid.positions, 0, 2, from_position=(p[0] + 0.1, p[1]))
    assert near.waypoints[0] != 0
    with pytest.raises(IndexError):
        GraphRoute(grid.graph, grid.positions, 0, 99)


# --- LocalController geometry -----------------------------------------------------------------

def test_free_length_of_a_point_ahead():
    c = LocalController(ControllerConfig(robot_radius=0.1, safety_margin=0.0))
    pts = np.array([[1.0, 0.0]])
    # Straight at it: the disc touches it after 1.0 - 0.1 m.
    assert c.free_lengths(pts, np.array([0.0]))[0] == pytest.approx(0.9)
    # Sideways or away from it: not blocking (capped).
    assert c.free_lengths(pts, np.array([math.pi / 2, math.pi]))[0] == pytest.approx(c.cap)
    # Lateral offset 0.06 m: touches at 1 - sqrt(0.1^2 - 0.06^2) = 0.92 m.
    assert c.free_lengths(np.array([[1.0, 0.06]]), np.array([0.0]))[0] == pytest.approx(0.92)


def test_scan_points_drop_missing_returns():
    s = Scan(np.array([1.0, 0.0, np.inf, np.nan, 2.0, 5.0], dtype=np.float32), 0.0,
             math.pi / 2, 0.12, 3.5)
    pts = scan_points(s)
    # beams 0 (1 m at 0 rad) and 4 (2 m at 2 pi = 0 rad) only
    assert pts.shape == (2, 2)
    assert pts[0] == pytest.approx([1.0, 0.0]) and pts[1] == pytest.approx([2.0, 0.0], abs=1e-6)


def test_controller_goes_straight_and_stops_at_target():
    c = LocalController()
    c.set_target((5.0, 0.0), 0.4, 0.0)
    cmd = c.step(0.0, (0.0, 0.0, 0.0), None)
    assert cmd.status == Status.DRIVING and cmd.v == pytest.approx(1.0) and cmd.w == 0.0
    cmd = c.step(0.0, (0.0, 0.0, math.pi), None)  # facing away: turn in place
    assert cmd.v == 0.0 and abs(cmd.w) > 0
    assert c.step(0.1, (4.7, 0.0, 0.0), None).status == Status.REACHED


def test_controller_steers_around_an_obstacle_keeping_right():
    c = LocalController()
    c.set_target((5.0, 0.0), 0.4, 0.0)
    wall = np.array([[0.8, y] for y in np.linspace(-0.3, 0.3, 13)])  # small block ahead
    cmd = c.step(0.0, (0.0, 0.0, 0.0), wall)
    assert cmd.w < 0  # turns right (clockwise) around it


def test_controller_recovers_then_fails_when_blocked():
    cfg = ControllerConfig(stuck_timeout_s=2.0, backoff_s=1.0, retry_wait_s=0.5, max_retries=2)
    c = LocalController(cfg)
    c.set_target((5.0, 0.0), 0.4, 0.0)
    # A wall right in front in every direction ahead: no progress is possible.
    blocked = np.array([[0.2 * math.cos(a), 0.2 * math.sin(a)]
                        for a in np.linspace(-math.pi / 2, math.pi / 2, 40)])
    statuses = []
    t = 0.0
    while t < 30.0:
        statuses.append(c.step(t, (0.0, 0.0, 0.0), blocked).status)
        if statuses[-1] == Status.FAILED:
            break
        t += 0.1
    assert Status.RECOVERING in statuses
    assert statuses[-1] == Status.FAILED and c.retries == 2
    # Failed for good until a new goal.
    assert c.step(t + 1, (0.0, 0.0, 0.0), None).status == Status.FAILED
    c.set_target((5.0, 0.0), 0.4, t + 1)
    assert c.step(t + 1, (0.0, 0.0, 0.0), None).status == Status.DRIVING


def test_controller_rejects_bad_config():
    with pytest.raises(ValueError, match="max_linear_speed"):
        ControllerConfig(max_linear_speed=0.0)


# --- closed loop on the world ----------------------------------------------------------------

def drive(world, navs, t_end, dt=0.1):
    events = []
    t = 0.0
    while t < t_end and any(n.route is not None for n in navs):
        poses = world.poses()
        for i, n in enumerate(navs):
            cmd, ev, v = n.step(t, tuple(poses[i]), points_of(world, i))
            if ev != Event.NONE:
                events.append((round(t, 1), i, ev, v))
            world.set_command(i, cmd.v, cmd.w)
        world.step(dt)
        t += dt
    return events


def test_navigator_follows_route_to_goal(grid):
    p = grid.positions[0]
    w = world_of(grid, [(p[0], p[1], 0.0)])
    nav = Navigator(LocalController())
    route = GraphRoute(grid.graph, grid.positions, 0, 12)
    nav.set_route(route, 0.0)
    events = drive(w, [nav], 120.0)
    passed = [v for _, _, e, v in events if e == Event.WAYPOINT]
    assert passed == route.waypoints[:-1]
    assert events[-1][2] == Event.ARRIVED and events[-1][3] == 12
    assert np.hypot(*(w.poses()[0][:2] - grid.positions[12])) <= 0.4
    assert w.contact_counts() == [0]


def test_head_on_in_a_corridor_both_get_through(grid):
    """Two robots driving toward each other along one corridor pass each other."""
    a, b = grid.positions[0], grid.positions[4]
    w = world_of(grid, [(a[0], a[1], -math.pi / 2), (b[0], b[1], math.pi / 2)])
    navs = []
    for i, (s, g) in enumerate([(0, 4), (4, 0)]):
        nav = Navigator(LocalController(ControllerConfig(retry_wait_s=0.5 + i)))
        nav.set_route(GraphRoute(grid.graph, grid.positions, s, g), 0.0)
        navs.append(nav)
    events = drive(w, navs, 120.0)
    arrived = {(i, v) for _, i, e, v in events if e == Event.ARRIVED}
    assert arrived == {(0, 4), (1, 0)}
    # Meeting at a shared junction, they may brush (the simulator stops them) but never stick.


def closed_loop(pm, strategy, n, duration, seed=0, kill=None, park=None):
    """Agents + monitor on the world, in one process (the nodes without ROS)."""
    starts = start_vertices(pm, n)
    w = world_of(pm, [(pm.positions[s][0], pm.positions[s][1], 0.0) for s in starts])
    mon = FleetMonitor(pm, n, duration)
    outbox = []
    agents = []
    for i in range(n):
        agents.append(AgentRuntime(pm, REGISTRY.create(strategy), i, n, seed, outbox.append,
                                   lambda k, v, f, t, i=i: mon.on_event(i, k, v, t)))
    t = 0.0
    while not mon.finished:
        poses = w.poses()
        for i in range(n):
            mon.on_pose(i, t, poses[i][0], poses[i][1])
        for i, a in enumerate(agents):
            if kill is not None and i == kill[0] and t >= kill[1]:
                w.set_command(i, 0.0, 0.0)
                continue
            a.on_pose(t, *poses[i])
            v, om = a.tick(t, points_of(w, i))
            w.set_command(i, v, om)
            while outbox:
                msg = outbox.pop(0)
                for b in agents:
                    if b.robot != msg.robot:
                        b.on_message(msg)
        w.step(0.1)
        t = round(t + 0.1, 6)
    return mon, agents, w


def test_agents_and_monitor_patrol_every_vertex(grid):
    mon, agents, w = closed_loop(grid, "tpuaf", 3, 300.0)
    s = mon.summary()
    assert s["unvisited_vertices"] == 0
    assert s["visits"] >= 3 * 8
    # The monitor's visits (ground truth) agree with the agents' own arrivals.
    assert abs(s["visits"] - (3 + sum(a.visits for a in agents))) <= 3
    assert sum(w.contact_counts()) == 0


def test_monitor_records_a_dead_robot(grid):
    mon, agents, _ = closed_loop(grid, "tpuaf", 3, 120.0, kill=(1, 40.0))
    s = mon.summary()
    assert s["deaths"] == 1 and s["dead_robots"] == [1]
    t_death = mon.deaths[0][0]
    # last heartbeat in (39, 40] s, silent for > the death timeout (the teammate timeout)
    silent = LIVENESS_DEFAULTS.death_timeout_s
    assert 39.0 + silent <= t_death <= 41.5 + silent
    # The others kept visiting after the death.
    later = [r for t, r, _ in mon.recorder.visits if t > t_death + 10]
    assert set(later) == {0, 2}


def test_robot_blocked_by_a_parked_robot_in_a_corridor_keeps_patrolling(grid):
    """A robot stands still mid-corridor on the other's way: it gets past (or gives up and
    picks another goal) and keeps patrolling."""
    a, b = grid.positions[1], grid.positions[2]
    mid = (0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.0)  # corridor between vertices 1 and 2
    start = grid.positions[0]
    w = world_of(grid, [mid, (start[0], start[1], -math.pi / 2)])
    mon = FleetMonitor(grid, 2, 240.0)
    agent = AgentRuntime(grid, REGISTRY.create("cr"), 1, 2, 0, lambda m: None,
                         lambda k, v, f, t: mon.on_event(1, k, v, t))
    # Send it through the blocked corridor first: 0 -> 4 passes 1, 2, 3.
    agent.policy.decide = _first_then(agent.policy.decide, 4)
    t = 0.0
    while not mon.finished:
        poses = w.poses()
        mon.on_event(0, 4, -1, t)  # the parked robot is alive
        for i in range(2):
            mon.on_pose(i, t, poses[i][0], poses[i][1])
        agent.on_pose(t, *poses[1])
        v, om = agent.tick(t, points_of(w, 1))
        w.set_command(1, v, om)
        w.set_command(0, 0.0, 0.0)
        w.step(0.1)
        t = round(t + 0.1, 6)
    visits = [(t, v) for t, r, v in mon.recorder.visits if r == 1]
    assert 4 in [v for _, v in visits] or agent.failures >= 1
    assert len({v for _, v in visits}) >= 5  # and it kept patrolling afterwards
    assert w.contact_counts()[1] == 0


def _first_then(decide, first):
    state = {"first": True}

    def wrapped(ctx):
        if state["first"]:
            state["first"] = False
            return first
        return decide(ctx)

    return wrapped


def test_change_goal_redirects_a_driving_agent(grid):
    """DTAG's re-plan: a goal changed while driving takes effect at the next vertex passed, and
    the monitor counts the visit of the new goal (announced by a GOAL event), not the old one."""
    start = grid.positions[0]
    w = world_of(grid, [(start[0], start[1], 0.0)])
    mon = FleetMonitor(grid, 1, 60.0)
    agent = AgentRuntime(grid, REGISTRY.create("cr"), 0, 1, 0, lambda m: None,
                         lambda k, v, f, t: mon.on_event(0, k, v, t))
    agent.policy.decide = _first_then(agent.policy.decide, 4)  # 0 -> 4 along the first row
    t, redirected = 0.0, False
    while not mon.finished:
        pose = w.poses()[0]
        mon.on_pose(0, t, pose[0], pose[1])
        agent.on_pose(t, *pose)
        if not redirected and t >= 2.0:
            agent.change_goal(10)  # while driving 0 -> 1
            redirected = True
        v, om = agent.tick(t, points_of(w, 0))
        w.set_command(0, v, om)
        w.step(0.1)
        t = round(t + 0.1, 6)
    visited = [v for _, r, v in mon.recorder.visits if r == 0]
    assert visited[:2] == [0, 10]  # the start, then the new goal; 4 was never reached first
    with pytest.raises(IndexError, match="unknown vertex index 99"):
        agent.change_goal(99)


# --- TurtleBot3 Burgers on lab (issue 11: a Burger must not wedge for good) ------------------

STALL_PATH_M = 0.3  # [m] driven (path length) that ends a stall


def burgers_on_lab(duration_s: float, n: int = 2, seed: int = 0):
    """n Burger agents (TPUAF, built-in navigator) on lab in the simulator's own world (the
    tpuaf_stage world file: Burger disc, speeds and accelerations, LDS-01 at 5 Hz with noise and
    its mounting offset), poses and control at 10 Hz; each robot's arrival times [s]."""
    from tpuaf_stage.config import parse_world

    pm = load_map("lab")
    cfg = parse_world({"patrol_map": "lab", "seed": seed, "robot": {"preset": "burger"},
                       "laser": {"preset": "lds01"}, "robots": n})
    w = cfg.build()
    laser = cfg.laser
    outbox, arrivals = [], [[0.0] for _ in range(n)]
    # Stall: the longest time [s] a robot neither arrived anywhere nor drove STALL_PATH_M.
    stall = [0.0] * n
    anchor = [(0.0, 0.0)] * n  # (time, path length) since when it has been standing
    path = [0.0] * n
    last_xy = [None] * n
    agents = []
    for i in range(n):
        def event(kind, v, f, t, i=i):
            if kind == 2:  # REACHED
                arrivals[i].append(t)
                anchor[i] = (t, path[i])
        ctl = ControllerConfig(max_linear_speed=0.22, robot_radius=0.105,
                               retry_wait_s=0.5 + 0.5 * i)
        agents.append(AgentRuntime(pm, REGISTRY.create("tpuaf"), i, n, seed, outbox.append, event,
                                   ctl))
    t, k, points = 0.0, 0, [None] * n
    while t < duration_s:
        poses = w.poses()
        if k % 2 == 0:  # 5 Hz scans
            scans = w.scan_all()
            points = [scan_points(Scan(scans[i], laser.first_angle, laser.angle_increment,
                                       laser.range_min, laser.range_max)) for i in range(n)]
        for i, a in enumerate(agents):
            x, y = poses[i][0], poses[i][1]
            if last_xy[i] is not None:
                path[i] += math.hypot(x - last_xy[i][0], y - last_xy[i][1])
            last_xy[i] = (x, y)
            if path[i] - anchor[i][1] >= STALL_PATH_M:
                anchor[i] = (t, path[i])
            stall[i] = max(stall[i], t - anchor[i][0])
            a.on_pose(t, *poses[i])
            v, om = a.tick(t, points[i])
            w.set_command(i, v, om)
            while outbox:
                msg = outbox.pop(0)
                for b in agents:
                    if b.robot != msg.robot:
                        b.on_message(msg)
        for _ in range(10):
            w.step(0.01)
        t, k = round(t + 0.1, 6), k + 1
    for i in range(n):
        arrivals[i].append(t)
    return arrivals, stall, agents


def test_two_burgers_on_lab_never_stall_for_30_s():
    """15 simulated minutes: recoveries get every Burger unstuck (before the snug headings of
    the controller, both wedged for good within 90 s: 14 and 10 visits)."""
    arrivals, stall, agents = burgers_on_lab(900.0)
    for i, times in enumerate(arrivals):
        assert stall[i] < 30.0, (i, stall[i])
        assert float(np.diff(times).max()) < 60.0, (i, times)  # no goal takes a minute
        assert len(times) - 2 >= 120  # > 1 visit per 7.5 s
