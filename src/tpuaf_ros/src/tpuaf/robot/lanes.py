"""A robot's lane layer: the map's lanes (navigation/lanes.py) with its lock table
(team/lane_locks.py), as its navigator asks for them (docs/LANES.md).

The navigator asks `may_start(u, v, now)` before every leg u -> v that starts at a vertex and
`arrive(u, now)` at a route's goal: reaching a vertex outside the held lane (a waiting spot)
releases it; a leg into a lane not held asks for the lane and waits at u until it is granted.
With one-way lanes (navigation/one_way.py) only the lanes that stay two-way (`locked`: the
bridges) are locked; a one-way lane is entered without a lock (robots in it only follow), and
the robot whose leg drives it holds it off its route too (`driven`, `allowed`).

A robot that dies inside a lane blocks it with its body. Its last claim says which edge it drove
(team/lane_locks.py, `lost_in`); when the liveness rule reports it lost, every survivor drops
that edge from its plan (`blocked_layer`: the rest of the lane becomes a dead end, locked, and
the one-way lanes keep their direction where the plan stays strongly connected), re-routes and
re-times its policy on it. An edge whose loss would cut the plan in two is not dropped (the far
side would be unreachable): the lane's lock is freed as before (docs/LANES.md). A teammate lost
standing still outside a lane (its last two claims, about a second apart, both near a vertex)
or just off a vertex (its latest Intention left it after its last claim) closes the vertices
its body stands on (`body_vertices`, `closed_layer`: each keeps one edge, as above; a cut
vertex robots can pass gets a bypass first, `_bypassed`; none when closing would still cut
the plan in two). The robots announce where they are on maps without a lane too, so that
this works there (`lane_layer(..., without_lanes=True)`).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from tpuaf.navigation.lanes import Lane, LaneMap, find_lanes
from tpuaf.navigation.one_way import Orientation, orient_lanes
from tpuaf.params import CONTROLLER_DEFAULTS
from tpuaf.robot.body_sight import sight
from tpuaf.team.lane_locks import LaneLocks
from tpuaf.team.messages import LaneClaim
from tpuaf.topics import LANE_ENTER, LANE_WAIT, VERTEX_CLOSED


@dataclass(frozen=True)
class LaneLayer:
    """The team's lanes on one map and footprint: the lane map, the one-way orientation (None:
    locks only) and the plan's map, whose graph follows the one-way arcs."""

    lane_map: LaneMap
    orientation: Orientation | None
    plan_map: Any

    @property
    def locked(self) -> frozenset[int] | None:
        """The lanes entered holding a lock (None: all)."""
        return self.orientation.locked if self.orientation is not None else None

    @property
    def one_way_count(self) -> int:
        """The lanes driven one way."""
        return len(self.orientation.chains) if self.orientation is not None else 0

    def describe(self) -> str:
        """'K lane(s)[, M one-way]'."""
        one_way = f", {self.one_way_count} one-way" if self.orientation is not None else ""
        return f"{len(self.lane_map.lanes)} lane(s){one_way}"


def lane_layer(planner: Any, world_map: Any, plan_map: Any, one_way: bool,
               without_lanes: bool = False) -> LaneLayer | None:
    """The lane layer of every runtime (physics, ROS agents): the lanes of `world_map` for the
    footprint of `planner`, oriented when `one_way`; when the map has no lane, None (the run
    is then the run without the layer), or with `without_lanes` a layer of no lane (the
    robots still announce where they are, so that a lost teammate's body closes the vertices
    it stands on: `body_vertices`). Every robot of one model computes the same lanes (their
    indices are shared in LaneClaim)."""
    lane_map = find_lanes(planner, world_map)
    if not lane_map.lanes:
        return LaneLayer(lane_map, None, plan_map) if without_lanes else None
    orientation = orient_lanes(lane_map, plan_map) if one_way else None
    if orientation is not None and orientation.chains:
        plan_map = replace(plan_map, one_way=tuple(orientation.arcs))
    return LaneLayer(lane_map, orientation, plan_map)


