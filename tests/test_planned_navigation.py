"""Navigation on planned paths: the planner against hand-made maps with walls and doors (lengths
and clearance checked by hand), the navigator following a path's corners, the physics runtime
through a door, start poses of more robots than vertices, the agent runtime's events of one
tick, a reference map against the graph runtime on planned lengths, and `tpuaf maps`' edge
check."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
import tpuaf_core
from tpuaf.errors import MapError
from tpuaf.maps import START_CLEARANCE_M, START_SEARCH_M, load_map, start_poses, start_vertices
from tpuaf.navigation import ControllerConfig, Event, GraphRoute, LocalController, Navigator
from tpuaf.navigation.planner import PathPlanner, PlannerConfig, with_planned_lengths
from tpuaf.policies import REGISTRY
from tpuaf.robot.machine import STAY_S
from tpuaf.robot.model import choose_robot
from tpuaf.runtimes.agent import AgentRuntime
from tpuaf.runtimes.config import PhysicsConfig, RunConfig
from tpuaf.runtimes.graph import GraphRun
from tpuaf.runtimes.physics import PhysicsRun
from tpuaf.topics import DWELL

from .conftest import REPO, run_cli
from .map_folders import write_map_folder

TPUAF = str(REPO / ".venv" / "bin" / "tpuaf")
RES = 0.05  # [m per cell] of the hand-made maps
RADIUS = 0.165  # [m] robot radius of the hand-made maps: the physics runtime's robot there
WALL_COL = 60  # the wall is cell column 60: x in [3.0, 3.05) m
WALL_X0, WALL_X1 = WALL_COL * RES, (WALL_COL + 1) * RES


# ---------------------------------------------------------------------------------------------
# hand-made maps (our format: map.yaml, graph.yaml, occupancy.yaml + a PGM image)

def write_map(folder: Path, occupied: np.ndarray, vertices, edges, name: str = "walled",
              extra_settings: str = "") -> Path:
    """A map folder of ours; `occupied[row, col]` with row 0 at the bottom (y up)."""
    return write_map_folder(folder, occupied, vertices, edges, res=RES, name=name,
                            settings={"nominal_speed": 0.5, "goal_tolerance": 0.4,
                                      "robot_radius": RADIUS}, extra_settings=extra_settings)


def room(door: tuple[float, float] | None, width_m: float = 6.0, height_m: float = 5.0):
    """A walled room split by a wall at x in [3.0, 3.05) m with a door y in door [m] (None:
    closed). The outer wall is one cell thick."""
    g = np.zeros((round(height_m / RES), round(width_m / RES)), dtype=bool)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = True
    g[:, WALL_COL] = True
    if door is not None:
        g[round(door[0] / RES):round(door[1] / RES), WALL_COL] = False
    return g


WALL_END_Y = 2.5  # [m] top of the wall of the door room; the door is y in [2.5, 4.95) m
A, B = (1.5, 1.0), (4.55, 1.0)  # the two sides of the wall, mirror images about x = 3.025 m


@pytest.fixture
def door_map(tmp_path) -> Path:
    """Vertices 10 and 20 either side of the wall; their edge's straight line crosses it."""
    return write_map(tmp_path / "door", room((WALL_END_Y, 4.95)), [(10, *A), (20, *B)],
                     [(10, 20)])


@pytest.fixture
def narrow_door_map(tmp_path) -> Path:
    """A door 0.15 m wide (the robot is a 0.33 m disc): 10-20 has no path, 10-30 has one."""
    return write_map(tmp_path / "narrow", room((2.5, 2.65)),
                     [(10, *A), (20, *B), (30, 1.5, 4.0)], [(10, 20), (10, 30)], name="narrow")


def four_vertex_map(tmp_path) -> Path:
    return write_map(tmp_path / "four", room((WALL_END_Y, 4.95)),
                     [(10, 1.5, 1.0), (20, 4.55, 1.0), (30, 1.5, 4.0), (40, 4.55, 4.0)],
                     [(10, 20), (10, 30), (20, 40), (30, 40)], name="four")


