"""TPUAF+ (beyond the paper): a shared tour plan, online even spacing, and fault repair.

Rule (docs/STRATEGIES.md has the why and the measurements):

1. Plan. Every robot computes the same plan from the map and the team it believes alive
   (deterministic, no messages): either the shortest closed walk found through all vertices
   with all robots on it (`tours.cyclic_tour`), or a balanced partition into k parts (every
   k = 2..N on graphs up to SMALL_GRAPH vertices, else k = N) with one closed walk per part
   (`tours.partition_tours`), whichever has the lower predicted steady-state worst
   idleness at nominal speed (`tours.walk_idleness`; a tie within 2 % goes to the lower
   predicted mean X, TPUAF's uncertainty model integrated over the plan's visit gaps).
2. Start. From every robot's start vertex, all robots compute the same start schedule
   (`start_schedule`): evenly spaced virtual slots move along each walk and pick the robots up;
   each robot drives the shortest route (serving the most uncertain vertices, step 6) to the
   walk vertex where its slot passes soonest after it can be there, and leaves with it; the
   slot phase and robot-to-slot matching are those under which every walk vertex is first
   visited soonest. Until it leaves, a mate counts as on its slot, and after that while its
   latest message is older (a delayed or lost departure message).
3. Spacing. After that, on reaching each walk vertex a robot estimates where its walk mates
   are (arc position from their latest timed message: departure vertex + departure time,
   extrapolated at nominal speed; messages carry the sender's clock, so delay does not bias
   them) and dwells `gain * (gap_behind - gap_ahead) / (2 v)` when the mate behind is farther
   than the one ahead (a robot cannot speed up; the one ahead waits). Gaps converge to L / m.
4. Dwelling. A dwelling robot re-visits its vertex every `dwell_revisit_s` (goal = its own
   vertex: it is physically there) and re-announces its departure time (a heartbeat).
5. Faults. A mate not heard from for `silence_timeout_s` is presumed dead; every survivor
   then recomputes the plan for the survivors (step 1); a cycle re-spaces at once (each
   survivor dwells its share of the survivors' even spacing, capped so that no vertex ahead
   waits beyond L / (m v); `_respace_target`, `_idle_room`), then by step 3;
   a partition is merged or recomputed and each survivor drives to its new part (several
   robots new to one walk enter it where the start schedule, from where each stood when the
   team changed, puts their slots: `_transition_entries`). A presumed-dead robot
   that speaks again rejoins. Stale information never blocks a vertex: nothing is reserved;
   an old message only places a mate on its walk, and it expires with the silence timeout.
6. Repair. While driving to a (new) part, the robot chooses among the neighbours on a
   shortest path the one of maximal TPUAF utility (Eq. 13: X^ * I / dt), from the same shared
   visit knowledge as TPUAF.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
import tpuaf_core

from tpuaf.maps import tours
from tpuaf.policies.base import Parameter, Policy, RobotContext, register
from tpuaf.policies.tpuaf import new_knowledge
from tpuaf.team.messages import Intention, Visit

_EPS = 1e-6
SMALL_GRAPH = 60  # vertices: up to this, partitions into every k = 2..N are tried
FRESH_MARGIN = 1.15  # after a loss, merge unless a fresh plan's worst is lower by more than this
STAY_S = 1.0  # [s] the runtimes' dwell for a goal equal to the current vertex (runtimes.graph)
INTENTION_TIMEOUT_S = 30.0  # [s] its visit knowledge drops intentions this old (it hears none)


def _positive(x) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and x > 0 and x < 1e9


def _non_negative(x) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and 0 <= x < 1e9


@dataclass(frozen=True)
class Route:
    """One closed walk of the plan and the robots that share it."""

    walk: tuple[int, ...]  # vertex indices; consecutive entries adjacent, last -> first too
    arc: tuple[float, ...]  # [m] arc position of each walk entry from walk[0]
    length: float  # [m] L
    robots: tuple[int, ...]  # robot indices on this walk, sorted


@dataclass(frozen=True)
class Plan:
    kind: str  # "cycle" or "partition"
    routes: tuple[Route, ...]
    route_of: dict  # robot -> route index
    worst_s: float  # predicted steady-state worst idleness [s]
    # Start schedule (only for the full team): robot -> (entry walk index, departure time [s]).
    schedule: dict


def _route(graph, walk, robots) -> Route:
    arc, s = [], 0.0
    for i, v in enumerate(walk):
        arc.append(s)
        if len(walk) > 1:
            s += graph.edge_length(v, walk[(i + 1) % len(walk)])
    return Route(tuple(int(v) for v in walk), tuple(arc), float(s), tuple(sorted(robots)))


def predicted_mean_uncertainty(patrol_map, walk, n_robots: int, speed: float) -> float:
    """Mean over the walk's vertices of the steady-state time-mean X when `n_robots` evenly
    spaced robots drive it at `speed` [m/s]: Eq. 2 integrated over each vertex's visit gaps,
    one visit = one straight pass (as TPUAF's knowledge applies it)."""
    graph = patrol_map.graph
    info = tours.walk_idleness(graph, list(walk), n_robots, speed)
    model = patrol_map.uncertainty_model()
    s = patrol_map.settings
    pass_c, pass_t = 8.0 * s.sensing_peak / 15.0, 2.0 * s.sensing_radius / s.nominal_speed
    total = []
    for v, gap in info["per_vertex_worst"].items():
        c = float(patrol_map.importance[v])
        x = 0.0
        for _ in range(3):  # a few periods to approach the cycle's fixed point
            x = model.evolve(model.evolve(x, c, gap), c - pass_c, pass_t)
        samples = [model.evolve(x, c, gap * f) for f in (0.25, 0.5, 0.75, 1.0)]
        total.append(float(np.mean(samples)))
    return float(np.mean(total)) if total else 0.0


def _entry_index(route: Route, vertex: int, dist) -> int:
    """Walk index where a robot at `vertex` joins `route`: its nearest walk vertex (first
    occurrence; ties to the lowest vertex index)."""
    best = min(set(route.walk), key=lambda w: (dist[vertex, w], w))
    return route.walk.index(best)


def _urgent_entry(route: Route, vertex: int, dist, last_visit, now: float, speed: float) -> int:
    """Walk index where a lone robot at `vertex` joins a new walk (after a loss): the one whose
    first lap leaves the most idle vertex waiting least: min over entries k of max over walk
    vertices of (now - last visit + drive to walk[k] + arc from k to it) [s]; ties to the
    nearest entry. Its vertices (an orphaned part) must not wait a whole lap."""
    walk = np.asarray(route.walk)
    arc = np.asarray(route.arc)
    idle = now - np.asarray(last_visit, dtype=float)[walk]  # [s] per walk entry
    reach = np.asarray(dist[vertex, walk], dtype=float) / speed  # [s] to each entry
    ahead = np.mod(arc[None, :] - arc[:, None], route.length) / speed  # [k, i] k -> i [s]
    worst = (reach[:, None] + ahead + idle[None, :]).max(axis=1)
    return int(np.lexsort((np.arange(len(walk)), reach, np.round(worst, 6)))[0])


def start_schedule(graph, route: Route, starts: dict, speed: float, late_m: dict | None = None,
                   idle_s: np.ndarray | None = None) -> dict:
    """Robot -> (entry index, departure time [s]): the team starts spread at once. m virtual
    slots, evenly spaced along the walk and moving at `speed`, each pick up one robot: the robot
    drives the shortest route to the walk vertex where its slot passes soonest after it can be
    there, and leaves with the slot (robots only wait, never drive faster). Over slot phases,
    robots are matched to slots (least squared departures) and the schedule kept is the one
    whose walk vertices are all first visited soonest (then the least total wait); steady-state
    spacing then holds from the start. Robots may leave earlier than their slot while no gap
    exceeds 1.1 L / m (the first lap sooner; the spacing rule evens the gaps later).
    `late_m`: robot -> v times how long after t = 0 it is at its start vertex [m] (default 0).
    `idle_s`: per graph vertex, its idleness at t = 0 [s] (after a loss): then the schedule
    kept is the one whose walk vertices wait least in all, idleness at t = 0 + time to their
    first visit. Computed in the C++ core (tpuaf_core.start_schedule, on `graph`'s shortest
    paths)."""
    robots = list(route.robots)
    plan = tpuaf_core.start_schedule(
        graph, (list(route.walk), list(route.arc), route.length, robots),
        [int(starts[r]) for r in robots], [float((late_m or {}).get(r, 0.0)) for r in robots],
        float(speed), None if idle_s is None else np.asarray(idle_s, dtype=float).tolist())
    return {r: (int(k), float(t)) for r, (k, t) in zip(robots, plan, strict=True)}


_PLANS: OrderedDict = OrderedDict()


def make_plan(patrol_map, team: tuple[int, ...], all_starts: tuple[int, ...], mode: str,
              repair: str = "auto") -> Plan:
    """The plan for `team` (sorted robot indices believed alive); identical for every robot
    (cached per map object). `all_starts`: every robot's start vertex (may be empty)."""
    key = (id(patrol_map), team, all_starts, mode, repair)
    hit = _PLANS.get(key)
    if hit is not None and hit[0] is patrol_map:
        return hit[1]
    plan = _make_plan(patrol_map, team, all_starts, mode, repair)
    _PLANS[key] = (patrol_map, plan)
    while len(_PLANS) > 64:
        _PLANS.popitem(last=False)
    return plan


def _make_plan(patrol_map, team, all_starts, mode, repair) -> Plan:
    graph = patrol_map.graph
    speed = float(patrol_map.settings.nominal_speed)
    dist = np.asarray(graph.distances)
    m = len(team)
    cyc = tours.cyclic_tour(patrol_map)
    cyc_worst = tpuaf_core.walk_worst_idleness(graph, cyc.walk, m, speed)
    # Partitions into k = 2..m parts, robots spread over parts by L_p / m_p (k = m is MSP's).
    part, part_worst = None, np.inf
    if graph.num_vertices > 1 and mode != "cycle":
        top = min(m, graph.num_vertices)
        # every k on small graphs; on large ones only MSP's k = m (a partition search takes
        # tens of seconds at ~170 vertices); by size only, so every robot agrees
        ks = range(2, top + 1) if graph.num_vertices <= SMALL_GRAPH else [top] if top > 1 else []
        for k in ks:
            cand = tours.partition_tours(patrol_map, k)
            per_part = tours.robots_per_part([t.length for t in cand.tours], m)
            worst = max(
                tpuaf_core.walk_worst_idleness(graph, t.walk, j, speed)
                for t, j in zip(cand.tours, per_part, strict=True)
            )
            if worst < part_worst - _EPS:
                part = tours.Partition(cand.parts, cand.tours, per_part)
                part_worst = worst
    kind = mode
    if mode == "auto":
        kind = "partition" if part_worst < cyc_worst - _EPS else "cycle"
        if part is not None and abs(part_worst - cyc_worst) <= 0.02 * max(cyc_worst, _EPS):
            x_cyc = predicted_mean_uncertainty(patrol_map, cyc.walk, m, speed)
            x_part = sum(
                predicted_mean_uncertainty(patrol_map, t.walk, j, speed) * len(p)
                for t, j, p in zip(part.tours, part.robots_per_part, part.parts, strict=True)
            ) / graph.num_vertices
            kind = "partition" if x_part < x_cyc else "cycle"
    full = len(all_starts) == m and team == tuple(range(m))
    if not full and all_starts and repair != "replan":
        merged = _merge_repair(patrol_map, team, all_starts, mode)
        fresh_worst = part_worst if kind == "partition" else cyc_worst
        # a fresh plan moves every survivor to a new part: it must be clearly better
        if merged is not None and (repair == "merge" or merged.worst_s <= FRESH_MARGIN * fresh_worst
                                   + _EPS):
            return merged
    if kind == "cycle" or part is None:
        route = _route(graph, cyc.walk, team)
        routes = (route,)
        route_of = {r: 0 for r in team}
        worst = cyc_worst
    else:
        slots = [p for p, k in enumerate(part.robots_per_part) for _ in range(k)]
        if full:  # start: parts to robots so that every part is covered soon
            assignment = _assign_start_parts(part, list(all_starts), dist)
        elif not all_starts:  # start vertices unknown: robot order
            assignment = [slots[i % len(slots)] for i in range(m)]
        else:  # survivors: from the full team's plan, so every survivor agrees
            assignment = _assign_survivors(patrol_map, team, all_starts, part, slots, dist, mode)
        route_of = {r: assignment[i] for i, r in enumerate(team)}
        routes = tuple(
            _route(graph, t.walk, [r for r in team if route_of[r] == p])
            for p, t in enumerate(part.tours)
        )
        worst = part_worst
    schedule = {}
    if full:
        starts = {r: int(all_starts[r]) for r in team}
        for route in routes:
            schedule.update(start_schedule(graph, route, starts, speed))
    return Plan(kind, routes, route_of, float(worst), schedule)


def _assign_start_parts(part, starts: list[int], dist) -> list[int]:
    """Part index per robot at the start: each part gets its `robots_per_part` robots, matched
    so that the longest (drive to the part + L_p / m_p) is short: the time [m at v] until the
    part has been covered once (Hungarian on its 4th power: nearly a bottleneck matching)."""
    slots = [p for p, m in enumerate(part.robots_per_part) for _ in range(m)]
    d = np.asarray(dist)
    share = [part.tours[p].length / part.robots_per_part[p] for p in slots]
    cost = np.array([[d[s, part.parts[p]].min() + share[j] for j, p in enumerate(slots)]
                     for s in starts])
    rows, cols = tpuaf_core.linear_sum_assignment((cost / max(float(cost.max()), _EPS)) ** 4)
    out = [0] * len(starts)
    for r, c in zip(rows, cols, strict=True):
        out[r] = slots[c]
    return out


def _merge_repair(patrol_map, team, all_starts, mode) -> Plan | None:
    """Survivors keep their parts of the full team's partition; each part left without a robot
    joins the adjacent surviving part whose merged closed walk per robot is shortest (greedy,
    parts in index order). None when the full team's plan is a cycle."""
    graph = patrol_map.graph
    speed = float(patrol_map.settings.nominal_speed)
    home = make_plan(patrol_map, tuple(range(len(all_starts))), tuple(all_starts), mode)
    if home.kind != "partition":
        return None
    adj = tours._adjacency(graph)
    groups = []  # [vertex set, walk, robots]
    orphans = []
    for route in home.routes:
        robots = [r for r in route.robots if r in team]
        entry = [set(route.walk), list(route.walk), robots]
        (groups if robots else orphans).append(entry)
    if not groups:
        return None
    while orphans:
        progress = False
        for o in list(orphans):
            best = None
            for g in groups:
                if not any(w in g[0] for v in o[0] for w in adj[v]):
                    continue
                walk, length = tours.closed_walk(graph, sorted(g[0] | o[0]), adj, 3, 4)
                score = length / len(g[2])
                if best is None or score < best[0] - _EPS:
                    best = (score, g, walk)
            if best is not None:
                _, g, _ = best
                g[0] |= o[0]
                g[1] = tours.closed_walk(graph, sorted(g[0]), adj)[0]
                orphans.remove(o)
                progress = True
        if not progress:  # an orphan with no surviving neighbour part: re-plan from scratch
            return None
    routes = tuple(_route(graph, g[1], g[2]) for g in groups)
    route_of = {r: i for i, g in enumerate(groups) for r in g[2]}
    worst = max(
        tpuaf_core.walk_worst_idleness(graph, list(r.walk), len(r.robots), speed) for r in routes
    )
    return Plan("partition", routes, route_of, float(worst), {})


def _assign_survivors(patrol_map, team, all_starts, part, slots, dist, mode) -> list[int]:
    """Part per survivor (in `team` order): least total distance from each survivor's route in
    the full team's plan to the part (every survivor computes the same from the map alone)."""
    n_all = len(all_starts) if all_starts else max(team) + 1
    home = make_plan(patrol_map, tuple(range(n_all)), tuple(all_starts), mode)
    cost = np.zeros((len(team), len(slots)))
    for i, r in enumerate(team):
        walk = list(home.routes[home.route_of[r]].walk) if r in home.route_of else [0]
        for j, p in enumerate(slots):
            cost[i, j] = dist[np.ix_(walk, part.parts[p])].min()
    rows, cols = tpuaf_core.linear_sum_assignment(cost)
    out = [0] * len(team)
    for r, c in zip(rows, cols, strict=True):
        out[r] = slots[c]
    return out


def silence_timeout(graph, speed: float, setting: float) -> float:
    """The silence timeout [s]: `setting`, or for 0 max(60 s, 8 x the longest edge's travel
    time at `speed` [m/s])."""
    timeout = float(setting)
    if timeout <= 0:
        longest = max((float(c) for _, _, c in graph.edges), default=0.0)
        timeout = max(60.0, 8.0 * longest / speed)
    return timeout


@register
class TpuafPlus(Policy):
    """TPUAF+: shared tour plan, even spacing from timed messages, re-plan on silence."""

    name = "tpuaf_plus"
    description = (
        "TPUAF+ (beyond the paper): one shared cycle or partition (lower predicted idleness), "
        "robots evenly spaced online from teammates' timed messages, re-planned when a robot "
        "goes silent"
    )
    parameters = {
        "plan": Parameter(
            "auto",
            "shared plan: 'auto' (lower predicted worst idleness), 'cycle' or 'partition'",
            lambda v: v in ("auto", "cycle", "partition"),
        ),
        "repair": Parameter(
            "auto",
            "after a loss in a partition: 'merge' (orphan parts join a neighbouring part), "
            "'replan' (a fresh plan for the survivors) or 'auto' (merge unless the fresh plan's "
            "predicted worst idleness is lower by more than 15 %: it moves every survivor)",
            lambda v: v in ("auto", "merge", "replan"),
        ),
        "gain": Parameter(
            0.5,
            "fraction of the gap difference (behind - ahead) / 2 dwelt per vertex, in (0, 1]",
            lambda v: _positive(v) and v <= 1,
        ),
        "deadband_s": Parameter(
            0.5, "no dwell below this [s] (keeps the spacing from chattering)", _non_negative
        ),
        "dwell_revisit_s": Parameter(
            5.0, "a dwelling robot re-visits its vertex and re-announces every this [s]", _positive
        ),
        "silence_timeout_s": Parameter(
            0.0,
            "a mate silent this long [s] is presumed dead; 0 = auto: max(60 s, 8 x the longest "
            "edge's travel time)",
            _non_negative,
        ),
    }

    # ------------------------------------------------------------------ set-up

    def start(self, ctx: RobotContext) -> None:
        pm = ctx.patrol_map
        self.speed = float(pm.settings.nominal_speed)  # plan speed [m/s]
        self.graph = pm.graph
        self.dist = np.asarray(self.graph.distances)
        from tpuaf.policies.cyclic import team_start_vertices

        self.all_starts = tuple(team_start_vertices(ctx))
        self.robot = ctx.robot
        timeout = silence_timeout(self.graph, self.speed, self.params["silence_timeout_s"])
        self.silence_timeout_s = timeout
        self.knowledge = new_knowledge(pm, INTENTION_TIMEOUT_S, timeout)
        self.alive = set(range(ctx.n_robots))
        self.last_heard = {k: ctx.now for k in range(ctx.n_robots)}
        self.lost_at: dict[int, float] = {}  # robot -> when the runtime reported it lost [s]
        # latest timed message per mate: (from vertex, to vertex, departure [s], sent [s])
        self.heard: dict[int, tuple[int, int, float, float]] = {}
        self.mate_arc: dict[int, float] = {}  # last estimated arc [m] (disambiguates walks)
        # the last few timed announcements per robot, mine included, in the order sent: where
        # every robot stood when the team changed (`_transition_entries`)
        self.history: dict[int, list[tuple[int, int, float, float]]] = {}
        self.changed_at = 0.0  # [s] when the team last changed, as every survivor dates it
        self.hold_until: float | None = None  # planned departure while dwelling [s]
        self.respace: tuple[float, float] | None = None  # after a loss: (target arc [m], at [s])
        self.waking = False
        self.last_announce = -np.inf
        self.plan = None
        self._install_plan(ctx, initial=True)

    def _team(self, ctx) -> tuple[int, ...]:
        return tuple(sorted(self.alive | {ctx.robot}))

    def _install_plan(self, ctx, initial: bool = False) -> None:
        old_route = self.route if self.plan is not None else None
        self.plan = make_plan(
            ctx.patrol_map, self._team(ctx), self.all_starts, self.params["plan"],
            self.params["repair"],
        )
        self.route = self.plan.routes[self.plan.route_of[ctx.robot]]
        self.departure: float | None = None
        self.respace = None
        if initial and ctx.robot in self.plan.schedule:
            self.entry, self.departure = self.plan.schedule[ctx.robot]
            self.idx = None
        elif old_route is not None and old_route.walk == self.route.walk:
            # same walk (a cycle): keep my place on it; after a loss, re-space at once
            if len(self.route.robots) < len(old_route.robots):
                self.respace = self._respace_target(ctx)
        elif len(self.route.robots) == 1 and len(self.route.walk) > 1:  # a new part alone
            self.entry = _urgent_entry(self.route, ctx.current_vertex, self.dist,
                                       np.asarray(self.knowledge.last_visit), ctx.now, self.speed)
            self.idx = None
        else:
            # a walk new to several robots: enter where the start schedule (from where every
            # robot stood when the team changed) puts my slot, not all at the nearest vertex;
            # leave on arrival (waiting for the slot left vertices idle longer, measured) and
            # let the spacing rule even the gaps
            entries = self._transition_entries()
            self.entry = entries.get(ctx.robot)
            if self.entry is None:
                self.entry = _entry_index(self.route, ctx.current_vertex, self.dist)
            self.idx = None
        self.hold_until = None

    def _transition_entries(self) -> dict[int, int]:
        """Robot -> entry index on my new walk: `start_schedule`'s entries with each of its
        robots at the vertex its last announcement before the team change (`changed_at`) was
        heading to, from when it gets there. Every survivor computes it from the same messages
        (unless loss or delay kept one from it), so they agree on the entries. {} when a robot
        of the walk has not been heard."""
        t_ref, route = self.changed_at, self.route
        starts, late = {}, {}
        for r in route.robots:
            info = None
            for entry in self.history.get(r, ()):
                if entry[3] <= t_ref + _EPS:
                    info = entry  # the latest sent by then (an intention after its visit)
            if info is None:
                return {}
            a, b, departure, _ = info
            starts[r] = b
            late[r] = max(0.0, departure + float(self.dist[a, b]) / self.speed - t_ref) * self.speed
        idle = np.maximum(t_ref - np.asarray(self.knowledge.last_visit, dtype=float), 0.0)
        plan = start_schedule(self.graph, route, starts, self.speed, late, idle)
        return {r: k for r, (k, _) in plan.items()}

    def _remember(self, robot: int, entry: tuple[int, int, float, float]) -> None:
        past = self.history.setdefault(robot, [])
        past.append(entry)
        if len(past) > 4:
            del past[0]

    def _respace_target(self, ctx) -> tuple[float, float] | None:
        """After a loss on a shared walk: (my target arc [m], at time [s]) of the survivors'
        even spacing L / m that keeps their cyclic order and asks the least dwell of anyone
        (robots only wait). With survivors at unwrapped arcs p_0 <= ... < p_0 + L and
        e_j = p_j - j L / m, survivor j dwells (e_j - min e) / v, once, at its next walk
        vertex; the spacing rule then trims what my estimates of the mates got wrong."""
        route, now = self.route, ctx.now
        L, m = route.length, len(route.robots)
        if self.idx is None or m < 2 or L <= 0:
            return None
        mine = route.arc[self.idx]
        if self.hold_until is not None:  # dwelling counts as driving behind my vertex
            mine -= self.speed * max(0.0, self.hold_until - now)
        arcs = {ctx.robot: mine % L}
        for k in route.robots:
            if k != ctx.robot:
                arc = self._mate_arc(k, now)
                if arc is None:
                    return None  # a mate I cannot place: leave it to the spacing rule
                arcs[k] = arc
        # cyclic order from my position (ties: lower robot index ahead, as in spacing_wait)
        order = sorted(arcs, key=lambda k: ((arcs[k] - arcs[ctx.robot]) % L, -k))
        unwrapped = np.array([arcs[ctx.robot] + (arcs[k] - arcs[ctx.robot]) % L for k in order])
        e = unwrapped - np.arange(m) * (L / m)
        # my target: where I would be after my dwell; it moves on at v from `now`
        return float(mine - (e[0] - e.min())), now

    def _idle_room(self, now: float) -> float:
        """How long [s] I can dwell before some walk vertex ahead of me, up to the nearest mate
        ahead (where it is now, dwelling or not) and within L / m, waits longer than the even
        spacing's L / (m v) for me: min over them of L / (m v) - its idleness now (my visit
        knowledge) - my drive to it; never negative."""
        route = self.route
        n, L = len(route.walk), route.length
        here = route.arc[self.idx]
        even = L / len(route.robots)  # [m]
        reach = even
        for k in route.robots:
            arc = self._mate_arc(k, now) if k != self.robot else None
            if arc is not None:
                if k in self.heard:  # a dwelling mate is at its vertex, not behind it
                    arc += self.speed * max(0.0, self.heard[k][2] - now)
                reach = min(reach, (arc - here) % L)
        last = self.knowledge.last_visit
        room = np.inf
        for step in range(1, n):
            i = (self.idx + step) % n
            d = (route.arc[i] - here) % L
            if d > reach + _EPS:
                break
            room = min(room, (even - d) / self.speed - (now - float(last[route.walk[i]])))
        return max(0.0, float(room)) if np.isfinite(room) else 0.0

    def _respace_wait(self, ctx, now: float) -> float:
        """Dwell [s] towards my re-spacing target after a loss: what is left of it, but never
        so long that a vertex ahead of me waits longer than the even spacing allows (the robot
        ahead dwells its share first; `_idle_room`). Done when less than the deadband is left
        or after a lap."""
        target, at = self.respace
        L = self.route.length
        behind = (self.route.arc[self.idx] - target - self.speed * (now - at)) % L  # [m]
        left = behind / self.speed if behind < L / 2 else 0.0  # [s]
        wait = min(left, self._idle_room(now))
        if left - wait <= self.params["deadband_s"] or now - at > L / self.speed:
            self.respace = None
        return wait

    # ------------------------------------------------------------------ messages

    def on_message(self, message, ctx: RobotContext) -> None:
        # the hottest call of a run (every message x every recipient): locals, one dict lookup
        kind = type(message)
        if kind is Visit:
            k, sent = message.robot, message.time
            self.knowledge.hear_visit(k, message.vertex, sent, ctx.now)
            self._heard_from(k, sent)
            nxt = message.next_vertex if message.next_vertex >= 0 else message.vertex
            self._remember(k, (message.vertex, nxt, sent, sent))
            old = self.heard.get(k)
            if old is None or sent > old[3] + _EPS:
                self.heard[k] = (message.vertex, nxt, sent, sent)
        elif kind is Intention:
            k, sent = message.robot, message.time
            self._heard_from(k, sent)
            departure = message.expected_arrival - message.travel_time
            self._remember(k, (message.from_vertex, message.vertex, departure, sent))
            old = self.heard.get(k)
            if old is None or sent >= old[3] - _EPS:
                self.heard[k] = (message.from_vertex, message.vertex, departure, sent)

    def _heard_from(self, k: int, sent: float) -> None:
        sent = float(sent)
        last_heard = self.last_heard
        if sent > last_heard.get(k, -math.inf):
            last_heard[k] = sent
        lost_at = self.lost_at
        if lost_at and sent > lost_at.get(k, math.inf):
            del lost_at[k]  # heard again after it was reported lost

    def on_teammate_lost(self, robot: int, ctx: RobotContext) -> None:
        """The runtime's liveness timeout (faster than my own silence timeout)."""
        self.lost_at[robot] = ctx.now

    def _update_team(self, ctx) -> None:
        """Mates silent for longer than the timeout leave the team; a mate heard again rejoins."""
        now = ctx.now
        alive = {
            k for k in range(ctx.n_robots)
            if k == ctx.robot or (
                k not in self.lost_at
                and now - self.last_heard.get(k, -np.inf) <= self.silence_timeout_s
            )
        }
        if alive != self.alive:
            # dated as every survivor dates it: the loss report, else the end of the silence
            gone = [min(self.lost_at.get(k, np.inf),
                        self.last_heard.get(k, -np.inf) + self.silence_timeout_s)
                    for k in self.alive - alive]
            self.changed_at = min(max(gone), now) if gone else now
            self.alive = alive
            self._install_plan(ctx)

    # ------------------------------------------------------------------ spacing

    def _mate_arc(self, k: int, now: float) -> float | None:
        """Estimated arc position [m] of mate k on my walk now, None when unknown/off it: on its
        start slot until it leaves (and after, while its latest message is from before that, off
        my walk or due at its entry vertex in time), then from its latest timed message."""
        route = self.route
        scheduled = self.plan.schedule.get(k)
        if scheduled is not None and k not in route.robots:
            scheduled = None
        info = self.heard.get(k)
        if scheduled is not None and now < scheduled[1]:
            # not started yet: on its start slot (its messages while it drives to its entry
            # vertex place it off the slot)
            return self._slot_arc(k, scheduled, now)
        if info is None:
            # left, not heard yet (delay, loss): on its start slot
            return None if scheduled is None else self._slot_arc(k, scheduled, now)
        a, b, departure, sent = info
        walk, n = route.walk, len(route.walk)
        if a == b:
            hits = [i for i in range(n) if walk[i] == a]
        else:
            hits = [i for i in range(n) if walk[i] == a and walk[(i + 1) % n] == b]
        if scheduled is not None and sent < scheduled[1] - _EPS and (not hits or (
                departure + (self.dist[a, b] + self.dist[b, route.walk[scheduled[0]]])
                / self.speed <= scheduled[1] + _EPS)):
            # its latest message is from before it left its start slot, and it is off my walk
            # or was due at its entry vertex in time: the message telling me it left was
            # delayed or lost; on its start slot
            return self._slot_arc(k, scheduled, now)
        if not hits:
            return None
        # a mate dwelling until `departure` counts as driving behind its vertex: it will be there
        # then, as a robot moving at v would
        moved = self.speed * (now - departure)
        prev = self.mate_arc.get(k)
        if prev is None or len(hits) == 1:
            i = hits[0]
        else:
            i = min(hits, key=lambda h: abs(((route.arc[h] + moved - prev) + route.length / 2)
                                            % route.length - route.length / 2))
        arc = (route.arc[i] + moved) % route.length
        self.mate_arc[k] = arc
        return arc

    def _slot_arc(self, k: int, scheduled: tuple[int, float], now: float) -> float:
        """Mate k's arc [m] on its start slot at `now`: at its entry vertex at its departure
        time, moving at v (before and after)."""
        entry, departure = scheduled
        arc = (self.route.arc[entry] - self.speed * (departure - now)) % self.route.length
        self.mate_arc[k] = arc
        return arc

    def _gaps(self, ctx, now: float) -> tuple[float, float, float] | None:
        """(gap ahead, gap behind, even gap L / m) [m] from the current walk vertex to the
        nearest placed mates; None when no mate is placed."""
        route = self.route
        L = route.length
        me = ctx.robot
        here_arc = route.arc[self.idx]
        ahead = behind = None
        mates = [k for k in route.robots if k != me and k in self.alive]
        for k in mates:
            arc = self._mate_arc(k, now)
            if arc is None:
                continue
            d = (arc - here_arc) % L
            if d < _EPS or L - d < _EPS:  # together: the lower index is ahead
                fwd, back = (0.0, L) if k < me else (L, 0.0)
            else:
                fwd, back = d, L - d
            ahead = fwd if ahead is None else min(ahead, fwd)
            behind = back if behind is None else min(behind, back)
        if ahead is None:
            return None
        return ahead, behind, L / (len(mates) + 1)

    def spacing_wait(self, ctx, now: float) -> float:
        """Dwell [s] at the current walk vertex: gain * (gap_behind - gap_ahead) / (2 v)."""
        gaps = self._gaps(ctx, now) if self.route.length > 0 else None
        if gaps is None:
            return 0.0
        ahead, behind, ideal = gaps
        wait = self.params["gain"] * (behind - ahead) / (2.0 * self.speed)
        deadband = self.params["deadband_s"]
        if behind > ahead + _EPS and behind > ideal + 2.0 * deadband * self.speed:
            # gaps may step up by less than the deadband from robot to robot round the walk;
            # a robot with a long gap behind it dwells at least past the deadband
            wait = max(wait, deadband + 0.1)
        return float(min(max(wait, 0.0), ideal / self.speed))

    # ------------------------------------------------------------------ decisions

    def _announce(self, ctx, here: int, nxt: int, departure: float, visit: bool) -> None:
        now = ctx.now
        travel = self.graph.edge_length(here, nxt) / self.speed if nxt != here else 0.0
        if visit:
            ctx.send(Visit(ctx.robot, here, now, nxt))
        ctx.send(Intention(ctx.robot, here, nxt, departure + travel, travel, now))
        self._remember(ctx.robot, (here, nxt, departure, now))
        self.last_announce = now

    def _hold(self, ctx, here: int, waking: bool) -> int | None:
        """While dwelling: re-visit `here` every dwell_revisit_s, depart at hold_until."""
        now = ctx.now
        remaining = self.hold_until - now
        if remaining <= _EPS:
            return None  # caller departs
        if waking and remaining >= STAY_S - _EPS:
            return here  # a re-visit; it ends STAY_S later
        if remaining < STAY_S + 0.1:
            nap = remaining
        else:
            nap = min(remaining - STAY_S, self.params["dwell_revisit_s"])
        ctx.wake_at(now + nap)
        return -1

    def decide(self, ctx: RobotContext) -> int | None:
        if getattr(self, "plan", None) is None:
            self.start(ctx)
        now, here = ctx.now, ctx.current_vertex
        waking, self.waking = self.waking, False
        if not waking:
            self.knowledge.record_visit(here, now)
        self._update_team(ctx)
        route = self.route
        if self.idx is not None and route.walk[self.idx] != here:  # off my walk: rejoin it
            self.idx, self.hold_until = None, None
            self.entry = _entry_index(route, here, self.dist)
        if self.idx is None:  # driving to my walk
            target = route.walk[self.entry]
            if here != target:
                hop = self._repair_hop(ctx, here, target)
                self._announce(ctx, here, hop, now, visit=not waking)
                return hop
            self.idx = self.entry
        if len(route.walk) == 1:  # a one-vertex part: stay, re-visiting it
            if now - self.last_announce >= self.params["dwell_revisit_s"] - _EPS:
                self._announce(ctx, here, here, now + STAY_S, visit=True)
            return here
        return self._step(ctx, waking)

    def _step(self, ctx, waking: bool = False) -> int | None:
        now, here = ctx.now, ctx.current_vertex
        route = self.route
        nxt_idx = (self.idx + 1) % len(route.walk)
        nxt = route.walk[nxt_idx]
        if self.hold_until is None:
            if self.departure is not None:  # the start schedule
                wait, self.departure = max(0.0, self.departure - now), None
            elif self.respace is not None:
                wait = self._respace_wait(ctx, now)
            else:
                wait = self.spacing_wait(ctx, now)
            if wait > self.params["deadband_s"]:
                self.hold_until = now + wait
                self._announce(ctx, here, nxt, self.hold_until, visit=True)
        elif not waking:
            self._announce(ctx, here, nxt, self.hold_until, visit=True)  # heartbeat
        if self.hold_until is not None:
            action = self._hold(ctx, here, waking)
            if action == -1:
                self.waking = True
                return None
            if action is not None:
                return action
            self.hold_until = None
            self._announce(ctx, here, nxt, now, visit=False)
        else:
            self._announce(ctx, here, nxt, now, visit=True)
        self.idx = nxt_idx
        return nxt

    def _repair_hop(self, ctx, here: int, target: int) -> int:
        """Next vertex towards `target`: among neighbours on a shortest path, the one of
        maximal TPUAF utility (Eq. 13), so that driving to a new part also repairs gaps."""
        dist = self.dist
        nbrs = sorted({int(w) for w in self.graph.neighbours(here) if int(w) != here})
        best = dist[here, target]
        on_path = [
            w for w in nbrs
            if abs(self.graph.edge_length(here, w) + dist[w, target] - best) <= 1e-6 * (1 + best)
        ]
        if len(on_path) <= 1:
            return on_path[0] if on_path else min(nbrs, key=lambda w: (dist[w, target], w))
        result = self.knowledge.utilities(self.graph, ctx.now, here, on_path, self.speed)
        return on_path[int(np.argmax(result.utility))]

    def on_goal_failed(self, vertex, ctx: RobotContext) -> None:
        self.idx, self.hold_until = None, None
        self.entry = _entry_index(self.route, ctx.current_vertex, self.dist)