def narrow_headway_s(radius_m: float, speed_mps: float) -> float:
    """[s] The least time between two robots passing one narrow vertex in the graph runtime
    (EngineConfig.narrow_headway_s): a body length and the controller's safety margin at
    cruise speed."""
    return (2.0 * radius_m + CONTROLLER_DEFAULTS.safety_margin) / speed_mps


BLOCK_LOST_BODIES = True  # a lost teammate's body blocks the lane edge it drove (False: the
# lane's lock is only freed, as before; benchmarks/bench_lane_death.py compares the two)
_BLOCKED: dict[tuple, tuple[LaneLayer, LaneLayer | None]] = {}


def body_reach_m(layer: LaneLayer) -> float:
    """[m] A lost teammate's body this near a vertex (its last known position) keeps the
    others from reaching it: two robots side by side plus the visit radius."""
    return layer.lane_map.pass_band_m + float(layer.plan_map.visit_radius_m)


def body_blocks(layer: LaneLayer, claim: LaneClaim) -> tuple[tuple[int, int], tuple[int, ...]]:
    """Where a lost teammate's body lies, from its last claim: the edge of its leg, and the
    leg's end vertices it stands too near for a robot to reach (closer than two robots side
    by side plus the visit radius [m]; none when the claim has no position)."""
    u, v = claim.leg
    x, y = claim.position
    positions = np.asarray(layer.plan_map.positions, dtype=float)
    reach = body_reach_m(layer)
    occupied = tuple(sorted(w for w in {u, v}
                            if math.hypot(positions[w][0] - x, positions[w][1] - y) < reach))
    return (min(u, v), max(u, v)), occupied


STANDING_M = 0.1  # [m] a teammate that moved no more between its last two claims stood
CLAIM_SLACK_S = 0.2  # [s] a claim goes out on the first control tick (10 Hz) once it is due


def body_vertices(layer: LaneLayer, positions: list[tuple[float, float]],
                  goal: int | None = None, left: tuple[int, float] | None = None,
                  moved_m: float = 0.0) -> tuple[int, ...]:
    """The vertices a lost teammate's body stands too near to reach, from where it announced
    it was (`LaneLocks.last_positions` [m]), the goal it was heading to (its latest
    Intention; None: not known) and `left`: (the vertex that Intention left, the most it can
    have driven since [m]) when the Intention is newer than its last position (None: not).
    Near is within `body_reach_m`. A vertex near both of its last two positions when they are
    at most STANDING_M apart (it stood there, about a second apart), nearer still by
    `moved_m` [m] to the last (how far it may have driven off since: `_heading`); its goal
    when near its last position (it drove on toward it, no farther: it lies between the two);
    the vertex it left when the visit radius plus the drive since is within reach (it died
    just after leaving it). Else none: a robot that died driving lies on an edge
    (`body_blocks`)."""
    if not positions:
        return ()
    xy = np.asarray(layer.plan_map.positions, dtype=float)
    reach = body_reach_m(layer)
    away = [np.hypot(xy[:, 0] - x, xy[:, 1] - y) for x, y in positions[-2:]]  # [m]
    covered = np.zeros(len(xy), dtype=bool)
    if len(positions) >= 2 and math.dist(positions[-2], positions[-1]) <= STANDING_M:
        covered = (away[0] < reach) & (away[1] < reach - moved_m)
    if goal is not None and 0 <= goal < len(xy) and away[-1][goal] < reach:
        covered[goal] = True
    if left is not None and 0 <= left[0] < len(xy) and (
            float(layer.plan_map.visit_radius_m) + left[1] < reach):
        covered[left[0]] = True
    return tuple(int(v) for v in np.flatnonzero(covered) if int(v) not in layer.plan_map.closed)


