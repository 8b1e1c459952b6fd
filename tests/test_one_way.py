"""One-way lanes (navigation/one_way.py, docs/LANES.md): the traffic orientation of the lanes on
cycles, the directed patrol graph it gives, and robots that follow it."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import tpuaf_core
from tpuaf.maps import load_map
from tpuaf.maps.model import PatrolMap
from tpuaf.navigation.lanes import group_lanes
from tpuaf.navigation.one_way import bridges, lane_chain, orient_lanes

from tests.test_lanes import write_map


def hand_map(positions, edges, narrow=None) -> tuple[PatrolMap, object]:
    """A map of straight edges and its lane map: every edge (or those in `narrow`) one robot
    wide; every vertex of degree <= 2 narrow (a corridor stop or a dead end)."""
    n = len(positions)
    pm = PatrolMap("hand", list(range(n)), np.asarray(positions, dtype=float),
                   [(u, v, float("nan")) for u, v in edges], np.ones(n), np.ones(n))
    narrow = set(edges) if narrow is None else set(narrow)
    widths = {(min(u, v), max(u, v)): (0.1 if (u, v) in narrow else 1.0) for u, v in edges}
    degree = np.bincount(np.asarray(edges).ravel(), minlength=n)
    lanes = group_lanes(widths, frozenset(int(v) for v in range(n) if degree[v] <= 2), 0.3, n)
    return pm, lanes


def strongly_connected(pm: PatrolMap, arcs) -> bool:
    from dataclasses import replace

    try:
        graph = replace(pm, one_way=tuple(arcs)).graph
    except Exception:
        return False
    return bool(np.isfinite(np.asarray(graph.distances)).all())


# A ring 0-1-2-3-0 with a dead end 2-4: the ring is one lane from junction 2 back to it, the
# dead end another (a bridge).
RING_WITH_DEAD_END = ([(0, 0), (2, 0), (2, 2), (0, 2), (4, 2)],
                      [(0, 1), (1, 2), (2, 3), (3, 0), (2, 4)])
# A ladder: two rails 0-1-2 and 3-4-5 joined by rungs 0-3, 1-4, 2-5.
LADDER = ([(0, 0), (2, 0), (4, 0), (0, 2), (2, 2), (4, 2)],
          [(0, 1), (1, 2), (3, 4), (4, 5), (0, 3), (1, 4), (2, 5)])
# A T: arms 0-1, 1-2, 1-3 (a tree: every edge a bridge).
T_MAP = ([(0, 0), (2, 0), (4, 0), (2, 2)], [(0, 1), (1, 2), (1, 3)])


def test_bridges_of_a_ring_with_a_dead_end_and_of_a_tree():
    assert bridges(5, RING_WITH_DEAD_END[1]) == {(2, 4)}
    assert bridges(6, LADDER[1]) == set()
    assert bridges(4, T_MAP[1]) == {(0, 1), (1, 2), (1, 3)}


@pytest.mark.parametrize("case", [RING_WITH_DEAD_END, LADDER, T_MAP], ids=["ring", "ladder", "t"])
def test_orientation_is_strongly_connected_and_bridges_keep_their_locks(case):
    pm, lanes = hand_map(*case)
    orientation = orient_lanes(lanes, pm)
    assert strongly_connected(pm, orientation.arcs)
    cut = bridges(pm.num_vertices, [(min(u, v), max(u, v)) for u, v, _ in pm.edges])
    for lane in lanes.lanes:  # a lane is one-way exactly when no edge of it is a bridge
        on_bridge = any(e in cut for e in lane.edges)
        assert (lane.index in orientation.locked) == on_bridge
        assert (lane.index in orientation.chains) == (not on_bridge)
    arcs = orientation.arcs
    assert len({(min(u, v), max(u, v)) for u, v in arcs}) == len(arcs)  # one direction each
    if case is T_MAP:
        assert arcs == [] and orientation.total_m == orientation.two_way_total_m


def test_the_chosen_orientation_is_the_shortest_strongly_connected_one():
    pm, lanes = hand_map(*LADDER)
    orientation = orient_lanes(lanes, pm)
    chains = [lane_chain(lane) for lane in lanes.lanes]
    best = np.inf
    for flips in itertools.product((False, True), repeat=len(chains)):
        arcs = [a for c, f in zip(chains, flips, strict=True)
                for a in zip((c[::-1] if f else c)[:-1], (c[::-1] if f else c)[1:], strict=True)]
        if strongly_connected(pm, arcs):
            from dataclasses import replace

            best = min(best, float(np.asarray(replace(pm, one_way=tuple(arcs)).graph
                                              .distances).sum()))
    assert orientation.total_m == pytest.approx(best)
    assert orientation.total_m > orientation.two_way_total_m  # one-way costs some travel


def test_a_directed_graph_routes_along_its_arcs_and_refuses_a_dead_end_arc():
    positions = np.array([(0, 0), (1, 0), (1, 1), (0, 1)], dtype=float)
    ring = [(0, 1), (1, 2), (2, 3), (3, 0)]
    graph = tpuaf_core.PatrolGraph(positions, ring, [], ring)  # 0 -> 1 -> 2 -> 3 -> 0
    assert graph.path(1, 0) == [1, 2, 3, 0]
    assert graph.distance(1, 0) == pytest.approx(3.0)
    assert graph.distance(0, 1) == pytest.approx(1.0)
    assert graph.neighbours(0) == [1]
    assert graph.edge_length(1, 0) == pytest.approx(1.0)  # lengths stay undirected
    assert graph.one_way == ring
    with pytest.raises(ValueError, match="cannot drive back"):
        tpuaf_core.PatrolGraph(positions, ring[:3], [], [(0, 1)])  # a line: 1 cannot reach 0
    with pytest.raises(ValueError, match="not an edge"):
        tpuaf_core.PatrolGraph(positions, ring, [], [(0, 2)])


def test_lab_orientation_drives_every_lane_one_way_and_every_route_follows_it():
    from tpuaf.navigation.lanes import find_lanes
    from tpuaf.navigation.planner import PathPlanner

    pm = load_map("lab")
    lanes = find_lanes(PathPlanner(pm, 0.105), pm)
    orientation = orient_lanes(lanes, pm)
    assert len(orientation.chains) == 7 and not orientation.locked  # no bridge on the lab
    from dataclasses import replace

    directed = replace(pm, one_way=tuple(orientation.arcs)).graph
    allowed = set(orientation.arcs)
    for u, v in itertools.permutations(range(pm.num_vertices), 2):
        path = directed.path(u, v)
        assert all((a, b) in allowed for a, b in zip(path[:-1], path[1:], strict=True)), path


def ring_of_aisles(folder):
    """Two rooms joined by two aisles 0.45 m wide (a ring of two lanes): vertices 0 (left room),
    1 (upper aisle), 2 (right room), 3 (lower aisle), 4 and 5 (the rooms' far corners)."""
    return write_map(folder, (5.8, 2.6), [(0.05, 0.05, 1.65, 2.55), (1.6, 0.3, 4.2, 0.75),
                                          (1.6, 1.85, 4.2, 2.3), (4.15, 0.05, 5.75, 2.55)],
                     [(0.85, 1.3), (2.9, 2.075), (4.95, 1.3), (2.9, 0.525), (0.4, 2.2),
                      (5.4, 2.2)],
                     [(0, 1), (1, 2), (2, 3), (3, 0), (0, 4), (2, 5)])


def record_legs(run) -> list[tuple[int, int]]:
    """The (u, v) legs of every route the physics run's navigators are given, filled as it runs."""
    legs: list[tuple[int, int]] = []
    for agent in run.agents:
        nav = agent.navigator
        original = nav.set_route

        def recording(route, t, original=original):
            seq = [route.start, *route.waypoints]
            legs.extend(zip(seq[:-1], seq[1:], strict=True))
            return original(route, t)

        nav.set_route = recording
    return legs


def test_two_robots_on_a_ring_of_aisles_only_follow_each_other_in_physics(tmp_path):
    """One robot in each room: with one-way lanes every leg through an aisle follows the
    orientation (no head-on meeting), no lane is locked, nobody collides, both keep visiting."""
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    pm = load_map(str(ring_of_aisles(tmp_path / "ring")))
    run = PhysicsRun(PhysicsConfig(map=pm.name, strategy="cr", robots=2, seed=1,
                                   duration_s=200.0, robot="burger", lanes="one_way"),
                     patrol_map=pm)
    assert len(run.lane_map.lanes) == 2 and len(run.orientation.chains) == 2
    allowed = set(run.orientation.arcs)
    lane_edges = {e for lane in run.lane_map.lanes for e in lane.edges}
    legs = record_legs(run)
    counts: list[tuple[float, list[int]]] = []
    summary = run.run(lambda t: counts.append((t, [a.machine.visits for a in run.agents])))
    through = [(a, b) for a, b in legs if (min(a, b), max(a, b)) in lane_edges]
    assert through and all(leg in allowed for leg in through)
    assert summary["lane_waits"] == 0 and summary["collisions"] == 0
    for start, end in ((0.0, 100.0), (100.0, 200.0)):
        before = next(c for t, c in counts if t >= start)
        after = [c for t, c in counts if t <= end][-1]
        assert all(b > a for a, b in zip(before, after, strict=True)), (start, before, after)


def test_lane_modes_are_checked_and_auto_resolves_per_strategy():
    from tpuaf.runtimes.config import ConfigError, PhysicsConfig, RunConfig

    with pytest.raises(ConfigError, match="lanes must be one of auto, off, locks, one_way"):
        PhysicsConfig(map="lab", lanes="both").validate()
    with pytest.raises(ConfigError, match="lane locks need the physics runtime"):
        RunConfig(map="lab", lanes="locks").validate()
    PhysicsConfig(map="lab", lanes="locks").validate()
    for strategy, mode in (("tpuaf", "one_way"), ("tpuaf_plus", "one_way"), ("cgg", "one_way"),
                           ("msp", "off"), ("dtap", "off"), ("sebs", "off")):
        for config in (RunConfig(map="lab", strategy=strategy, robot="burger"),
                       PhysicsConfig(map="lab", strategy=strategy)):  # the default: auto
            config.validate()
            assert config.lanes == "auto" and config.lane_mode() == mode, strategy
            assert config.one_way is (mode == "one_way")
    # the graph runtime's point robot (no --robot) has no width: auto is off, one_way is not
    assert RunConfig(map="lab").lane_mode() == "off"
    assert RunConfig(map="lab", lanes="one_way").lane_mode() == "one_way"


def test_tpuaf_maps_prints_and_draws_the_orientation(tmp_path, capsys):
    import json

    from tpuaf.cli import main

    folder = ring_of_aisles(tmp_path / "ring")
    assert main(["maps", str(folder), "--lanes", "--json", "--picture", str(tmp_path)]) == 0
    (summary,) = json.loads(capsys.readouterr().out)
    arcs = summary["one_way"]["arcs"]
    assert len(arcs) == 4 and {tuple(sorted(a)) for a in arcs} == {(0, 1), (1, 2), (2, 3),
                                                                   (0, 3)}
    assert any("one-way" in line for line in summary["one_way"]["text"])
    assert (tmp_path / "ring.png").read_bytes()[:4] == b"\x89PNG"


def test_one_way_changes_nothing_on_a_map_without_lanes():
    """The grid map (wide corridors) has no lanes: the run with one-way lanes on is the run
    without the lane layer, figure for figure; it only reports its (no) lanes, since the layer
    is kept without lanes (a lost teammate's body is placed from its claims)."""
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    def summary(**lanes):
        run = PhysicsRun(PhysicsConfig(map="grid", strategy="tpuaf", robots=2, seed=3,
                                       duration_s=60.0, **lanes))
        out = run.run()
        assert not run.agents[0].machine.patrol_map.one_way
        return {k: v for k, v in out.items() if isinstance(v, int | float)}

    layer, off, auto = summary(lanes="one_way"), summary(lanes="off"), summary()
    assert layer == auto
    lane_keys = {"lanes": 0, "lane_waits": 0, "lane_wait_s": 0.0}
    assert {k: layer[k] for k in lane_keys} == lane_keys and not lane_keys.keys() & off.keys()
    assert {k: v for k, v in layer.items() if k not in lane_keys} == off


def test_a_robot_follows_only_in_one_way_lanes_along_their_leg():
    from tpuaf.navigation.lanes import find_lanes
    from tpuaf.navigation.planner import PathPlanner
    from tpuaf.robot.lanes import LaneAccess
    from tpuaf.team.lane_locks import LaneLocks

    pm = load_map("lab")
    lanes = find_lanes(PathPlanner(pm, 0.105), pm)
    locks = LaneLocks(0, lambda claim: None, lambda robot: False)
    middle_aisle = [(1.5, 1.3)]  # inside lane 3 (the aisle 5-6-7-8-9)
    one_way = LaneAccess(lanes, locks, locked=frozenset())
    assert one_way.one_way and one_way.follows(9, 8, middle_aisle)
    assert not one_way.follows(4, 9, middle_aisle)  # the blocker is in another lane
    assert not one_way.follows(None, 8, middle_aisle)
    # no lock asked: the one-way lane is announced as where the robot is (held, no wait)
    assert one_way.may_start(9, 8, 0.0) and locks.mine.held and locks.mine.leg == (9, 8)
    assert locks.waits == 0
    all_locked = LaneAccess(lanes, LaneLocks(1, lambda claim: None, lambda robot: False))
    assert not all_locked.one_way and not all_locked.follows(9, 8, middle_aisle)


def test_the_graph_runtime_drives_one_way_lanes_their_way(tmp_path, capsys):
    """`--lanes one_way` in the graph runtime (the promise): routes follow the same orientation
    as in physics; both ways are driven without it."""
    from tpuaf.cli import main
    from tpuaf.runtimes.config import RunConfig
    from tpuaf.runtimes.graph import make_run

    pm = load_map(str(ring_of_aisles(tmp_path / "ring")))

    def legs(one_way: bool) -> tuple[set, set, dict]:
        run = make_run(RunConfig(map=pm.name, strategy="rand", robots=2, seed=2,
                                 duration_s=600.0, robot="burger", lanes="one_way" if one_way else "off"), pm)
        summary = run.run()
        last: dict[int, int] = {}
        seen = set()
        for _, robot, vertex in run.recorder.visits:
            if robot in last and last[robot] != vertex:
                seen.add((last[robot], vertex))
            last[robot] = vertex
        return seen, (set(run.lanes.plan_map.one_way) if run.lanes else set()), summary

    lane_edges = {(0, 1), (1, 2), (2, 3), (0, 3)}
    two_way, _, _ = legs(False)
    assert {(b, a) for a, b in two_way} & two_way & {*lane_edges, *((b, a) for a, b in lane_edges)}
    one_way, arcs, summary = legs(True)
    assert len(arcs) == 4 and summary["one_way_lanes"] == 2
    driven = {leg for leg in one_way if (min(leg), max(leg)) in lane_edges}
    assert driven and driven <= arcs
    # the CLI: one_way in the graph runtime, locks refused (exit 2, one line)
    assert main(["run", "--map", str(tmp_path / "ring"), "--robots", "2", "--duration", "60",
                 "--lanes", "one_way", "--quiet"]) == 0
    capsys.readouterr()


def test_a_robot_holds_the_one_way_lane_it_drives_and_paths_off_its_route_are_checked_along():
    """Off its route a robot keeps out of the lanes it does not hold, checked at every point of
    a path, not only at its corners: a straight path down a whole aisle from one corner to the
    next has both ends outside the lane (before: a refuge down aisle 0, past the robot's goal,
    and back against the flow). The one-way lane its leg drives counts as held by it."""
    from tpuaf.navigation.route import GraphRoute
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    run = PhysicsRun(PhysicsConfig(map="lab", strategy="tpuaf", robots=1, seed=1,
                                   duration_s=10.0, robot="burger", lanes="one_way"))
    agent = run.agents[0]
    nav, lanes = agent.navigator, run.lane_map
    down_aisle_0 = np.array([(0.31, 0.34), (2.51, 0.34)])  # corner 0 to corner 4, straight
    inside_aisle_0 = np.array([(0.9, 0.3), (1.5, 0.3)])
    up_rail_1 = np.array([(0.3, 0.45), (0.3, 1.15)])
    assert lanes.lane_at(down_aisle_0).tolist() == [-1, -1]  # both ends outside every lane
    assert lanes.lane_at(inside_aisle_0).tolist() == [0, 0]
    assert not nav._lane_free_path(down_aisle_0)  # no route: every lane is someone else's
    assert not nav._lane_free_path(inside_aisle_0)
    assert not nav._lane_free(inside_aisle_0[:1]).any()
    nav.set_route(GraphRoute(agent._graph, agent._positions, 0, 2), 0.0)  # 0 -> 1 -> 2: lane 0
    assert nav._driven_lane() == 0
    assert nav._lane_free_path(inside_aisle_0) and nav._lane_free_path(down_aisle_0)
    assert nav._lane_free(inside_aisle_0).all()
    assert not nav._lane_free_path(up_rail_1)  # rail 5 -> 0 (lane 1): not driven, not held
    nav.set_route(GraphRoute(agent._graph, agent._positions, 5, 0), 0.0)  # down rail 1
    assert nav._driven_lane() == 1 and not nav._lane_free_path(inside_aisle_0)


def test_four_robots_on_the_lab_one_way_never_drive_back_against_the_flow_in_physics():
    """4 tpuaf Burgers, lab, one-way, 600 s (seed 1): no goal fails and no robot drives back
    along a one-way lane (before: a robot at corner 0 gave way down aisle 0 to corner 4, past
    its goal 1, drove back against the flow and met a robot head-on: 2 goal failures by 570 s,
    3.2 m against the flow)."""
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    run = PhysicsRun(PhysicsConfig(map="lab", strategy="tpuaf", robots=4, seed=1,
                                   duration_s=600.0, robot="burger", lanes="one_way"))
    lanes, positions = run.lane_map, run.agents[0]._positions
    arcs = [(u, v) for u, v in run.orientation.arcs if lanes.lane_of(u, v) >= 0]
    last: dict[int, np.ndarray] = {}
    against = np.zeros(4)  # [m] driven against the arc of the lane the robot is in

    def watch(t: float) -> None:
        for i, agent in enumerate(run.agents):
            p = np.array(agent.pose[:2])
            q = last.get(i)
            last[i] = p
            lane = -1 if q is None else int(lanes.lane_at(q[None])[0])
            if lane < 0:
                continue
            best = (math.inf, None)
            for u, v in arcs:  # the lane's arc nearest to where the robot was
                if lanes.lane_of(u, v) == lane:
                    a, ab = positions[u], positions[v] - positions[u]
                    f = np.clip((q - a) @ ab / (ab @ ab), 0.0, 1.0)
                    best = min(best, (float(np.hypot(*(q - a - f * ab))), tuple(ab)),
                               key=lambda b: b[0])
            ab = np.asarray(best[1])
            against[i] += max(0.0, -float((p - q) @ ab) / float(np.hypot(*ab)))

    summary = run.run(watch)
    assert summary["goal_failures"] == 0, summary
    assert against.max() < 1.0, against
    assert summary["visits"] >= 300