def around_wall_end(rho: float) -> float:
    """Shortest length [m] from A to B keeping `rho` [m] from the wall: tangent from A to the
    circle of radius rho round the wall's top-left corner, the arc over it, the wall's
    thickness, and the mirror image down to B (A and B are mirror images about the wall)."""
    corner = (WALL_X0, WALL_END_Y)
    d = math.dist(A, corner)
    heading = math.atan2(corner[1] - A[1], corner[0] - A[0]) + math.asin(rho / d)  # tangent
    return 2.0 * (math.sqrt(d * d - rho * rho) + rho * heading) + (WALL_X1 - WALL_X0)


def wall_clearance(grid, points: np.ndarray) -> np.ndarray:
    """Exact distance [m] from each point to the nearest occupied cell (a square)."""
    rows, cols = np.nonzero(grid.occupied)
    cx = grid.origin[0] + (cols + 0.5) * grid.resolution
    cy = grid.origin[1] + (rows + 0.5) * grid.resolution
    half = 0.5 * grid.resolution
    dx = np.maximum(np.abs(points[:, :1] - cx[None, :]) - half, 0.0)
    dy = np.maximum(np.abs(points[:, 1:] - cy[None, :]) - half, 0.0)
    return np.hypot(dx, dy).min(axis=1)


def along(path: np.ndarray, step_m: float) -> np.ndarray:
    """Points every `step_m` [m] (at most) along a polyline, its corners included."""
    out = [path[:1]]
    for a, b in itertools.pairwise(path):
        k = max(1, math.ceil(np.linalg.norm(b - a) / step_m))
        out.append(a + (b - a) * (np.arange(1, k + 1) / k)[:, None])
    return np.concatenate(out)


# ---------------------------------------------------------------------------------------------
# 1. a wall between two vertices, a door at its end

def test_planned_length_is_the_detour_round_the_wall_and_keeps_clearance(door_map):
    pm = load_map(door_map)
    planner = PathPlanner(pm, RADIUS)
    rho = planner.inscribed_radius_m
    (check,) = planner.check_edges()
    straight = math.dist(A, B)
    assert check.declared_m == pytest.approx(straight)
    # By hand: no path keeping rho from the wall is shorter than round its end at clearance rho
    # (4.65 m); the path at rho + inflation_m costs nothing, and the planner minimises length
    # plus cost, so the planned path is no longer than that one (5.66 m), give or take a cell.
    shortest = around_wall_end(rho)
    free_of_cost = around_wall_end(rho + PlannerConfig().inflation_m)
    assert shortest - straight > 1.5  # the detour is real
    assert shortest - 1e-6 <= check.planned_m <= free_of_cost + 0.1
    path = planner.edge_path(check.u, check.v)
    np.testing.assert_allclose(path[0], A)
    np.testing.assert_allclose(path[-1], B)
    assert np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)) == pytest.approx(check.planned_m)
    points = along(path, 0.02)
    crossing = points[(points[:, 0] >= WALL_X0) & (points[:, 0] <= WALL_X1)]
    assert len(crossing) and crossing[:, 1].min() > WALL_END_Y + rho  # through the door
    assert wall_clearance(pm.occupancy_grid(), points).min() >= rho - 1e-9


@pytest.mark.slow
def test_physics_robots_cross_the_wall_only_on_planned_paths(door_map):
    def run(planner: bool):
        engine = PhysicsRun(PhysicsConfig(map=str(door_map), strategy="cr", robots=2,
                                          duration_s=200, planner=planner))
        return engine.run(), engine

    planned, engine = run(True)
    assert engine.robot.radius_m == RADIUS
    per_vertex = np.bincount([v for _, _, v in engine.recorder.visits], minlength=2)
    assert per_vertex.min() >= 5  # both sides of the wall, again and again
    assert planned["goal_failures"] == 0 and planned["collisions"] == 0
    straight, _ = run(False)  # the old navigator: straight at the wall
    assert straight["goal_failures"] > 0
    assert planned["visits"] > straight["visits"]


# ---------------------------------------------------------------------------------------------
# 2. a door narrower than the robot

def test_a_door_narrower_than_the_robot_blocks_its_edge(narrow_door_map):
    pm = load_map(narrow_door_map)
    checks = {(pm.vertex_ids[c.u], pm.vertex_ids[c.v]): c
              for c in PathPlanner(pm, RADIUS).check_edges()}
    assert math.isinf(checks[10, 20].planned_m)
    assert math.isfinite(checks[10, 30].planned_m)
    assert checks[10, 30].planned_m == pytest.approx(3.0, abs=0.05)  # a straight open edge
    with pytest.raises(MapError, match=r"edge\(s\) 10-20$") as err:
        with_planned_lengths(pm, RADIUS)
    assert "narrow" in str(err.value) and "10-30" not in str(err.value)