def closed_layer(layer: LaneLayer, occupied: tuple[int, ...]) -> LaneLayer | None:
    """`layer` with the vertices `occupied` closed (a dead robot's body on them): each keeps
    one edge, its tether, as in `blocked_layer` (plans skip it, goals there fail at once,
    runtimes/agent.py, and no route passes through it). A body on a cut vertex robots can pass
    gets a bypass first (`_bypassed`): routes drive by it, never to it. None when there is
    none, or when the other vertices would no longer all reach each other (a body on a narrow
    cut vertex: the goals there keep failing). The same on every robot (cached)."""
    key = (id(layer), "closed", tuple(sorted(occupied)))
    if key in _BLOCKED:
        return _BLOCKED[key][1]
    result = None
    if occupied:
        plan = _bypassed(layer, replace(layer.plan_map, one_way=()), tuple(occupied))
        pairs = [(min(int(a), int(b)), max(int(a), int(b))) for a, b, _ in plan.edges]
        cut = _cut_edges(plan, pairs, (-1, -1), tuple(occupied))  # no edge of its own
        if cut is not None:
            plan = replace(plan, closed=plan.closed | frozenset(int(v) for v in occupied))
            result = _without(layer, plan, pairs, cut)
    _BLOCKED[key] = (layer, result)
    return result


def _bypassed(layer: LaneLayer, plan, occupied: tuple[int, ...]):
    """`plan` with a bypass round each body on a cut vertex that robots can pass (not one of
    the lane map's narrow vertices): an edge between two of its open neighbours as long as
    the way between them through the covered vertices [m], where that is shorter than every
    way round them. The vertex then hangs on its tether like any other closed one: routes
    drive past the body on the bypass legs (the planner's path, round it on the laser), and
    no goal is set on it."""
    n = plan.num_vertices
    pairs = [(min(int(a), int(b)), max(int(a), int(b))) for a, b, _ in plan.edges]
    covered = set(occupied)
    passable = {v for v in covered if v not in layer.lane_map.narrow_vertices
                and not _connected(n, [p for p in pairs if v not in p], {v})}
    if not passable:
        return plan
    graph = plan.graph
    adjacency: dict[int, list[tuple[int, float]]] = {}
    for a, b in pairs:
        length = float(graph.edge_length(a, b))
        adjacency.setdefault(a, []).append((b, length))
        adjacency.setdefault(b, []).append((a, length))
    bypass = []
    for source in sorted({w for v in passable for w, _ in adjacency[v] if w not in covered}):
        through = _ways(adjacency, source, lambda u: u in passable)
        around = _ways(adjacency, source, lambda u: u not in covered)
        bypass += [(source, w, d) for w, d in sorted(through.items())
                   if w > source and w not in covered and d < around.get(w, math.inf) - 1e-9]
    return replace(plan, edges=[*plan.edges, *bypass])


def _ways(adjacency: dict[int, list[tuple[int, float]]], source: int,
          via: Callable[[int], bool]) -> dict[int, float]:
    """Shortest lengths [m] from `source` to every vertex reached through vertices `via`
    alone (Dijkstra; the ends themselves may be any)."""
    best, frontier = {source: 0.0}, [(0.0, source)]
    while frontier:
        d, u = heapq.heappop(frontier)
        if d > best[u] or (u != source and not via(u)):
            continue
        for w, length in adjacency.get(u, ()):
            if d + length < best.get(w, math.inf):
                best[w] = d + length
                heapq.heappush(frontier, (d + length, w))
    return best


def blocked_layer(layer: LaneLayer, edge: tuple[int, int],
                  occupied: tuple[int, ...] = ()) -> LaneLayer | None:
    """`layer` with the edge u-v blocked (a dead robot's body on it): the plan's graph without
    it, the lanes without it (the rest of that lane is a dead end: a bridge, locked) and
    re-oriented keeping their directions where they can (one_way.orient_lanes). A vertex of
    `occupied` (the body too near it to reach) keeps one edge, to its nearest neighbour, so
    that no route passes through it (the plan's graph stays connected; its plan map lists it
    `closed`: plans skip it, goals there fail at once, runtimes/agent.py). None when the edge
    is not in a lane or dropping it would leave some vertex unreachable (then occupied
    vertices keep their edges if that would). The same on every robot (cached per layer, edge
    and occupied vertices)."""
    u, v = min(edge), max(edge)
    key = (id(layer), (u, v), tuple(occupied))
    if key in _BLOCKED:
        return _BLOCKED[key][1]
    plan = replace(layer.plan_map, one_way=())
    pairs = [(min(int(a), int(b)), max(int(a), int(b))) for a, b, _ in plan.edges]
    result = None
    if layer.lane_map.lane_of(u, v) >= 0:
        closed = tuple(occupied)
        cut = _cut_edges(plan, pairs, (u, v), closed)
        if cut is None and closed:
            closed = ()
            cut = _cut_edges(plan, pairs, (u, v), closed)
        if cut is not None:
            plan = replace(plan, closed=plan.closed | frozenset(int(w) for w in closed))
            result = _without(layer, plan, pairs, cut)
    _BLOCKED[key] = (layer, result)
    return result


