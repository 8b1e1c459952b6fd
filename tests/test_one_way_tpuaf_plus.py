"""tpuaf_plus on one-way lanes (docs/LANES.md): its walks drive every one-way lane only its way,
robots are spaced so that none meet where a walk passes a vertex twice, and physics runs keep
every robot visiting."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from tpuaf.maps import load_map
from tpuaf.maps.model import PatrolMap
from tpuaf.policies import tpuaf_plus
from tpuaf.policies.tpuaf_plus_routes import MEET_CLEARANCE_M

from tests.test_one_way import record_legs, ring_of_aisles


def against_arcs(walk, arcs) -> list[tuple[int, int]]:
    """The steps of the closed walk that drive an arc backwards."""
    back = {(v, u) for u, v in arcs}
    return [(a, b) for a, b in zip(walk, walk[1:] + walk[:1], strict=True) if (a, b) in back]


def ring(n: int) -> PatrolMap:
    angles = 2 * np.pi * np.arange(n) / n
    positions = np.c_[np.cos(angles), np.sin(angles)] * 2.0
    return PatrolMap("ring", list(range(n)), positions,
                     [(i, (i + 1) % n, float("nan")) for i in range(n)], np.ones(n), np.ones(n))


@pytest.mark.parametrize("robots", [1, 2, 3])
def test_the_cycle_drives_a_one_way_lane_only_its_way(robots):
    """A ring of 6 whose edge 0-1 is one way, 1 -> 0: the cycle goes round the ring that way
    (through 1 -> 0), never 0 -> 1, and visits every vertex; the plan tpuaf_plus picks (here
    with 3 robots a partition, parts of two-way edges) never drives 0 -> 1 either."""
    arcs = ((1, 0),)
    pm = replace(ring(6), one_way=arcs)
    team, starts = tuple(range(robots)), tuple([0] * robots)
    (route,) = tpuaf_plus.make_plan(pm, team, starts, "cycle").routes
    walk = list(route.walk)
    assert against_arcs(walk, arcs) == [], walk
    assert (1, 0) in list(zip(walk, walk[1:] + walk[:1], strict=True))
    assert set(walk) == set(range(6))
    plan = tpuaf_plus.make_plan(pm, team, starts, "auto")
    for route in plan.routes:
        assert against_arcs(list(route.walk), arcs) == [], route.walk
    assert set().union(*(r.walk for r in plan.routes)) == set(range(6))


def lab_one_way() -> tuple[PatrolMap, list[tuple[int, int]]]:
    from tpuaf.navigation.lanes import find_lanes
    from tpuaf.navigation.one_way import orient_lanes
    from tpuaf.navigation.planner import PathPlanner

    pm = load_map("lab")
    arcs = orient_lanes(find_lanes(PathPlanner(pm, 0.105), pm), pm).arcs
    return replace(pm, one_way=tuple(arcs)), arcs


def test_lab_figure_eight_is_driven_one_way_and_spaced_so_no_two_robots_meet():
    """The lab's one-way lanes form a figure eight whose middle aisle every closed walk passes
    twice. Every walk follows the arcs; with 2 and 4 robots (whose even spacing L / 2 would put
    two robots at the middle aisle at once, one from each loop) the target gaps keep every
    pair's phase difference at least MEET_CLEARANCE_M from the arc between two passes of a
    vertex; with 3 robots even spacing already does (no gaps)."""
    pm, arcs = lab_one_way()
    clearance = MEET_CLEARANCE_M
    for robots in (1, 2, 3, 4):
        plan = tpuaf_plus.make_plan(pm, tuple(range(robots)), tuple([0] * robots), "auto")
        (route,) = plan.routes
        walk = list(route.walk)
        assert against_arcs(walk, arcs) == [] and set(walk) == set(range(pm.num_vertices))
        L = route.length
        passes: dict[int, list[float]] = {}
        for v, a in zip(walk, route.arc, strict=True):
            passes.setdefault(v, []).append(a)
        apart = {(q - p) % L for ps in passes.values() for p in ps for q in ps if p != q}
        assert apart  # the middle aisle is passed twice
        if robots == 1 or robots == 3:
            assert route.gaps == ()
            continue
        assert len(route.gaps) == robots and sum(route.gaps) == pytest.approx(L)
        assert max(route.gaps) <= L / robots + 2 * clearance  # near even
        phases = np.cumsum([0.0, *route.gaps[:-1]])
        for i in range(robots):
            for j in range(i + 1, robots):
                d = phases[j] - phases[i]
                assert all(min(abs(d - a), L - abs(d - a)) >= clearance - 1e-6 for a in apart)
        # even spacing would meet: robots L / 2 apart, about one loop
        assert any(min(abs(L / 2 - a), L - abs(L / 2 - a)) < clearance for a in apart)


def test_msp_takes_fewer_parts_where_one_way_arcs_leave_no_n_strongly_connected_ones():
    """The lab's every directed cycle runs through the middle aisle: no 2 or 4 strongly
    connected parts, so msp's partition is the one part (the figure eight); on the ring with
    one arc a partition into 3 parts exists and is kept."""
    from tpuaf.maps import tours

    pm, _ = lab_one_way()
    assert tours.partition_tours(pm, 4).parts == []
    partition = tours.tourable_partition(pm, 4)
    assert len(partition.parts) == 1 and sorted(partition.parts[0]) == list(range(pm.graph.num_vertices))
    assert partition.robots_per_part == [4]
    ring_map = replace(ring(6), one_way=((1, 0),))
    assert len(tours.tourable_partition(ring_map, 3).parts) == 3
    with pytest.raises(ValueError, match="parts must be in 1..4"):
        tours.partition_tours(pm, 4, parts=5)


@pytest.mark.parametrize("strategy", ["cgg", "msp"])
def test_cgg_and_msp_drive_the_lab_one_way(strategy):
    """Their tours follow the arcs (cgg: the directed cycle; msp: the parts that exist): in
    physics no leg of any route drives a one-way lane backwards, and every robot visits."""
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    PhysicsConfig(map="lab", strategy=strategy, lanes="one_way").validate()
    run = PhysicsRun(PhysicsConfig(map="lab", strategy=strategy, robots=2, seed=1,
                                   duration_s=150.0, robot="burger", lanes="one_way"))
    back = {(v, u) for u, v in run.orientation.arcs}
    legs = record_legs(run)
    run.run()
    assert legs and not [leg for leg in legs if leg in back]
    assert all(a.machine.visits >= 3 for a in run.agents), [a.machine.visits for a in run.agents]


def run_and_count(run, windows):
    """Runs `run`; per window (start, end) [s], each robot's visits in it."""
    counts: list[tuple[float, list[int]]] = []
    summary = run.run(lambda t: counts.append((t, [a.machine.visits for a in run.agents])))
    out = []
    for start, end in windows:
        before = next(c for t, c in counts if t >= start)
        after = [c for t, c in counts if t <= end][-1]
        out.append([b - a for a, b in zip(before, after, strict=True)])
    return summary, out