def test_run_on_planned_travel_refuses_a_blocked_edge(narrow_door_map):
    proc = run_cli([TPUAF, "run", "--map", str(narrow_door_map), "--travel", "planned",
                    "--duration", "10", "--quiet"], timeout=120)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "10-20" in lines[0] and "no collision-free path" in lines[0]
    assert "Traceback" not in proc.stderr
    # Declared travel does not look at the grid.
    proc = run_cli([TPUAF, "run", "--map", str(narrow_door_map), "--duration", "10",
                    "--quiet"], timeout=120)
    assert proc.returncode == 0, proc.stderr


# ---------------------------------------------------------------------------------------------
# 3. start poses of more robots than vertices

@pytest.mark.parametrize("n", [5, 8, 12])
def test_start_poses_never_overlap_and_lie_on_free_cells(tmp_path, n):
    pm = load_map(four_vertex_map(tmp_path))
    poses = np.asarray(start_poses(pm, n, RADIUS))
    assert poses.shape == (n, 3)
    gaps = [math.dist(p[:2], q[:2]) for p, q in itertools.combinations(poses, 2)]
    assert min(gaps) >= 2 * RADIUS + START_CLEARANCE_M - 1e-9
    grid = pm.occupancy_grid()
    assert all(grid.is_free(x, y) for x, y, _ in poses)
    assert wall_clearance(grid, poses[:, :2]).min() >= RADIUS + START_CLEARANCE_M - RES
    # The first four robots stand on their start vertices, the others beside theirs (shared).
    starts = start_vertices(pm, n)
    assert sorted(starts[:4]) == [0, 1, 2, 3] and starts[4:] == starts[:n - 4]
    np.testing.assert_allclose(poses[:4, :2], pm.positions[starts[:4]])
    off = np.hypot(*(poses[4:, :2] - pm.positions[starts[4:]]).T)
    assert off.min() >= 2 * RADIUS + START_CLEARANCE_M - 1e-9 and off.max() <= START_SEARCH_M


def test_physics_runtime_takes_eight_robots_on_four_vertices(tmp_path):
    engine = PhysicsRun(PhysicsConfig(map=str(four_vertex_map(tmp_path)), strategy="cr",
                                      robots=8, duration_s=20))
    start = np.asarray(engine.world.poses())[:, :2]
    assert min(math.dist(p, q) for p, q in itertools.combinations(start, 2)) >= 2 * RADIUS
    summary = engine.run()
    assert engine.now == 20.0 and summary["visits"] >= 8  # every robot's START at least


# ---------------------------------------------------------------------------------------------
# 4. the navigator on a path's corners (a stand-in planner: fixed polylines)

class FixedPaths:
    """Stands in for PathPlanner: fixed edge paths, one fixed plan from anywhere."""

    def __init__(self, edges: dict, plan: np.ndarray | None = None):
        self.edges = {k: np.asarray(v, dtype=float) for k, v in edges.items()}
        self._plan = plan
        self.plan_calls: list[tuple] = []

    def edge_path(self, u, v):
        return self.edges.get((u, v))

    def plan(self, start_xy, goal_xy, obstacles=None):
        self.plan_calls.append((tuple(start_xy), tuple(goal_xy)))
        return self._plan


LINE = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]])  # vertices 0 - 1 - 2


def walk(nav: Navigator, pose: tuple[float, float], steps: int = 20):
    """Step, putting the robot onto the controller's target after each step: (the targets the
    controller was given, in order, events)."""
    targets, events = [nav.controller.target], []
    for k in range(steps):
        if nav.route is None:
            break
        _, event, vertex = nav.step(0.1 * k, (*pose, 0.0), None)
        if event != Event.NONE:
            events.append((event, vertex))
        target = nav.controller.target
        if target is not None:
            if target != targets[-1]:
                targets.append(target)
            pose = target
    return targets, events


def line_route(start_xy=None) -> GraphRoute:
    graph = tpuaf_core.PatrolGraph(LINE, [(0, 1, math.nan), (1, 2, math.nan)], [0, 1, 2])
    return GraphRoute(graph, LINE, 0, 2, from_position=start_xy, snap_m=0.6)


