"""Lanes (docs/LANES.md): found on hand-built occupancy maps (an aisle, a T of corridors, a T
meeting in a room, a star of dead ends, a dead end, a wide room), and the lane locks' guarantee on random request sequences (no wait cycle, one lane
per robot, every request served once messages arrive; one holder per lane when they arrive)."""

from __future__ import annotations

import math
import random
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tpuaf.maps import load_map
from tpuaf.navigation.lanes import find_lanes
from tpuaf.navigation.planner import PathPlanner
from tpuaf.team.lane_locks import SETTLE_S, LaneLocks, claim_order

from .map_folders import write_map_folder

RES = 0.05  # [m per cell]
RADIUS = 0.105  # [m] a TurtleBot3 Burger


def write_map(folder: Path, size_m: tuple[float, float], free: list[tuple],
              vertices: list[tuple[float, float]], edges: list[tuple[int, int]]) -> Path:
    """A map folder: walls everywhere but the free rectangles (x0, y0, x1, y1) [m]."""
    occ = np.ones((round(size_m[1] / RES), round(size_m[0] / RES)), dtype=bool)
    for x0, y0, x1, y1 in free:
        occ[round(y0 / RES):round(y1 / RES), round(x0 / RES):round(x1 / RES)] = False
    return write_map_folder(folder, occ, vertices, edges, res=RES, settings={
        "nominal_speed": 0.22, "goal_tolerance": 0.1, "robot_radius": RADIUS})


def aisle_map(folder: Path) -> Path:
    """Two rooms 1.6 m square joined by an aisle 0.45 m wide, 2.5 m long: vertices 0 (left
    room), 1 (aisle middle), 2 (right room), 3 and 4 (the rooms' other corners)."""
    return write_map(folder, (5.8, 1.7), [(0.05, 0.05, 1.65, 1.65), (1.6, 0.6, 4.2, 1.05),
                                          (4.15, 0.05, 5.75, 1.65)],
                     [(0.85, 0.825), (2.9, 0.825), (4.95, 0.825), (0.45, 1.3), (5.35, 1.3)],
                     [(0, 1), (1, 2), (0, 3), (2, 4)])


def lanes_of(folder: Path):
    pm = load_map(str(folder))
    lanes = find_lanes(PathPlanner(pm, RADIUS), pm)
    return [(lane.edges, lane.interior, lane.spots) for lane in lanes.lanes], lanes


def test_an_aisle_is_one_lane_with_a_waiting_spot_in_each_room(tmp_path):
    found, lanes = lanes_of(aisle_map(tmp_path / "aisle"))
    assert found == [(((0, 1), (1, 2)), (1,), (0, 2))]
    assert lanes.lane_of(2, 1) == 0 and lanes.lane_of(0, 3) == -1
    assert lanes.interior_of(1) == 0 and lanes.interior_of(0) == -1
    assert lanes.edge_width_m[(0, 3)] > lanes.pass_band_m > lanes.edge_width_m[(0, 1)]


def tee_map(folder: Path) -> Path:
    """A corridor 0.45 m wide from a left room to a right one, a stem down from its middle to a
    third room: vertices 0, 4, 6 in the rooms, 2 the junction, 1, 3, 5 in the corridors."""
    return write_map(folder, (6.0, 4.0),
                     [(0.05, 2.0, 1.65, 3.95), (1.6, 2.8, 4.4, 3.25), (4.35, 2.0, 5.95, 3.95),
                      (2.775, 1.6, 3.225, 3.0), (2.0, 0.05, 4.0, 1.65)],
                     [(0.85, 3.0), (2.2, 3.025), (3.0, 3.025), (3.8, 3.025), (5.15, 3.0),
                      (3.0, 2.2), (3.0, 0.85)],
                     [(0, 1), (1, 2), (2, 3), (3, 4), (2, 5), (5, 6)])


def test_a_t_of_one_robot_corridors_is_one_lane_through_its_tight_junction(tmp_path):
    # a robot waiting on junction 2 would shut in the robot coming out of any corridor: the
    # junction is inside the lane, whose waiting spots are the three rooms
    found, lanes = lanes_of(tee_map(tmp_path / "tee"))
    assert lanes.tight_vertices == frozenset({2})
    assert found == [(((0, 1), (1, 2), (2, 3), (2, 5), (3, 4), (5, 6)), (1, 2, 3, 5), (0, 4, 6))]
    assert "through tight junction 2" in lanes.describe([str(v) for v in range(7)])[0]