def _cut_edges(plan, pairs: list[tuple[int, int]], edge: tuple[int, int],
               occupied: tuple[int, ...]) -> set[tuple[int, int]] | None:
    """The edges to drop: `edge`, and every edge of an occupied vertex but its tether (the
    shortest, then the lowest far end); None when the other vertices would not all reach
    each other."""
    cut = {edge} | {pair for pair in pairs if set(pair) & set(occupied)}
    if not _connected(plan.num_vertices, [p for p in pairs if p not in cut], set(occupied)):
        return None
    graph = plan.graph
    for w in occupied:
        ties = [p for p in pairs if w in p and p != edge and not set(p) - {w} & set(occupied)]
        if ties:
            cut.discard(min(ties, key=lambda p: (graph.edge_length(*p), sum(p) - w)))
        elif not any(w in p for p in pairs if p not in cut):
            return None  # no tether: w would be cut off (a PatrolGraph is connected)
    return cut


def _without(layer: LaneLayer, plan, pairs: list[tuple[int, int]],
             cut: set[tuple[int, int]]) -> LaneLayer:
    """The layer on `plan` without the edges `cut` (lanes keep their indices: claims name
    them; a lane cut away has no edge left)."""
    plan = replace(plan, edges=[e for e, pair in zip(plan.edges, pairs, strict=True)
                                if pair not in cut])
    old = layer.lane_map
    lanes = [Lane(lane.index, tuple(e for e in lane.edges if e not in cut), lane.interior,
                  lane.spots, lane.min_width_m) for lane in old.lanes]
    lane_map = replace(old, lanes=lanes, edge_width_m={
        e: w for e, w in old.edge_width_m.items() if e not in cut})
    orientation = None
    if layer.orientation is not None:
        orientation = orient_lanes(lane_map, plan, keep=layer.orientation)
        if orientation.chains:
            plan = replace(plan, one_way=tuple(orientation.arcs))
    return LaneLayer(lane_map, orientation, plan)


def _connected(n: int, edges: list[tuple[int, int]], aside: set[int]) -> bool:
    """Do the vertices not `aside` all reach each other along `edges`?"""
    adjacency: dict[int, list[int]] = {w: [] for w in range(n)}
    for a, b in edges:
        adjacency[a].append(b)
        adjacency[b].append(a)
    rest = [w for w in range(n) if w not in aside]
    if not rest:
        return False
    seen, stack = {rest[0]}, [rest[0]]
    while stack:
        for w in adjacency[stack.pop()]:
            if w not in seen:
                seen.add(w)
                stack.append(w)
    return len(seen) == len(rest)


def claims_current(locks: LaneLocks, robot: int, heard_s: float) -> bool:
    """Is teammate `robot`'s last claim its last word: heard (`heard_s` [s], a heartbeat too)
    no later than its next claim was due (+ CLAIM_SLACK_S)? Else that claim was lost (or came
    late) and the teammate may have lived on and moved: its body is placed by nothing."""
    claim = locks.claims.get(int(robot))
    return claim is not None and heard_s <= claim.time + locks.reannounce_s + CLAIM_SLACK_S