def test_navigator_drives_the_corners_in_order_then_the_vertex():
    paths = {(0, 1): [(0, 0), (0.1, 0.1), (1, 1), (3, 1), (4, 0)],  # (0.1, 0.1): within 0.3 m
             (1, 2): [(4, 0), (5, 1), (5, 3), (4, 4)]}
    nav = Navigator(LocalController(), planner=FixedPaths(paths))
    nav.set_route(line_route(), 0.0)
    targets, events = walk(nav, (0.0, 0.0))
    # The vertex until the first step plans the leg; then its corners, vertex 1, the corners of
    # the next edge, vertex 2.
    assert targets == [(4, 0), (1, 1), (3, 1), (4, 0), (5, 1), (5, 3), (4, 4)]
    assert events == [(Event.WAYPOINT, 1), (Event.ARRIVED, 2)]
    assert nav.route is None and nav.unplanned_legs == 0 and nav.planner.plan_calls == []
    # The same events as on straight edges, without a planner.
    plain = Navigator(LocalController())
    plain.set_route(line_route(), 0.0)
    targets, straight_events = walk(plain, (0.0, 0.0))
    assert targets == [(4, 0), (4, 4)] and straight_events == events


def test_navigator_plans_from_the_pose_off_the_start_vertex():
    plan = np.array([(2.0, 2.0), (1.0, 2.0), (0.0, 0.0)])
    fake = FixedPaths({(0, 1): [(0, 0), (2, -1), (4, 0)]}, plan=plan)
    nav = Navigator(LocalController(), planner=fake)
    nav.set_route(line_route(start_xy=(2.0, 2.0)), 0.0)  # 2.8 m from vertex 0: back to it
    targets, events = walk(nav, (2.0, 2.0), steps=4)
    assert fake.plan_calls == [((2.0, 2.0), (0.0, 0.0))]
    assert targets == [(0, 0), (1, 2), (0, 0), (2, -1), (4, 0)]
    assert events == [(Event.WAYPOINT, 0)]
    # No path at all: the leg is driven straight.
    nav = Navigator(LocalController(), planner=FixedPaths({}))
    nav.set_route(line_route(), 0.0)
    targets, events = walk(nav, (0.0, 0.0))
    assert targets == [(4, 0), (4, 4)] and nav.unplanned_legs == 2
    assert events == [(Event.WAYPOINT, 1), (Event.ARRIVED, 2)]


# ---------------------------------------------------------------------------------------------
# 5. the agent runtime: a goal reached at once is an event too

@pytest.mark.parametrize("planned", [False, True])
def test_agent_never_stands_with_a_goal_and_no_route(tmp_path, planned):
    """Two vertices 0.3 m apart, goal tolerance 0.4 m, a robot that never moves: it neither
    stands with a goal and no route (a lost event) nor counts a visit (VisitRule: standing
    never visits); the goal 0.3 m away, beyond the visit radius, is driven to (a route)."""
    folder = tmp_path / "close"
    folder.mkdir()
    (folder / "map.yaml").write_text("name: close\ncorridor_width: 1.0\nsettings:\n"
                                     "  goal_tolerance: 0.4\n  interference_distance: 0.2\n")
    (folder / "graph.yaml").write_text("vertices:\n  - {id: 0, x: 1.0, y: 1.0}\n"
                                       "  - {id: 1, x: 1.3, y: 1.0}\nedges:\n  - [0, 1]\n")
    pm = load_map(folder)
    events: list[tuple] = []
    planner = PathPlanner(pm, pm.settings.robot_radius) if planned else None
    agent = AgentRuntime(pm, REGISTRY.create("cr"), 0, 1, 0, lambda m: None,
                         lambda k, v, f, t: events.append((k, v, t)), planner=planner)
    m = agent.machine
    x, y = pm.positions[0]
    visits = []
    for k in range(100):
        t = 0.1 * k
        agent.on_pose(t, x, y, 0.0)
        agent.tick(t, None)
        assert (agent.navigator.route is not None or m.goal is None or m.dwelling
                or agent.staying), k
        visits.append(m.visits)
    assert visits[-1] == 0  # standing still: no visit
    dwells = [e for e in events if e[0] == DWELL]
    assert len(dwells) == m.dwells <= 10.0 / STAY_S + 2
    assert all(b >= a for a, b in itertools.pairwise(visits))