def test_a_junction_in_a_room_stays_a_waiting_spot_of_three_lanes(tmp_path):
    # the same three corridors, but they meet in a 1.6 m room: a robot waiting on its vertex
    # leaves a way round it, so each corridor is its own lane
    folder = write_map(tmp_path / "hub", (8.0, 5.6),
                       [(0.05, 3.6, 1.65, 5.55), (1.6, 4.35, 3.25, 4.8), (3.2, 3.8, 4.8, 5.4),
                        (4.75, 4.35, 6.4, 4.8), (6.35, 3.6, 7.95, 5.55), (3.775, 1.6, 4.225, 3.85),
                        (3.0, 0.05, 5.0, 1.65)],
                       [(0.85, 4.575), (2.4, 4.575), (4.0, 4.6), (5.6, 4.575), (7.15, 4.575),
                        (4.0, 2.6), (4.0, 0.85)],
                       [(0, 1), (1, 2), (2, 3), (3, 4), (2, 5), (5, 6)])
    found, lanes = lanes_of(folder)
    assert lanes.tight_vertices == frozenset()
    assert found == [(((0, 1), (1, 2)), (1,), (0, 2)), (((2, 3), (3, 4)), (3,), (2, 4)),
                     (((2, 5), (5, 6)), (5,), (2, 6))]


def star_map(folder: Path) -> Path:
    """Three dead-end corridors 0.45 m wide (east, north, west) from one junction, vertex 0:
    no room anywhere, so two robots can pass nowhere; two vertices along each corridor."""
    c, h = 3.0, 0.225
    free = [(c, c - h, c + 2.6, c + h), (c - h, c, c + h, c + 2.6), (c - 2.6, c - h, c, c + h),
            (c - h, c - h, c + h, c + h)]
    vertices = [(c, c), (c + 1.1, c), (c + 2.2, c), (c, c + 1.1), (c, c + 2.2), (c - 1.1, c),
                (c - 2.2, c)]
    return write_map(folder, (6.0, 6.0), free, vertices,
                     [(0, 1), (1, 2), (0, 3), (3, 4), (0, 5), (5, 6)])


def test_a_star_of_dead_ends_is_one_lane_without_a_waiting_spot(tmp_path):
    found, lanes = lanes_of(star_map(tmp_path / "star"))
    assert lanes.tight_vertices == frozenset({0})
    assert found == [(((0, 1), (0, 3), (0, 5), (1, 2), (3, 4), (5, 6)), (0, 1, 2, 3, 4, 5, 6),
                      ())]
    assert "robots inside it cannot pass each other" in lanes.describe(
        [str(v) for v in range(7)])[0]


def test_a_dead_end_is_a_lane_with_one_waiting_spot(tmp_path):
    folder = write_map(tmp_path / "dead_end", (4.2, 1.7),
                       [(0.05, 0.05, 1.65, 1.65), (1.6, 0.6, 4.15, 1.05)],
                       [(0.85, 0.825), (2.5, 0.825), (3.8, 0.825)], [(0, 1), (1, 2)])
    found, lanes = lanes_of(folder)
    assert found == [(((0, 1), (1, 2)), (1, 2), (0,))]
    assert "waiting spots 0" in lanes.describe(["0", "1", "2"])[0]


def test_a_wide_room_has_no_lanes(tmp_path):
    folder = write_map(tmp_path / "room", (3.0, 3.0), [(0.05, 0.05, 2.95, 2.95)],
                       [(0.8, 0.8), (2.2, 2.2), (0.8, 2.2)], [(0, 1), (1, 2)])
    found, lanes = lanes_of(folder)
    assert found == [] and not lanes


# --- the lock rule on random request sequences --------------------------------------------

