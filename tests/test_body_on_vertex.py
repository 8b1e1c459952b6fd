"""A teammate lost standing on a vertex outside any lane: its last two claims say where its
body stands, and the survivors close the vertices it covers (robot/lanes.py `body_vertices`,
`closed_layer`: each keeps one edge, unless that cuts the plan in two); tpuaf_plus plans
without them."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from tpuaf.maps.model import MapSettings, PatrolMap
from tpuaf.navigation.lanes import LaneMap
from tpuaf.robot.lanes import LaneLayer, body_vertices, closed_layer
from tpuaf.team.lane_locks import LaneLocks
from tpuaf.team.messages import LaneClaim

MAPS = Path(__file__).resolve().parents[2] / "shared" / "maps" / "patrolling_sim"
PASS_BAND_M = 0.4  # [m] two robots side by side


def star_map() -> PatrolMap:
    """A junction 0 with three arms of two vertices 2 m apart: 0 is a cut vertex."""
    positions = [(0.0, 0.0)]
    edges = []
    for dx, dy in [(1, 0), (-1, 0), (0, 1)]:
        first = len(positions)
        positions += [(2.0 * dx, 2.0 * dy), (4.0 * dx, 4.0 * dy)]
        edges += [(0, first, math.nan), (first, first + 1, math.nan)]
    n = len(positions)
    return PatrolMap("star", list(range(n)), np.asarray(positions, dtype=float), edges,
                     np.ones(n), np.ones(n), MapSettings())


def layer_without_lanes(pm: PatrolMap) -> LaneLayer:
    return LaneLayer(LaneMap([], {}, frozenset(), PASS_BAND_M), None, pm)


def test_a_teammate_that_stood_by_a_vertex_covers_it_one_that_drove_or_was_heard_once_not():
    layer = layer_without_lanes(star_map())
    assert body_vertices(layer, [(0.05, 0.1), (0.1, 0.05)]) == (0,)
    assert body_vertices(layer, [(0.05, 0.1), (0.9, 0.0)]) == ()  # it was driving away
    assert body_vertices(layer, [(0.05, 0.1)]) == ()  # heard once: not known to stand
    assert body_vertices(layer, [(1.0, 0.0), (1.0, 0.0)]) == ()  # mid-edge: no vertex covered
    # moving 0.3 m a second near vertex 0: not standing, even with both positions near it
    assert body_vertices(layer, [(0.3, 0.0), (0.0, 0.1)]) == ()
    # on its way to its goal 1 (2, 0), 0.4 m short of it: it lies between there and 1
    assert body_vertices(layer, [(1.0, 0.0), (1.6, 0.0)], goal=1) == (1,)
    assert body_vertices(layer, [(1.0, 0.0), (1.3, 0.0)], goal=1) == ()  # 0.7 m short
    assert body_vertices(layer, [(1.6, 0.0)], goal=1) == (1,)  # heard once on its way
    # its Intention left vertex 1 after its last claim, and it can have driven 0.2 m since:
    # its body lies by 1 (ctcv, 8 robots: it died 0.2 s after leaving a junction)
    assert body_vertices(layer, [(0.5, 0.0), (1.3, 0.0)], goal=2, left=(1, 0.2)) == (1,)
    assert body_vertices(layer, [(0.5, 0.0), (1.3, 0.0)], goal=2, left=(1, 0.9)) == ()


def test_where_a_lost_teammate_went_is_read_from_its_intention_and_claims():
    from types import SimpleNamespace

    from tpuaf.robot.lanes import _heading
    from tpuaf.team.messages import Intention

    locks = LaneLocks(1, lambda claim: None)
    locks.on_claim(LaneClaim(0, -1, 0.0, False, 9.0, (-1, -1), (1.0, 0.0)))
    locks.on_claim(LaneClaim(0, -1, 0.0, False, 10.0, (-1, -1), (1.0, 0.0)))
    # it reached 1 and left at once 0.2 s before its next claim was due
    machine = SimpleNamespace(teammate_intentions={0: Intention(0, 1, 2, 12.8, 2.0, 10.8)},
                              teammate_visits={})
    goal, (left, drive), moved = _heading(machine, locks, 0, 1.0)
    assert (goal, left, moved) == (2, 1, 0.0) and math.isclose(drive, 0.2)
    # ... dwelling there until 11.5 s: it never left
    machine.teammate_intentions[0] = Intention(0, 1, 2, 13.5, 2.0, 10.8)
    assert _heading(machine, locks, 0, 1.0) == (2, (1, 0.0), 0.0)
    # it stood at its last two claims and was to leave at 10.3 s: it may be 0.7 m off
    machine.teammate_intentions[0] = Intention(0, 1, 2, 12.3, 2.0, 8.0)
    goal, left, moved = _heading(machine, locks, 0, 1.0)
    assert (goal, left) == (2, None) and math.isclose(moved, 0.7)
    # ... to leave before its last two claims: held there (blocked), it stays put
    machine.teammate_intentions[0] = Intention(0, 1, 2, 10.5, 2.0, 8.0)
    assert _heading(machine, locks, 0, 1.0) == (2, None, 0.0)
    # ... unless that was within a turn on the spot of them (ctcv, 12 robots: it turned at 13
    # for a second, then drove 0.9 m off before it died)
    goal, left, moved = _heading(machine, locks, 0, 1.0, turn_s=1.0)
    assert math.isclose(moved, 1.0)
    assert _heading(SimpleNamespace(teammate_intentions={}, teammate_visits={}), locks, 0,
                    1.0) == (None, None, 0.0)
    from tpuaf.robot.lanes import claims_current

    assert claims_current(locks, 0, 11.2) and not claims_current(locks, 0, 11.4)
    assert not claims_current(locks, 5, 0.0)  # never claimed
    # heard after its next claim was due: that claim was lost, it may have lived on
    machine.teammate_intentions[0] = Intention(0, 1, 2, 12.8, 2.0, 10.8)
    goal, (left, drive), _ = _heading(machine, locks, 0, 1.0, current=claims_current(locks, 0, 11.0))  # the claim's time
    assert left == 1 and math.isclose(drive, 0.2)
    assert _heading(machine, locks, 0, 1.0, current=claims_current(locks, 0, 11.4)) == (None, None, math.inf)
    machine.teammate_intentions[0] = Intention(0, 1, 2, 12.3, 2.0, 8.0)
    assert _heading(machine, locks, 0, 1.0, current=claims_current(locks, 0, 11.4)) == (None, None, math.inf)


def test_a_visit_newer_than_the_intention_means_its_next_intention_was_lost():
    """Under message loss: a teammate standing at its last two claims whose latest Visit is
    newer than its latest Intention (tpuaf and tpuaf_plus send both at each arrival) may have
    left after its last claim: it covers the vertex only where that drive could not take it
    off (recovery_physics_loss.md: 9 vertices closed with no body on them)."""
    from types import SimpleNamespace

    from tpuaf.robot.lanes import _heading
    from tpuaf.team.messages import Intention, Visit

    locks = LaneLocks(1, lambda claim: None)
    locks.on_claim(LaneClaim(0, -1, 0.0, False, 9.0, (-1, -1), (1.95, 0.0)))
    locks.on_claim(LaneClaim(0, -1, 0.0, False, 10.0, (-1, -1), (1.95, 0.0)))
    # heard: the Intention to vertex 1 (sent at 6 s) and the arrival there at 8.5 s
    machine = SimpleNamespace(teammate_intentions={0: Intention(0, 0, 1, 8.5, 2.0, 6.0)},
                              teammate_visits={0: Visit(0, 1, 8.5, 2)})
    assert _heading(machine, locks, 0, 1.0) == (2, None, 1.0)  # may be 1 m off by 11 s
    layer = layer_without_lanes(star_map())
    assert body_vertices(layer, locks.last_positions(0), *_heading(machine, locks, 0, 1.0)) == ()
    # a slow robot (0.1 m/s) cannot have left the vertex's reach: covered still
    assert body_vertices(layer, locks.last_positions(0), *_heading(machine, locks, 0, 0.1)) == (
        1,)
    # arrived after its last claim (10.8 s): it left vertex 1 at the earliest then
    machine.teammate_visits[0] = Visit(0, 1, 10.8, 2)
    goal, (left, drive), moved = _heading(machine, locks, 0, 1.0)
    assert (goal, left, moved) == (2, 1, 0.0) and math.isclose(drive, 0.2)
    # the Intention heard with the Visit: the rules of the Intention
    machine.teammate_intentions[0] = Intention(0, 1, 2, 13.5, 2.0, 10.8)
    assert _heading(machine, locks, 0, 1.0) == (2, (1, 0.0), 0.0)
    # a strategy that sends no Intention (gbs, sebs): the Visit alone changes nothing
    machine = SimpleNamespace(teammate_intentions={}, teammate_visits={0: Visit(0, 1, 8.5, 2)})
    assert _heading(machine, locks, 0, 1.0) == (None, None, 0.0)


def test_a_teammate_that_stood_then_may_have_left_covers_only_what_it_covers_wherever_it_went():
    layer = layer_without_lanes(star_map())  # reach 0.4 + 0.15 m
    assert body_vertices(layer, [(0.05, 0.0), (0.05, 0.0)], moved_m=0.3) == (0,)
    assert body_vertices(layer, [(0.05, 0.0), (0.05, 0.0)], moved_m=0.6) == ()


def test_the_locks_keep_a_teammates_last_two_positions():
    locks = LaneLocks(1, lambda claim: None)
    assert locks.last_positions(0) == []
    locks.on_claim(LaneClaim(0, -1, 0.0, False, 1.0, (-1, -1), (1.0, 2.0)))
    locks.on_claim(LaneClaim(0, -1, 0.0, False, 2.0, (-1, -1), (1.5, 2.0)))
    locks.on_claim(LaneClaim(0, -1, 0.0, False, 1.5, (-1, -1), (9.0, 9.0)))  # late: ignored
    assert locks.last_positions(0) == [(1.0, 2.0), (1.5, 2.0)]
    locks.on_claim(LaneClaim(0, -1, 0.0, False, 3.0))  # position not known
    assert locks.last_positions(0) == [(1.5, 2.0)]


def ring_map() -> PatrolMap:
    """A ring 0-1-2-3 of 2 m sides with a spur 3-4: 1 is no cut vertex, 3 is."""
    positions = [(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0), (-2.0, 2.0)]
    edges = [(0, 1, math.nan), (1, 2, math.nan), (2, 3, math.nan), (3, 0, math.nan),
             (3, 4, math.nan)]
    return PatrolMap("ring", list(range(5)), np.asarray(positions, dtype=float), edges,
                     np.ones(5), np.ones(5), MapSettings())


def test_a_closed_vertex_hangs_on_one_edge_and_one_layer_serves_the_team():
    layer = layer_without_lanes(ring_map())
    new = closed_layer(layer, (1,))
    assert new is not None and new is closed_layer(layer, (1,))
    assert new.plan_map.closed == {1}
    edges = {(min(u, v), max(u, v)) for u, v, _ in new.plan_map.edges}
    assert edges == {(0, 1), (2, 3), (0, 3), (3, 4)}  # its tether: the lowest far end
    assert closed_layer(layer, ()) is None
    # a cut vertex robots can pass: a bypass between its open neighbours, then its tether
    new = closed_layer(layer, (3,))
    assert new.plan_map.closed == {3}
    edges = {(min(u, v), max(u, v)): d for u, v, d in new.plan_map.edges}
    assert set(edges) == {(0, 1), (1, 2), (0, 3), (0, 4), (2, 4)}  # 0-2 has a way round (1)
    assert edges[(0, 4)] == edges[(2, 4)] == 4.0  # [m] through the body's vertex
    # ... not one a robot cannot pass by (two robots do not fit side by side there)
    narrow = LaneLayer(LaneMap([], {}, frozenset({3}), PASS_BAND_M), None, ring_map())
    assert closed_layer(narrow, (3,)) is None


def test_a_body_on_a_junction_is_bypassed_every_arm_reaches_every_other():
    layer = layer_without_lanes(star_map())
    pm = closed_layer(layer, (0,)).plan_map
    assert pm.closed == {0}
    assert [v for v in pm.graph.neighbours(0)] == [1]  # its tether, to the lowest far end
    graph = pm.graph
    for a, b in [(1, 3), (1, 5), (3, 5)]:
        assert graph.has_edge(a, b) and graph.edge_length(a, b) == 4.0
        assert 0 not in graph.path(a, b)  # routes drive by the body, never to it
    # two bodies side by side on a corridor's cut vertices: one bypass over both
    corridor = PatrolMap("corridor", list(range(4)), np.asarray([(0.0, 0), (1, 0), (2, 0), (3, 0)],
                                                                dtype=float),
                         [(0, 1, math.nan), (1, 2, math.nan), (2, 3, math.nan)], np.ones(4),
                         np.ones(4), MapSettings())
    pm = closed_layer(layer_without_lanes(corridor), (1, 2)).plan_map
    assert pm.closed == {1, 2} and pm.graph.edge_length(0, 3) == 3.0


def test_tpuaf_plus_plans_without_the_closed_vertex():
    from tpuaf.policies.tpuaf_plus import make_plan

    pm = closed_layer(layer_without_lanes(ring_map()), (1,)).plan_map
    graph = pm.graph
    for team in [(0, 1), (1, 2, 3), (1,)]:
        plan = make_plan(pm, team, (0, 1, 3, 4), "auto", "auto")
        walks = [r.walk for r in plan.routes]
        assert all(1 not in w for w in walks), walks  # no goal at the body
        assert set().union(*walks) == {0, 2, 3, 4}  # every other vertex is planned
        for w in walks:  # each step an edge of the plan's graph
            for a, b in zip(w, w[1:] + w[:1], strict=True):
                assert a == b or b in graph.neighbours(a), (a, b, w)


def test_survivors_close_the_vertex_a_dead_robot_stands_on_and_patrol_the_rest():
    """Grid (no lane for the default robot), tpuaf_plus, 4 robots: robot 0 stalls on its
    start vertex at 0.1 s and dies there at 20 s. Before, the survivors kept trying to visit
    the vertex under its body."""
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    run = PhysicsRun(PhysicsConfig(map="grid", strategy="tpuaf_plus", robots=4, duration_s=400.0,
                                   seed=1, stall=["0@0.1"], fail=["0@20"]))
    summary = run.run()
    assert summary["lanes"] == 0  # the layer without lanes: positions are still shared
    body = run.starts[0]
    assert [access.closed for access in run.lane_access[1:]] == [{body}] * 3
    assert run.lane_access[0].closed == frozenset()  # the dead robot hears nothing
    assert body in run.recorder.closed  # the agents' VERTEX_CLOSED events
    times = run.recorder.vertex_times
    assert not [t for t in times[body] if t > 20.0]
    assert all(len([t for t in ts if t > 60.0]) >= 5 for v, ts in enumerate(times) if v != body)
    (recovery,) = summary["recovery"]
    assert recovery["worst_idleness_ratio_reachable"] < 2.5


def test_a_teammate_heard_again_reopens_the_vertices_its_body_was_thought_to_close():
    """A false loss (message loss) or a restarted robot: its vertex must not stay closed."""
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    run = PhysicsRun(PhysicsConfig(map="grid", strategy="tpuaf_plus", robots=3, duration_s=1.0,
                                   seed=1))
    run.run()
    machine, access = run.agents[1].machine, run.lane_access[1]
    x, y = run.patrol_map.positions[run.starts[0]]
    for t in (1.0, 2.0):  # robot 0 stood on its start vertex
        machine.lane_locks.on_claim(LaneClaim(0, -1, 0.0, False, t, (-1, -1), (x, y)))
    machine.on_teammate_lost_first(0)
    assert access.closed == {run.starts[0]}
    assert run.agents[1].machine.patrol_map.closed == {run.starts[0]}  # the policy's plan map
    machine.on_teammate_back(0)
    assert access.closed == frozenset() and not machine.patrol_map.closed
    assert len(machine.patrol_map.edges) == len(run.patrol_map.edges)  # its edges back


def test_a_replan_reads_every_robot_from_its_claims_its_own_too():
    """Every survivor must match parts to robots alike: its own vertex is read from the claim
    it sent, as the others read it, not from where it stands now (ctcv, 12 robots, 3 deaths:
    two survivors took one part and left 7-11 to nobody for half an hour)."""
    from types import SimpleNamespace

    from tpuaf.policies.tpuaf_plus import replan_starts

    locks = LaneLocks(0, lambda claim: None)
    locks.position = (2.1, 0.0)  # near vertex 1 when it announced
    locks.announce(10.0)
    locks.on_claim(LaneClaim(1, -1, 0.0, False, 10.0, (-1, -1), (0.0, 3.9)))  # near 6
    ctx = SimpleNamespace(lane_locks=locks, patrol_map=star_map(), n_robots=2, robot=0,
                          position=(0.2, 0.0))  # it has driven on, nearer 0, since
    assert replan_starts(ctx) == (1, 6)


def test_survivors_drive_past_a_body_on_a_cut_vertex_and_patrol_both_sides():
    """ctcv (a tree), tpuaf_plus, 3 robots: robot 1 stalls on its start vertex 12, a cut
    vertex between the two halves of the map, and dies there at 20 s. The survivors close 12
    with a bypass 10-13 through it and patrol both sides; before, closing it would have cut
    the plan in two, so 12 stayed a goal none could reach (the 17x physics recovery of
    recovery_physics.md)."""
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    run = PhysicsRun(PhysicsConfig(map=str(MAPS / "ctcv"), strategy="tpuaf_plus", robots=3,
                                   duration_s=600.0, seed=1, stall=["1@0.1"], fail=["1@20"]))
    summary = run.run()
    body = run.starts[1]
    ids = run.patrol_map.vertex_ids
    assert ids[body] == 12
    assert [access.closed for access in (run.lane_access[0], run.lane_access[2])] == [{body}] * 2
    graph = run.agents[0].machine.patrol_map.graph
    a, b = ids.index(10), ids.index(13)
    assert graph.has_edge(a, b) and body not in graph.path(a, b)  # the bypass
    times = run.recorder.vertex_times
    late = {v: len([t for t in ts if t > 200.0]) for v, ts in enumerate(times) if v != body}
    assert min(late.values()) >= 2, late  # both halves still patrolled
    assert summary["goal_failures"] <= 3