def _heading(machine: Any, locks: LaneLocks, robot: int, max_speed: float,
             turn_s: float = 0.0,
             current: bool = True) -> tuple[int | None, tuple[int, float] | None, float]:
    """(goal, left, moved_m) of `body_vertices` for lost teammate `robot`, from its latest
    Intention and its last claims. Its next claim, due a re-announcement after the last,
    never came: it died before. When the Intention is newer than the last claim, `left` is
    the vertex it left and the most it drove since its departure at `max_speed` [m/s]; when
    it stood at its last two claims and its departure (the Intention's expected arrival -
    travel time) falls after the first of them less `turn_s` [s] (a turn on the spot, which
    moves it no farther), `moved_m` is the most it drove from its last position since (it
    dwelt or turned, then may have left), else 0 (held there long: blocked; or still dwelling
    at its death). Not `current` (`claims_current`: its last claim was not its last word):
    it may have lived on and moved, and is not placed at all (no goal, no `left`, `moved_m`
    inf). A Visit newer than the latest Intention (`_after_lost_intention`): the Intention
    of its next leg was lost, and it may have left any time since it arrived."""
    intent = machine.teammate_intentions.get(robot)
    claim = locks.claims.get(int(robot))
    if claim is not None and not current:
        return None, None, math.inf  # where it went since its last claim is unknown
    visit = machine.teammate_visits.get(robot)
    if claim is not None and visit is not None and intent is not None and (
            visit.time > intent.time):  # (strategies that send no Intention: below)
        return _after_lost_intention(visit, claim.time, claim.time + locks.reannounce_s,
                                     max_speed)
    if intent is None:
        return None, None, 0.0
    if claim is None:
        return intent.vertex, None, 0.0
    due = claim.time + locks.reannounce_s  # [s] its next claim
    departure = intent.expected_arrival - intent.travel_time  # [s] (after a dwell: later)
    if intent.time > claim.time and intent.from_vertex >= 0:
        drive = max_speed * max(0.0, due - max(intent.time, departure))
        return intent.vertex, (intent.from_vertex, drive), 0.0
    before = locks.previous.get(int(robot))
    moved = 0.0
    if before is not None and before.time - turn_s < departure < due:
        moved = max_speed * (due - max(departure, claim.time))
    return intent.vertex, None, moved


def _after_lost_intention(visit: Any, claimed_s: float, due_s: float,
                          max_speed: float) -> tuple[int | None, tuple[int, float] | None, float]:
    """`_heading` for a teammate whose latest Visit (at `visit.vertex`, heading to
    `visit.next_vertex`) is newer than its latest Intention heard: its leg's Intention was
    lost (tpuaf and tpuaf_plus send both at each arrival), so its departure is not known.
    Arrived after its last claim (`claimed_s` [s]): it left that vertex at the earliest then,
    `left` drove the most since until its next claim was due (`due_s` [s]). Arrived before:
    it may have left right after that claim, `moved_m` the most it drove since."""
    nxt = visit.next_vertex if visit.next_vertex not in (-1, visit.vertex) else None
    if visit.time > claimed_s:
        return nxt, (int(visit.vertex), max_speed * max(0.0, due_s - visit.time)), 0.0
    return nxt, None, max_speed * max(0.0, due_s - claimed_s)