class Team:
    """N robots' LaneLocks over a radio that loses, delays and reorders claims (`lossy`)."""

    def __init__(self, n: int, rng: random.Random, lossy: bool):
        self.rng, self.lossy, self.now = rng, lossy, 0.0
        self.in_flight: list = []  # (recipient, claim)
        self.locks = [LaneLocks(i, self._sender(i)) for i in range(n)]
        for lk in self.locks:
            lk.hold(-1, 0.0)

    def _sender(self, i: int):
        def send(claim) -> None:
            for j in range(len(self.locks)):
                if j != i:
                    self.in_flight.append((j, claim))
            if not self.lossy:
                self.deliver_all()
        return send

    def deliver_all(self) -> None:
        while self.in_flight:
            j, claim = self.in_flight.pop(0)
            self.locks[j].on_claim(claim)

    def deliver_some(self) -> None:
        if self.in_flight:
            j, claim = self.in_flight.pop(self.rng.randrange(len(self.in_flight)))
            if self.rng.random() > 0.3:  # 30 % lost
                self.locks[j].on_claim(claim)

    def waits_for(self) -> dict[int, set[int]]:
        """Over the robots' true claims: a waiting robot waits for those ahead of it."""
        true = [lk.mine for lk in self.locks]
        out: dict[int, set[int]] = {}
        for c in true:
            if c.lane >= 0 and not c.held:
                out[c.robot] = {d.robot for d in true if d.lane == c.lane and d.robot != c.robot
                                and claim_order(d) < claim_order(c)}
        return out


def acyclic(graph: dict[int, set[int]]) -> bool:
    state: dict[int, int] = {}

    def visit(v: int) -> bool:
        if state.get(v) == 1:
            return False
        if state.get(v) == 2:
            return True
        state[v] = 1
        ok = all(visit(w) for w in graph.get(v, ()))
        state[v] = 2
        return ok

    return all(visit(v) for v in graph)


def step(team: Team, robot: int, op: int, lane: int) -> None:
    lk = team.locks[robot]
    if op == 0 and lk.held < 0:  # at a waiting spot: ask for a lane (or keep asking)
        lk.may_enter(lk.mine.lane if lk.mine.lane >= 0 else lane, team.now)
    elif op == 1 and lk.held >= 0:  # out of the lane at its waiting spot
        lk.release(team.now)
    elif op == 2:
        team.now += 0.3
        for other in team.locks:
            other.tick(team.now)
    elif op == 3:
        team.deliver_some()


OPS = st.lists(st.tuples(st.integers(0, 3), st.integers(0, 3), st.integers(0, 2)),
               min_size=1, max_size=120)


@settings(derandomize=True, max_examples=150, deadline=None)
@given(ops=OPS, seed=st.integers(0, 1000))
def test_no_wait_cycle_one_lane_each_and_every_request_served_under_loss(ops, seed):
    team = Team(4, random.Random(seed), lossy=True)
    for robot, op, lane in ops:
        step(team, robot, op, lane)
        assert acyclic(team.waits_for())
        for lk in team.locks:  # holds at most one lane, asks only while holding none
            assert lk.mine.lane >= -1 and (lk.mine.held or lk.held == -1)
    # Then the radio works again: every waiting robot gets its lane in turn.
    team.lossy = False
    for _ in range(4 * len(team.locks) + 2):
        team.now += REANNOUNCE_STEP_S
        for lk in team.locks:
            lk.tick(team.now)
        team.deliver_all()
        for lk in team.locks:
            if lk.held >= 0:
                lk.release(team.now)
            elif lk.mine.lane >= 0:
                lk.may_enter(lk.mine.lane, team.now)
        team.deliver_all()
    assert all(lk.mine.lane == -1 for lk in team.locks)


REANNOUNCE_STEP_S = max(SETTLE_S, 1.0) + 0.1  # [s] one round of the drain


@settings(derandomize=True, max_examples=150, deadline=None)
@given(ops=OPS)
def test_one_holder_per_lane_when_claims_arrive(ops):
    team = Team(4, random.Random(0), lossy=False)
    for robot, op, lane in ops:
        step(team, robot, op, lane)
        held = [lk.held for lk in team.locks if lk.held >= 0]
        assert len(held) == len(set(held))


def test_a_dead_holders_lane_is_free_after_the_liveness_timeout():
    lost: set[int] = set()
    sent: list = []
    waiter = LaneLocks(1, sent.append, lambda r: r in lost)
    holder = LaneLocks(0, waiter.on_claim)
    holder.hold(-1, 0.0)
    assert holder.may_enter(2, 0.0) is False and holder.may_enter(2, SETTLE_S)
    assert waiter.may_enter(2, 1.0) is False
    assert waiter.may_enter(2, 1.0 + 5 * SETTLE_S) is False  # held by robot 0
    lost.add(0)  # silent for the teammate timeout: TeammateLiveness calls it lost
    assert waiter.may_enter(2, 12.0) and waiter.held == 2
    assert waiter.waits == 1 and math.isclose(waiter.wait_s, 11.0)
    assert sent[-1].held and sent[-1].lane == 2