def test_tpuaf_plus_on_a_ring_of_aisles_follows_the_arcs_and_keeps_visiting(tmp_path):
    """Two robots, one-way lanes on a ring of two aisles with a dead end in each room: every leg
    through a one-way lane follows its arc, and both robots visit in each 100 s of the run."""
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    pm = load_map(str(ring_of_aisles(tmp_path / "ring")))
    run = PhysicsRun(PhysicsConfig(map=pm.name, strategy="tpuaf_plus", robots=2, seed=1,
                                   duration_s=300.0, robot="burger", lanes="one_way"),
                     patrol_map=pm)
    allowed = set(run.orientation.arcs)
    one_way_edges = {(min(a, b), max(a, b)) for a, b in allowed}
    legs = record_legs(run)
    summary, visits = run_and_count(run, [(0.0, 100.0), (100.0, 200.0), (200.0, 300.0)])
    through = [(a, b) for a, b in legs if (min(a, b), max(a, b)) in one_way_edges]
    assert through and all(leg in allowed for leg in through)
    assert summary["collisions"] == 0
    assert all(v > 0 for window in visits for v in window), visits


def test_four_burgers_with_tpuaf_plus_keep_visiting_on_the_lab_one_way():
    """The issue's lab, 4 Burgers, tpuaf_plus on one-way lanes, 300 s: every robot visits in
    every 100 s (no robot stuck behind another at a merge)."""
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    run = PhysicsRun(PhysicsConfig(map="lab", strategy="tpuaf_plus", robots=4, seed=2,
                                   duration_s=300.0, robot="burger", lanes="one_way"))
    assert run.patrol_map.one_way  # the plan's graph follows the arcs
    summary, visits = run_and_count(run, [(0.0, 100.0), (100.0, 200.0), (200.0, 300.0)])
    assert all(v > 0 for window in visits for v in window), visits
    assert summary["lane_waits"] == 0


def test_dtap_counts_hops_along_the_arcs():
    """On a ring of 6 whose edge 0-1 is one way (1 -> 0), vertex 1 is one edge from 0 but five
    hops away driving the arcs; without arcs the graph's own hop matrix."""
    from tpuaf.maps.tours import travel_hops

    two_way = ring(6)
    assert (travel_hops(two_way) == two_way.graph.hop_matrix).all()
    hops = travel_hops(replace(ring(6), one_way=((1, 0),)))
    assert hops[1, 0] == 1 and hops[0, 1] == 5 and hops[2, 0] == 2 and hops[0, 2] == 4