class LaneAccess:
    """One robot's lanes and locks (see the module docstring)."""

    def __init__(self, lane_map: LaneMap, locks: LaneLocks,
                 locked: frozenset[int] | None = None,
                 report: Callable[[int, int, float], None] | None = None):
        self.locks = locks
        # report(kind, waiting spot, t [s]): LANE_WAIT (stamped at the request) and LANE_ENTER
        self.report = report
        self.now = 0.0  # [s] the last time asked
        self._set_map(lane_map, locked)
        self.started = False  # start_at called: the start's lane is held
        self.blocked: list[tuple[int, int]] = []  # edges dropped: a lost teammate's body on them
        # vertices cut off (a lost teammate's body too near them): the plan map's `closed`
        self.closed: frozenset[int] = frozenset()
        # look(pose, laser points in the robot frame): judge the closed vertices in view
        # (attach_lanes, robot/body_sight.py); None: not judged
        self.look: Callable[[tuple[float, float, float], np.ndarray], None] | None = None

    def start_at(self, vertex: int, now: float) -> None:
        """The robot starts at `vertex` [index] at run time `now` [s]: inside a locked lane, it
        holds that lane at once (first in its queue)."""
        self.started = True
        inside = self.lane_map.interior_of(vertex)
        self.locks.hold(inside if inside in self.locked else -1, now)

    def locked_lane(self, u: int, v: int) -> int:
        """The locked lane of the edge u-v, -1 when none (wide, or a one-way lane)."""
        lane = self.lane_map.lane_of(u, v)
        return lane if lane in self.locked else -1

    def enters(self, prev: int | None, u: int, nxt: int | None) -> bool:
        """Whether the route ... prev -> u -> nxt enters a lane at u (u is then a waiting spot
        the robot must reach, not just pass near)."""
        if nxt is None:
            return False
        lane = self.locked_lane(u, nxt)
        return lane >= 0 and (prev is None or self.lane_map.lane_of(prev, u) != lane)

    def arrive(self, u: int, now: float) -> None:
        """At vertex u: outside the held lane, release it."""
        self.now = now
        held = self.locks.held
        if held >= 0 and self.lane_map.interior_of(u) != held:
            self.locks.release(now)

    def may_start(self, u: int, v: int, now: float) -> bool:
        """May the robot, at vertex u, drive the edge u -> v now? (Asks for its lane.)"""
        self.arrive(u, now)
        lane = self.locked_lane(u, v)
        if lane < 0:
            one_way = self.lane_map.lane_of(u, v)
            if one_way >= 0:  # entered without a lock: announced, as where we are
                self.locks.drive(one_way, (u, v), now)
            return True
        locks = self.locks
        waits, waited = locks.waits, locks.wait_s
        granted = locks.may_enter(lane, now)
        if self.report is not None:
            if locks.waits > waits:
                self.report(LANE_WAIT, u, locks.mine.stamp)
            if locks.wait_s > waited:
                self.report(LANE_ENTER, u, now)
        if granted:
            locks.drive(lane, (u, v), now)
        return granted

    def queued_behind_waiter(self, u: int, v: int) -> bool:
        """Is another robot waiting for the lane of u -> v ahead of us (not only a holder)?"""
        lane = self.locked_lane(u, v)
        for claim in self.locks.queue(lane):
            if claim.robot == self.locks.robot:
                return False
            if not claim.held:
                return True
        return False

    def follows(self, u: int | None, v: int, points) -> bool:
        """On the leg u -> v of a one-way lane, is what holds us (map-frame points (k, 2) [m])
        inside that lane, i.e. a robot ahead driving the same way (wait behind it: no way
        round, no giving way)?"""
        lane = -1 if u is None else self.lane_map.lane_of(u, v)
        if lane < 0 or lane in self.locked:
            return False
        return bool((self.lane_map.lane_at(points) == lane).any())

    def driven(self, u: int | None, v: int | None) -> int:
        """The one-way lane of the leg u -> v when the leg drives it along its arc, -1 when
        none: the robot holds the one-way lane it drives (docs/LANES.md, section 2b)."""
        if u is None or v is None or not self.one_way:
            return -1
        lane = self.lane_map.lane_of(u, v)
        return lane if lane >= 0 and lane not in self.locked else -1

    def allowed(self, points, driven: int = -1) -> np.ndarray:
        """Mask of map-frame points (k, 2) [m] outside every lane but the one held and the
        one-way lane `driven` (the lane of the robot's leg, -1: none)."""
        lanes = self.lane_map.lane_at(points)
        return (lanes < 0) | (lanes == self.locks.held) | ((lanes == driven) & (driven >= 0))

    def _set_map(self, lane_map: LaneMap, locked: frozenset[int] | None) -> None:
        """The lanes, and those entered holding a lock (None: every lane)."""
        self.lane_map = lane_map
        self.locked = (frozenset(lane.index for lane in lane_map.lanes) if locked is None
                       else frozenset(locked))
        self.one_way = len(self.locked) < len(lane_map.lanes)  # some lanes driven one way

    @property
    def has_lanes(self) -> bool:
        """Whether the map has any lane (a layer without lanes only shares positions)."""
        return bool(self.lane_map.lanes)

    def use(self, lane_map: LaneMap, locked: frozenset[int] | None, position, now: float) -> None:
        """Drive on another lane map from now on (a lane blocked): inside a lane that is now
        locked, the robot holds it at once (it drives out, or on, as at the start)."""
        self._set_map(lane_map, locked)
        inside = int(lane_map.lane_at(position)[0])
        if inside in self.locked and self.locks.held != inside:
            self.locks.hold(inside, now)

    def withdraw(self) -> None:
        """The route changed: a request not granted yet is dropped (a held lane is kept)."""
        if self.locks.mine.lane >= 0 and not self.locks.mine.held:
            self.locks.release(self.now)

    def tick(self, now: float, position: tuple[float, float] | None = None) -> None:
        """Re-announce the claim when due, with the robot's `position` [m]."""
        self.now = now
        if position is not None:
            self.locks.position = (float(position[0]), float(position[1]))
        self.locks.tick(now)