def test_lab_lanes_are_its_aisles_and_rails_between_corners_and_junctions():
    pm = load_map("lab")
    found = find_lanes(PathPlanner(pm, RADIUS), pm)  # 0.5 m corridors everywhere
    assert [lane.spots for lane in found.lanes] == [(0, 4), (0, 5), (4, 9), (5, 9), (5, 10),
                                                     (9, 14), (10, 14)]
    assert found.narrow_vertices == frozenset({1, 2, 3, 6, 7, 8, 11, 12, 13})
    # inside a lane: the middle aisle and the left rail's middle; not at a waiting spot
    assert found.lane_at([(1.5, 1.3), (0.3, 0.8), (0.3, 1.3), (0.3, 0.3)]).tolist() == [
        3, 1, -1, -1]


def test_two_robots_entering_one_aisle_from_both_ends_keep_visiting_in_physics(tmp_path):
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    pm = load_map(str(aisle_map(tmp_path / "aisle")))
    config = PhysicsConfig(map=pm.name, strategy="cr", robots=2, seed=1, duration_s=160.0,
                           robot="burger", lanes="locks")
    run = PhysicsRun(config, patrol_map=pm)
    assert run.starts == [0, 4]  # one robot in each room: the aisle is entered from both ends
    counts: list[tuple[float, list[int]]] = []
    summary = run.run(lambda t: counts.append((t, [a.machine.visits for a in run.agents])))
    assert summary["lanes"] == 1 and summary["lane_waits"] > 0 and summary["collisions"] == 0
    for start, end in ((0.0, 80.0), (80.0, 160.0)):  # every robot visits in every window
        before = next(c for t, c in counts if t >= start)
        after = [c for t, c in counts if t <= end][-1]
        assert all(b > a for a, b in zip(before, after, strict=True)), (start, before, after)
    assert all(access.locks.entries >= 2 for access in run.lane_access)  # both used the aisle


def test_tpuaf_maps_prints_and_draws_the_lanes(tmp_path, capsys):
    from tpuaf.cli import main

    folder = aisle_map(tmp_path / "aisle")
    assert main(["maps", str(folder), "--lanes", "--json", "--picture", str(tmp_path)]) == 0
    import json

    (summary,) = json.loads(capsys.readouterr().out)
    assert [(lane["edges"], lane["waiting_spots"]) for lane in summary["lanes"]] == [
        ([[0, 1], [1, 2]], [0, 2])]
    assert (tmp_path / "aisle.png").read_bytes()[:4] == b"\x89PNG"


def test_a_dead_holders_lane_is_freed_in_physics(tmp_path):
    """Robot 0 dies holding the aisle, in a room at least 0.5 m from the aisle's mouth (a body
    in the aisle or its mouth blocks the only way between the rooms); robot 1 enters once
    robot 0 is lost (the teammate timeout) and keeps visiting. The moment is the first such
    second of the same run without the death (runs are deterministic)."""
    from tpuaf.params import LIVENESS_DEFAULTS
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    pm = load_map(str(aisle_map(tmp_path / "aisle")))

    def lane_trace(fail):
        """(t, lane robot 0 holds, lane robot 1 holds, robot 1's visits, robot 0's x [m])."""
        run = PhysicsRun(PhysicsConfig(map=pm.name, strategy="cr", robots=2, seed=1,
                                       duration_s=100.0, robot="burger", fail=fail,
                                       lanes="locks"), patrol_map=pm)
        first, second = (access.locks for access in run.lane_access)
        trace: list[tuple[float, int, int, int, float]] = []
        run.run(lambda t: trace.append((t, first.held, second.held,
                                        run.agents[1].machine.visits,
                                        float(run.world.poses()[0][0]))))
        return trace

    aisle_x = (1.6, 4.2)  # [m] (aisle_map)
    died = next(t for t, held, _, _, x in lane_trace([])
                if held == 0 and not aisle_x[0] - 0.5 <= x <= aisle_x[1] + 0.5)
    trace = lane_trace([f"0@{died:g}"])
    assert trace[-1][1] == 0  # it died holding the aisle
    granted = next(t for t, _, held, _, _ in trace if t > died and held == 0)
    assert granted >= died + LIVENESS_DEFAULTS.teammate_timeout_s
    assert trace[-1][3] > next(v for t, _, _, v, _ in trace if t >= granted)