# ---------------------------------------------------------------------------------------------
# 6. a reference map with edges through walls

@pytest.mark.slow
def test_cumberland_edges_drivable_and_physics_close_to_planned_graph_runs(shared_maps):
    folder = shared_maps / "cumberland"
    pm = load_map(folder)
    robot = choose_robot("auto", pm.settings)
    assert robot.radius_m == pm.settings.robot_radius
    checks = PathPlanner(pm, robot.radius_m).check_edges()
    assert len(checks) == pm.graph.num_edges
    assert all(math.isfinite(c.planned_m) for c in checks)
    # The map is a test of planning: some edges' straight lines cross walls.
    grid = pm.occupancy_grid()
    through_walls = [c for c in checks
                     if not all(grid.is_free(x, y) for x, y in
                                along(pm.positions[[c.u, c.v]], RES / 2))]
    assert len(through_walls) >= 3
    for c in through_walls:
        assert c.planned_m > math.dist(pm.positions[c.u], pm.positions[c.v]) + 0.1
    kwargs = dict(map=str(folder), strategy="tpuaf", robots=4, duration_s=300, seed=0)
    physics = PhysicsRun(PhysicsConfig(**kwargs)).run()
    graph = GraphRun(RunConfig(**kwargs, travel="planned")).run()
    assert physics["goal_failures"] == 0
    assert physics["visits"] >= 0.8 * graph["visits"], (physics["visits"], graph["visits"])


# ---------------------------------------------------------------------------------------------
# `tpuaf maps`: the edge check

def test_maps_reports_a_blocked_edge_and_exits_2(narrow_door_map, capsys):
    from tpuaf.cli import main

    assert main(["maps", "grid", str(narrow_door_map)]) == 2
    out, err = capsys.readouterr()
    assert "edges of grid for a robot of radius 0.105 m: 40 checked, 0 without" in out
    assert "edges of narrow for a robot of radius 0.165 m: 2 checked, 1 without" in out
    errors = [line for line in err.splitlines() if "error" in line]
    assert len(errors) == 1
    assert "(narrow): edge 10-20 (declared 3.05 m): no collision-free path" in errors[0]
    assert main(["maps", "--json", str(narrow_door_map)]) == 2
    import json

    (summary,) = json.loads(capsys.readouterr().out)
    check = summary["edge_check"]
    assert check["edges"] == 2 and [b["edge"] for b in check["blocked"]] == ["10-20"]
    assert check["max_ratio"] == pytest.approx(1.0, abs=0.02)  # 10-30 is straight and open


def test_maps_edge_check_of_the_builtin_maps_and_a_long_detour(door_map, capsys):
    from tpuaf.cli import main

    assert main(["maps", "grid", "lab"]) == 0
    out, err = capsys.readouterr()
    for line in ("edges of grid for a robot of radius 0.105 m: 40 checked, 0 without a "
                 "collision-free path, 0 planned > 1.5 x declared; planned / declared median "
                 "1.00, max 1.00",
                 "edges of lab for a robot of radius 0.105 m: 16 checked, 0 without"):
        assert line in out
    assert "error" not in err
    assert main(["maps", str(door_map)]) == 0  # long is a warning
    out, err = capsys.readouterr()
    assert "1 checked, 0 without a collision-free path, 1 planned > 1.5 x declared" in out
    (warning,) = [line for line in err.splitlines() if "planned" in line]
    assert "warning (walled): edge 10-20 planned" in warning and "declared 3.05 m" in warning


def test_maps_lists_ten_blocked_edges_then_counts(tmp_path, capsys):
    from tpuaf.cli import main

    left = [(10 + k, 1.5, 0.75 + 0.7 * k) for k in range(6)]
    right = [(20 + k, 4.55, 0.75 + 0.7 * k) for k in range(6)]
    edges = [(10 + k, 20 + k) for k in range(6)] + [(10 + k, 20 + (k + 1) % 6) for k in range(6)]
    folder = write_map(tmp_path / "closed", room(None), left + right, edges, name="closed")
    assert main(["maps", str(folder)]) == 2
    out, err = capsys.readouterr()
    assert "12 checked, 12 without a collision-free path" in out
    assert "median n/a, max n/a" in out
    errors = [line for line in err.splitlines() if "error" in line]
    assert len(errors) == 11
    assert errors[-1] == "tpuaf maps: error (closed): and 2 more edges without a collision-free " \
                         "path"
    named = {line.split("edge ")[1].split(" ")[0] for line in errors[:10]}
    assert len(named) == 10 and named <= {f"{u}-{v}" for u, v in edges}


