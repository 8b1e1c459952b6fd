"""A dead robot's body inside a lane: its last lane claim says which edge it drove, and the
survivors drop that edge from their plan (robot/lanes.py `blocked_layer`, docs/LANES.md)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from tpuaf.maps import load_map
from tpuaf.navigation.lanes import find_lanes
from tpuaf.navigation.one_way import orient_lanes
from tpuaf.navigation.planner import PathPlanner
from tpuaf.robot import lanes as robot_lanes
from tpuaf.robot.lanes import LaneLayer, blocked_layer, body_blocks
from tpuaf.team.lane_locks import LaneLocks
from tpuaf.team.messages import LaneClaim, problem

RADIUS = 0.105  # [m] a TurtleBot3 Burger


def lab_layer() -> LaneLayer:
    pm = load_map("lab")
    lane_map = find_lanes(PathPlanner(pm, RADIUS), pm)
    orientation = orient_lanes(lane_map, pm)
    return LaneLayer(lane_map, orientation, replace(pm, one_way=tuple(orientation.arcs)))


def directed_distances(plan_map) -> np.ndarray:
    graph = plan_map.graph
    n = plan_map.num_vertices
    return np.array([[graph.distance(u, v) for v in range(n)] for u in range(n)])


def test_a_blocked_rail_drops_its_edge_keeps_the_other_lanes_directions_and_every_vertex():
    layer = lab_layer()
    new = blocked_layer(layer, (9, 4))  # the rail 4-9 (lane 2) holds a body
    assert new is not None and new is blocked_layer(layer, (4, 9))  # one layer for the team
    edges = {(min(u, v), max(u, v)) for u, v, _ in new.plan_map.edges}
    assert (4, 9) not in edges and len(edges) == len(layer.plan_map.edges) - 1
    assert new.lane_map.lanes[2].edges == ()  # a one-edge lane is gone (its index stays)
    # where robots are inside lanes is still known (the middle aisle: lane 3), edge by edge
    assert new.lane_map.lane_at([(1.5, 1.3)]).tolist() == [3]
    assert new.lane_map.lane_of(4, 9) == -1 and layer.lane_map.lane_of(4, 9) == 2
    # the aisle 0..4 now ends at 4: a dead end, two-way and locked; so is the rail 0-5
    assert {0, 1} <= new.locked and 0 not in new.orientation.chains
    # the lanes still on a cycle keep the direction robots drive them now
    for lane, chain in new.orientation.chains.items():
        assert chain == layer.orientation.chains[lane]
    assert np.isfinite(directed_distances(new.plan_map)).all()  # every vertex reaches every other
    # the old plan drove 4 -> 9 only; the new one reaches 4 (from 3, the dead end's way in)
    assert math.isfinite(new.plan_map.graph.distance(9, 4))


def test_a_bridge_or_a_wide_edge_is_not_blocked():
    layer = lab_layer()
    twice = blocked_layer(blocked_layer(layer, (4, 9)), (0, 1))  # 0-1 is now a dead end's edge
    assert twice is None  # dropping it would cut 1..4 off: the lock is only freed
    assert blocked_layer(layer, (0, 14)) is None  # not an edge of a lane


def test_a_robot_announces_the_lane_it_drives_one_way_and_a_lost_ones_claim_says_where():
    sent: list[LaneClaim] = []
    locks = LaneLocks(0, sent.append)
    locks.drive(3, (9, 8), 10.0)  # one-way lane 3 entered without a lock
    assert sent[-1].held and sent[-1].lane == 3 and sent[-1].leg == (9, 8)
    locks.drive(3, (8, 7), 12.0)  # the next edge of the same lane: re-announced
    assert sent[-1].leg == (8, 7) and sent[-1].stamp == 10.0
    locks.release(15.0)  # out at its waiting spot
    assert sent[-1].lane == -1 and not sent[-1].held

    other = LaneLocks(1, lambda c: None)
    other.on_claim(LaneClaim(0, 3, 10.0, True, 12.0, (8, 7), (1.9, 1.3)))
    claim = other.lost_in(0)
    assert claim.lane == 3 and claim.leg == (8, 7) and claim.position == (1.9, 1.3)
    other.on_claim(LaneClaim(0, 3, 20.0, False, 21.0, (-1, -1)))  # only asking: not inside
    assert other.lost_in(0) is None
    assert other.lost_in(5) is None  # never heard


def test_a_body_next_to_a_junction_cuts_it_off_but_one_tether():
    """Robot dead 4 cm from junction 9 on its leg 9 -> 8: 9 cannot be reached (another robot
    would have to stand on the body); it keeps one edge, so no route passes through it."""
    layer = lab_layer()
    claim = LaneClaim(0, 3, 10.0, True, 12.0, (9, 8), (2.70, 1.26))
    edge, occupied = body_blocks(layer, claim)
    assert edge == (8, 9) and occupied == (9,)
    new = blocked_layer(layer, edge, occupied)
    graph = new.plan_map.graph
    assert len(graph.neighbours(9)) == 1  # the tether: a dead end now
    assert np.isfinite(directed_distances(new.plan_map)).all()
    assert body_blocks(layer, replace(claim, position=(math.nan, math.nan)))[1] == ()
    rail = LaneClaim(0, 2, 10.0, True, 12.0, (4, 9), (2.70, 0.80))  # half way down 1 m
    assert body_blocks(layer, rail) == ((4, 9), ())  # both ends still reachable


def test_lane_claim_legs_are_checked():
    assert problem(LaneClaim(1, 2, 3.0, True, 3.5, (0, 4)), 2, 5, 3) is None
    assert "outside the map" in problem(LaneClaim(1, 2, 3.0, True, 3.5, (0, 5)), 2, 5, 3)
    assert "not a pair" in problem(LaneClaim(1, 2, 3.0, True, 3.5, (0,)), 2, 5, 3)
    assert "not an integer" in problem(LaneClaim(1, 2, 3.0, True, 3.5, (0, 1.5)), 2, 5, 3)
    bad_position = LaneClaim(1, 2, 3.0, True, 3.5, (0, 1), (math.inf, 0.0))
    assert "not a point" in problem(bad_position, 2, 5, 3)


def run_death(block: bool, monkeypatch, strategy: str = "tpuaf",
              duration_s: float = 600.0) -> tuple[dict, list]:
    """Lab, 4 Burgers, one-way, robot 0 dies at 200 s inside a lane (seed 1); the summary
    gains `visits_after_death`."""
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    monkeypatch.setattr(robot_lanes, "BLOCK_LOST_BODIES", block)
    run = PhysicsRun(PhysicsConfig(map="lab", strategy=strategy, robots=4, duration_s=duration_s,
                                   seed=1, robot="burger", fail=["0@200"], lanes="one_way"))
    at_death: list[int] = []

    def progress(t: float) -> None:
        if t >= 200.0 and not at_death:
            at_death.append(sum(a.machine.visits for a in run.agents))

    summary = run.run(progress)
    summary["visits_after_death"] = summary["visits"] - at_death[0]
    return summary, run.lane_access


def test_survivors_drop_the_dead_robots_edge_and_visit_more_than_without(monkeypatch):
    blocked, access = run_death(True, monkeypatch)
    freed, _ = run_death(False, monkeypatch)
    assert freed["lane_edges_blocked"] == []
    (edge,) = blocked["lane_edges_blocked"]  # every survivor blocked the same edge
    assert all(a.blocked == [tuple(edge)] for a in access[1:])  # lab ids are indices
    assert access[0].blocked == []  # the dead robot hears nothing
    # without the edge the survivors stop queueing behind the body in its one-way lane
    after, before = blocked["visits_after_death"], freed["visits_after_death"]
    assert after > 1.2 * before, (after, before)


@pytest.mark.parametrize("mode", ["locks"])
def test_blocking_keeps_lock_mode_locked(mode):
    pm = load_map("lab")
    lane_map = find_lanes(PathPlanner(pm, RADIUS), pm)
    layer = LaneLayer(lane_map, None, replace(pm))
    new = blocked_layer(layer, (4, 9))
    assert new is not None and new.orientation is None and new.locked is None  # all locked
    assert not new.plan_map.one_way


def body_on_junction_9() -> LaneLayer:
    """The lab after robot 0 died 4 cm from junction 9 on its leg 9 -> 8: 8-9 dropped, 9 cut
    off (tethered to 14); the lab is then a tree of dead-end aisles round 5, all locked."""
    layer = lab_layer()
    edge, occupied = body_blocks(layer, LaneClaim(0, 3, 10.0, True, 12.0, (9, 8), (2.70, 1.26)))
    return blocked_layer(layer, edge, occupied)


def test_a_cut_off_vertex_is_closed_and_tpuaf_plus_plans_without_it():
    from tpuaf.policies.tpuaf_plus import make_plan

    new = body_on_junction_9()
    pm = new.plan_map
    assert pm.closed == {9}
    graph = pm.graph
    for team in [(0, 1, 2, 3), (1, 2, 3), (1, 2)]:
        plan = make_plan(pm, team, (0, 4, 10, 14), "auto", "auto")
        walks = [r.walk for r in plan.routes]
        assert all(9 not in w for w in walks), walks  # no goal at the body
        assert set().union(*walks) == set(range(15)) - {9}  # every other vertex is planned
        for w in walks:  # each step one edge of the plan's graph (no detour through a lane)
            for a, b in zip(w, w[1:] + w[:1], strict=True):
                assert a == b or b in graph.neighbours(a), (a, b, w)


def test_a_replan_gives_each_dead_end_to_a_survivor_already_in_it():
    """Survivors at 12 and 14 in the lower aisle (now a dead end) and at 0: the one nearer
    the aisle's mouth leaves it, the deeper one keeps it, the third keeps the upper aisle;
    the run's start vertices (4, 10, 14) would send robot 1 from 12 to the upper aisle,
    crossing the others in one-robot lanes."""
    from tpuaf.policies.tpuaf_plus import plan_from

    pm = body_on_junction_9().plan_map
    plan = plan_from(pm, (1, 2, 3), (14, 12, 14, 0), "auto")
    walk = {r: set(plan.routes[plan.route_of[r]].walk) for r in (1, 2, 3)}
    assert {14, 13, 12, 11} <= walk[2] and 0 in walk[3] and 12 not in walk[1]
    assert plan.schedule == {} and sorted(plan.route_of) == [1, 2, 3]


def test_tpuaf_plus_keeps_patrolling_after_a_body_cuts_a_junction_off(monkeypatch):
    """Lab, tpuaf_plus, robot 0 dies on junction 9 at 200 s (seed 1): before plans skipped
    the cut-off vertex and were matched to where the survivors stood, they queued in the
    dead-end aisles (23 visits in the 200 s after the death)."""
    s, _ = run_death(True, monkeypatch, "tpuaf_plus", 400.0)
    assert s["lane_vertices_closed"] == [9]
    assert s["visits_after_death"] > 60, s["visits_after_death"]
    (recovery,) = s["recovery"]
    # 9 is never visited again: the plain ratio counts it, the reachable one does not
    assert recovery["worst_idleness_ratio_reachable"] < 3.0
    assert recovery["worst_idleness_ratio_to_detection_reference"] > \
        recovery["worst_idleness_ratio_reachable"]