def test_lane_claims_are_checked_as_every_team_message():
    from tpuaf.team.messages import LaneClaim, problem

    ok = LaneClaim(1, 2, 3.0, False, 3.5)
    assert problem(ok, n_robots=2, n_vertices=5, n_lanes=3) is None
    # a robot that starts inside a lane holds it from -inf: first in every queue
    assert problem(LaneClaim(1, 2, -math.inf, True, 0.0), 2, 5, 3) is None
    assert "not finite" in problem(LaneClaim(1, 2, -math.inf, False, 0.0), 2, 5, 3)
    assert "not finite" in problem(LaneClaim(1, 2, math.nan, True, 0.0), 2, 5, 3)
    assert "outside" in problem(LaneClaim(1, 3, 1.0, False, 1.0), 2, 5, 3)
    assert "unknown robot" in problem(LaneClaim(2, 0, 1.0, False, 1.0), 2, 5, 3)
    # a robot without the lane layer refuses claims on lanes it does not know
    assert "no lane layer" in problem(ok, 2, 5)
    assert problem(LaneClaim(1, -1, 1.0, False, 1.0), 2, 5) is None


def test_lane_waits_are_reported_as_events_stamped_at_the_request(tmp_path):
    """The events the ROS monitor counts (LANE_WAIT at the request, LANE_ENTER at the grant)
    give the physics runtime's own lane-wait figures."""
    from tpuaf.measure.health import FleetHealth
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun
    from tpuaf.topics import LANE_ENTER, LANE_WAIT

    pm = load_map(str(aisle_map(tmp_path / "aisle")))
    run = PhysicsRun(PhysicsConfig(map=pm.name, strategy="cr", robots=2, seed=1,
                                   duration_s=160.0, robot="burger", lanes="locks"), patrol_map=pm)
    health = FleetHealth(2, 60.0)
    events: list[tuple[int, int, int, float]] = []
    for agent in run.agents:
        emit, robot = agent.machine.emit, agent.machine.robot

        def tee(kind, vertex, from_vertex, t, emit=emit, robot=robot):
            if kind in (LANE_WAIT, LANE_ENTER):
                events.append((robot, kind, vertex, t))
                health.on_event(robot, kind, t)
            emit(kind, vertex, from_vertex, t)

        agent.machine.emit = tee
    summary = run.run()
    assert summary["lane_waits"] > 0
    assert sum(1 for e in events if e[1] == LANE_WAIT) == summary["lane_waits"]
    assert all(vertex in (0, 2) for _, _, vertex, _ in events)  # the aisle's waiting spots
    counted = health.summary(0.0, summary["duration_s"])
    assert counted["lane_waits"] == summary["lane_waits"]
    # waits still open at the end run to it in the monitor; the physics figure counts granted ones
    open_s = sum(summary["duration_s"] - s0 for w in health.lane_waits for s0, s1 in w
                 if s1 is None)
    assert counted["lane_wait_s"] == pytest.approx(summary["lane_wait_s"] + open_s, abs=1e-6)