def attach_lanes(agent: Any, layer: LaneLayer, start_vertex: int | None) -> LaneAccess:
    """Give an `AgentRuntime` the team's lane `layer`: its machine hears the claims, its
    navigator asks at lane entries, its ticks re-announce the claim; a robot that starts inside
    a locked lane holds it (`start_vertex` [index]; None: not known yet, then when the runtime
    begins). A teammate lost inside a lane then blocks the edge it was on (`blocked_layer`)."""
    machine = agent.machine

    def send(claim: LaneClaim) -> None:
        if machine.alive:
            machine.driver.transmit(machine.robot, claim)

    def report(kind: int, spot: int, t: float) -> None:
        if machine.alive:
            machine.emit(kind, int(spot), -1, float(t))

    locks = LaneLocks(machine.robot, send, lambda r: r in machine.liveness.lost)
    access = LaneAccess(layer.lane_map, locks, layer.locked, report)
    machine.lane_locks = locks
    agent.navigator.lanes = access
    if BLOCK_LOST_BODIES:
        config = agent.navigator.controller.config
        max_speed = float(config.max_linear_speed)  # [m/s]
        turn_s = math.pi / float(config.max_angular_speed)  # [s] a half turn on the spot
        current = [layer]
        # teammate -> (the layer before the vertices its body stood on were closed, after)
        standing: dict[int, tuple[LaneLayer, LaneLayer]] = {}

        def use(new: LaneLayer) -> None:
            current[0] = new
            access.closed = new.plan_map.closed
            access.use(new.lane_map, new.locked, agent.position, machine.now)
            agent.replan(new.plan_map)

        def teammate_lost(robot: int) -> None:
            latest = claims_current(locks, robot, machine.liveness.last_heard_s(robot))
            claim = locks.lost_in(robot) if latest else None
            new = None
            if claim is not None:  # lost inside a lane: its edge blocked
                edge, occupied = body_blocks(current[0], claim)
                new = blocked_layer(current[0], edge, occupied)
                if new is not None:
                    access.blocked.append(edge)
            if new is None:  # lost standing elsewhere: the vertices it stands on closed
                occupied = body_vertices(current[0], locks.last_positions(robot),
                                         *_heading(machine, locks, robot, max_speed, turn_s,
                                                   latest))
                new = closed_layer(current[0], occupied)
                if new is not None:
                    standing[robot] = (current[0], new)
            if new is None:
                return
            for vertex in sorted(new.plan_map.closed - access.closed):
                report(VERTEX_CLOSED, vertex, machine.now)  # the monitor's reachable recovery
            use(new)

        def teammate_back(robot: int) -> None:
            before, after = standing.pop(robot, (None, None))
            if after is not None and current[0] is after:  # nothing changed since: reopen
                use(before)  # (the monitor keeps them closed: docs/LANES.md)

        machine.on_teammate_lost_first = teammate_lost
        machine.on_teammate_back = teammate_back
        planner = getattr(agent.navigator, "planner", None)
        if planner is not None:
            access.look = sight(planner, standing, current, use, float(config.robot_radius),
                                float(config.safety_margin))
    if start_vertex is not None:
        access.start_at(start_vertex, 0.0)
    return access