def test_maps_blocked_edge_at_an_accepted_occupied_vertex_is_a_warning(tmp_path,
                                                                        narrow_door_map, capsys):
    from tpuaf.cli import main

    g = room((WALL_END_Y, 4.95))
    g[60:90, 80:110] = True  # a block x in [4.0, 5.5), y in [3.0, 4.5) m; vertex 50 0.75 m deep
    folder = write_map(tmp_path / "block", g, [(10, *A), (20, *B), (50, 4.75, 3.75)],
                       [(10, 20), (20, 50)], name="block")
    assert main(["maps", str(folder)]) == 2  # the vertex itself is refused (on load)
    capsys.readouterr()
    assert main(["maps", "--allow-occupied-vertices", str(folder)]) == 0
    out, err = capsys.readouterr()
    assert "2 checked, 1 without a collision-free path" in out
    declared = math.dist(B, (4.75, 3.75))
    assert (f"tpuaf maps: warning (block): edge 20-50 (declared {declared:.2f} m): no "
            "collision-free path for a robot of radius 0.165 m (vertex 50 on an occupied cell, "
            "accepted)") in err
    assert "error" not in err
    # A door too narrow is an error with the flag too.
    assert main(["maps", "--allow-occupied-vertices", str(narrow_door_map)]) == 2
    assert "error (narrow): edge 10-20" in capsys.readouterr().err


class CorridorMap:
    """Stands in for the costmap: walls along y = +-0.3 m (mapped), open space elsewhere."""

    @staticmethod
    def distance_to_obstacle(x, y):
        return max(0.0, 0.3 - abs(y))


class Recording(FixedPaths):
    costmap = CorridorMap()

    def distances_to_obstacle(self, points):
        return np.array([self.costmap.distance_to_obstacle(x, y) for x, y in points])

    def plan(self, start_xy, goal_xy, obstacles=None):
        self.plan_calls.append((tuple(start_xy), tuple(goal_xy),
                                None if obstacles is None else np.asarray(obstacles)))
        return np.array([start_xy, (1.0, 2.0), goal_xy])  # a detour by another corridor


def test_a_robot_held_still_by_another_replans_round_it_after_its_staggered_wait():
    """Head-on in a corridor (the other robot 0.35 m ahead, walls beside): the robot stops,
    and after yield_after_s (1 s + its staggered retry wait) replans with the unmapped points
    (the other robot), not the mapped walls, as obstacles, long before it would be stuck."""
    fake = Recording({(0, 1): [(0, 0), (4, 0)]})
    config = ControllerConfig(max_linear_speed=0.22, robot_radius=0.105, retry_wait_s=1.5)
    nav = Navigator(LocalController(config), planner=fake)
    assert nav.yield_after_s == pytest.approx(2.5)
    nav.set_route(line_route(), 0.0)
    ys = np.linspace(-0.28, 0.28, 15)
    other = np.column_stack((np.full_like(ys, 0.35), ys))  # the other robot's front
    walls = np.array([(x, s * 0.29) for x in np.linspace(-0.5, 1.0, 16) for s in (-1, 1)])
    points = np.vstack((other, walls))
    yielded_at = None
    for k in range(60):
        t = 0.1 * k
        cmd, event, _ = nav.step(t, (0.0, 0.0, 0.0), points)
        assert event == Event.NONE
        assert abs(cmd.v) < 0.03  # held still: it never drives into the other robot
        if nav.yields and yielded_at is None:
            yielded_at = t
    assert yielded_at is not None and 2.5 <= yielded_at <= 3.0, yielded_at
    assert nav.controller.retries == 0  # not stuck: it gave way before the stuck timeout
    obstacles = [c[2] for c in fake.plan_calls if c[2] is not None]
    assert obstacles, fake.plan_calls
    # The other robot's points, not the walls beside the robot.
    assert all(abs(y) < 0.29 for _, y, _ in obstacles[0])
    assert nav.corners[0] == pytest.approx((1.0, 2.0))  # on its detour