def test_lanes_flag_of_run_and_fleet(tmp_path, capsys):
    from tpuaf.cli import main

    folder = str(aisle_map(tmp_path / "aisle"))
    # the graph runtime models no widths: a one-line error, exit 2
    assert main(["run", "--map", folder, "--robots", "2", "--duration", "60", "--lanes",
                 "locks", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "lane locks need the physics runtime (--runtime physics)" in err[0]
    assert main(["run", "--map", folder, "--robots", "2", "--duration", "120", "--runtime",
                 "physics", "--robot", "burger", "--strategy", "cr", "--seed", "1", "--lanes",
                 "locks", "--quiet", "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "lane waits" in out and "lane wait time" in out
    import json

    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["lanes"] == 1 and "lane_waits" in summary
    assert main(["fleet", "--map", folder, "--robots", "2", "--lanes", "one_way",
                 "--prepare-only", "--out", str(tmp_path / "fleet")]) == 0
    printed = capsys.readouterr().out
    assert "lanes:=one_way" in printed


def test_agent_lanes_parameter_is_checked():
    from tpuaf.params import AgentParams, NodeParamError, parse
    from tpuaf.runtimes.agent_setup import check_agent_params

    base = {"map": "lab", "robots": 2, "robot_index": 0}
    check_agent_params(parse(AgentParams, {**base, "lanes": "one_way"}, "patrol_agent"), True)
    with pytest.raises(NodeParamError, match="~lanes must be one of auto, off, locks, one_way"):
        check_agent_params(parse(AgentParams, {**base, "lanes": "oneway"}, "patrol_agent"), True)
    with pytest.raises(NodeParamError, match="needs ~navigation builtin"):
        check_agent_params(parse(AgentParams, {**base, "lanes": "locks",
                                               "navigation": "move_base"}, "patrol_agent"), True)
    for strategy in ("cgg", "msp"):  # their tours follow the arcs too
        check_agent_params(parse(AgentParams, {**base, "lanes": "one_way", "strategy": strategy},
                                 "patrol_agent"), True)


def test_the_agents_default_lane_mode_is_auto():
    """auto: one_way where lanes can be found (built-in navigation on planned paths), off for
    msp (params.AUTO_LANES_OFF_STRATEGIES) and for move_base (no planned paths to find lanes on)."""
    from tpuaf.params import AgentParams, parse
    from tpuaf.runtimes.agent_setup import agent_lane_mode, check_agent_params

    base = {"map": "lab", "robots": 2, "robot_index": 0}
    for extra, mode in (({}, "one_way"), ({"strategy": "msp"}, "off"),
                        ({"navigation": "move_base"}, "off"), ({"global_planner": False}, "off"),
                        ({"lanes": "locks"}, "locks"), ({"lanes": "off"}, "off")):
        p = parse(AgentParams, {**base, **extra}, "patrol_agent")
        check_agent_params(p, True)
        assert agent_lane_mode(p) == mode, extra


def test_the_graph_runtime_holds_one_robot_at_a_time_on_the_lanes_narrow_vertices():
    """With lanes the graph runtime's engine gets the lane map's narrow vertices and the
    headway (C++ behaviour: test_engine.cpp); its config.yaml says so; without lanes, none."""
    from tpuaf.robot.lanes import narrow_headway_s
    from tpuaf.runtimes.config import RunConfig
    from tpuaf.runtimes.graph import make_run

    run = make_run(RunConfig(map="lab", strategy="tpuaf", robots=4, duration_s=120, seed=1,
                             robot="burger", lanes="one_way"))
    narrow = run.effective_config()["narrow_vertices"]
    ids = run.patrol_map.vertex_ids
    assert narrow["vertices"] == [ids[v] for v in sorted(run.lanes.lane_map.narrow_vertices)]
    assert len(narrow["vertices"]) == 9  # the lab's rails between corners and junctions
    assert narrow["headway_s"] == pytest.approx(narrow_headway_s(0.105, 0.1), abs=1e-3)
    assert run.run()["visits"] > 0
    plain = make_run(RunConfig(map="lab", strategy="tpuaf", robots=4, duration_s=120, seed=1,
                               robot="burger", lanes="off"))
    assert "narrow_vertices" not in plain.effective_config()


def test_a_death_on_a_one_way_plan_is_summarised():
    """Regression: the recovery's ideal (reference_tours) on a one-way plan, which has no
    partition into parts a robot can tour, raised ValueError (a traceback from `tpuaf run`)."""
    from tpuaf.maps.tours import reference_tours
    from tpuaf.runtimes.config import RunConfig
    from tpuaf.runtimes.graph import make_run

    run = make_run(RunConfig(map="lab", strategy="tpuaf", robots=4, duration_s=400, seed=2,
                             robot="burger", lanes="one_way", fail=[[0, 200]]))
    tours = reference_tours(run.patrol_map, 3, 0.1)
    assert tours["partition"]["worst_idleness_s"] == math.inf
    assert tours["better"] == "cyclic" and math.isfinite(tours["best_worst_idleness_s"])
    (after,) = run.run()["recovery"]
    assert math.isfinite(after["ideal_worst_idleness_survivors_s"])
