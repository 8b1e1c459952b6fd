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
   With one-way lanes (the map's `one_way` arcs) every walk and part follows the arcs: the
   walks are closed walks that drive each one-way lane only its way (tours_directed.cpp), the
   parts strongly connected, the routes to them directed shortest paths; robots drive the
   walk in its direction.
3. Spacing (closed loop). Each robot measures each mate's pace (its speed along the walk,
   from consecutive timed messages: edge length / (arrival - departure), a running average
   weighted `pace_weight`, clamped to 0.1-1x the plan speed v). On reaching each walk vertex it
   places its walk mates (arc position from their latest timed message, extrapolated at their
   measured pace; messages carry the sender's clock, so delay does not bias them) and computes
   its phase error e [m] against the team's even spacing (phases L / m apart around the team's
   mean phase). Early (e > 0): it dwells `2 gain e / u` (u its own pace); late: it never
   dwells. A convoy dissolves within a lap; the gaps converge to L / m. On a one-way walk that
   passes a vertex twice, where robots L / m apart would reach it at once from its two passes,
   the targets are uneven gaps instead (`uneven_gaps`; the nearest rotation of them), and each
   mate's walk position is followed from message to message (a step can be on the walk twice).
   On a two-way map a walk back and forth gets uneven gaps too where the plan has slack
   (`apart_at_meetings`). Arcs are the edges' lengths (a timed map's turns are not added:
   docs/STRATEGIES.md, "Turns in the plan").
4. Dwelling. A dwelling robot re-visits its vertex every `dwell_revisit_s` (goal = its own
   vertex: it is physically there) and re-announces its departure time (a heartbeat).
5. Faults. A mate the runtime's one liveness rule reports lost (silent for the teammate
   timeout, `--teammate-timeout`, the agents' ~teammate_timeout) is presumed dead; every survivor
   then recomputes the plan for the survivors (step 1); a cycle re-spaces at once (each
   survivor dwells its share of the survivors' even spacing, capped so that no vertex ahead
   waits beyond L / (m v); `_respace_target`, `_idle_room`), then by step 3;
   a partition is merged or recomputed (still a partition when that is within
   KEEP_PARTITION_MARGIN of a cycle) and each survivor drives to its new part (several
   robots new to one walk enter it where the start schedule, from where each stood when the
   team changed, puts their slots: `_transition_entries`). A presumed-dead robot
   that speaks again rejoins. Stale information never blocks a vertex: nothing is reserved;
   an old message only places a mate on its walk, and it goes when the mate is reported lost.
6. Repair. While driving to a (new) part, the robot chooses among the neighbours on a
   shortest path the one of maximal TPUAF utility (Eq. 13: X^ * I / dt), from the same shared
   visit knowledge as TPUAF.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import replace

import numpy as np
import tpuaf_core

from tpuaf.maps import tours
from tpuaf.policies.base import Parameter, register
from tpuaf.policies.core import CoreStrategyPolicy
from tpuaf.policies.tpuaf import new_knowledge
from tpuaf.policies.tpuaf_plus_routes import (
    EPS,
    Plan,
    Route,
    apart_at_meetings,
    make_route,
)

_CORE_DEFAULTS = tpuaf_core.TpuafPlusParams()  # the core declares the spacing defaults
SMALL_GRAPH = 60  # vertices: up to this, partitions into every k = 2..N are tried
FRESH_MARGIN = 1.15  # after a loss, merge unless a fresh plan's worst is lower by more than this
KEEP_PARTITION_MARGIN = 1.05  # after a loss, a partitioned team re-partitions unless a cycle's
# predicted worst idleness is lower by more than this (example N = 12, one death: the worst
# after it 3.44 -> 2.00x the survivors' ideal; benchmarks/results/recovery.md)
STAY_S = 1.0  # [s] the runtimes' dwell for a goal equal to the current vertex (runtimes.graph)
INTENTION_TIMEOUT_S = 30.0  # [s] its visit knowledge drops intentions this old (it hears none)


def _positive(x) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and x > 0 and x < 1e9


def _non_negative(x) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and 0 <= x < 1e9


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
        graph, (list(route.walk), list(route.arc), route.length, robots, list(route.gaps)),
        [int(starts[r]) for r in robots], [float((late_m or {}).get(r, 0.0)) for r in robots],
        float(speed), None if idle_s is None else np.asarray(idle_s, dtype=float).tolist())
    return {r: (int(k), float(t)) for r, (k, t) in zip(robots, plan, strict=True)}


_PLANS: OrderedDict = OrderedDict()
_OPEN: OrderedDict = OrderedDict()  # id(plan map) -> (map, map without closed, kept, nearest)


def make_plan(patrol_map, team: tuple[int, ...], all_starts: tuple[int, ...], mode: str,
              repair: str = "auto") -> Plan:
    """The plan for `team` (sorted robot indices believed alive); identical for every robot
    (cached per map object). `all_starts`: every robot's start vertex (may be empty)."""
    key = (id(patrol_map), team, all_starts, mode, repair)
    hit = _PLANS.get(key)
    if hit is not None and hit[0] is patrol_map:
        return hit[1]
    if patrol_map.closed:  # a dead robot's body next to them: planned without them
        plan = _open_plan(patrol_map, team, all_starts, mode, repair)
    else:
        plan = _make_plan(patrol_map, team, all_starts, mode, repair)
    _PLANS[key] = (patrol_map, plan)
    while len(_PLANS) > 64:
        _PLANS.popitem(last=False)
    return plan


def _open_plan(patrol_map, team, all_starts, mode, repair) -> Plan:
    """The plan on `patrol_map` without its closed vertices (robot/lanes.py: each hangs on
    one edge, so the rest stays connected and no shortest path between the rest passes
    through one): planned on the map of the other vertices, its walks in `patrol_map`'s
    indices; a start at a closed vertex counts at the nearest open one."""
    hit = _OPEN.get(id(patrol_map))
    if hit is None or hit[0] is not patrol_map:
        graph = patrol_map.graph
        keep = [v for v in range(patrol_map.num_vertices) if v not in patrol_map.closed]
        new = {old: k for k, old in enumerate(keep)}
        sub = replace(patrol_map, vertex_ids=[patrol_map.vertex_ids[v] for v in keep],
                      positions=np.asarray(patrol_map.positions)[keep],
                      edges=[(new[u], new[v], d) for u, v, d in patrol_map.edges
                             if u in new and v in new],
                      importance=np.asarray(patrol_map.importance)[keep],
                      initial_uncertainty=np.asarray(patrol_map.initial_uncertainty)[keep],
                      one_way=tuple((new[u], new[v]) for u, v in patrol_map.one_way
                                    if u in new and v in new),
                      turns={(new[w], new[u], new[v]): t
                             for (w, u, v), t in patrol_map.turns.items()
                             if w in new and u in new and v in new},
                      closed=frozenset())
        near = [new[v] if v in new else new[min(keep, key=lambda w: graph.distance(v, w))]
                for v in range(patrol_map.num_vertices)]
        hit = _OPEN[id(patrol_map)] = (patrol_map, sub, keep, near)
        while len(_OPEN) > 8:
            _OPEN.popitem(last=False)
    _, sub, keep, near = hit
    plan = make_plan(sub, team, tuple(near[s] for s in all_starts), mode, repair)
    routes = tuple(replace(r, walk=tuple(keep[v] for v in r.walk)) for r in plan.routes)
    return replace(plan, routes=routes)


def _make_plan(patrol_map, team, all_starts, mode, repair) -> Plan:
    graph = patrol_map.graph
    speed = float(patrol_map.settings.nominal_speed)
    m = len(team)
    cyc = tours.cyclic_tour(patrol_map)
    # Chosen on the edges' times alone: with the turns in, partitions shared by several robots
    # that cross head-on on every walk back and forth win, and crossings are not in the model
    # (docs/STRATEGIES.md, "Turns in the plan").
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
            if not cand.parts:  # one-way arcs: no k parts each toured inside itself
                continue
            per_part = tours.robots_per_part([t.length for t in cand.tours], m)
            worst = max(
                tpuaf_core.walk_worst_idleness(graph, t.walk, j, speed)
                for t, j in zip(cand.tours, per_part, strict=True)
            )
            if worst < part_worst - EPS:
                part = tours.Partition(cand.parts, cand.tours, per_part)
                part_worst = worst
    kind = mode
    if mode == "auto":
        kind = "partition" if part_worst < cyc_worst - EPS else "cycle"
        if part is not None and abs(part_worst - cyc_worst) <= 0.02 * max(cyc_worst, EPS):
            x_cyc = predicted_mean_uncertainty(patrol_map, cyc.walk, m, speed)
            x_part = sum(
                predicted_mean_uncertainty(patrol_map, t.walk, j, speed) * len(p)
                for t, j, p in zip(part.tours, part.robots_per_part, part.parts, strict=True)
            ) / graph.num_vertices
            kind = "partition" if x_part < x_cyc else "cycle"
    full = len(all_starts) == m and team == tuple(range(m))
    if (not full and all_starts and mode == "auto" and kind == "cycle" and part is not None
            and part_worst <= KEEP_PARTITION_MARGIN * cyc_worst + EPS
            and make_plan(patrol_map, tuple(range(len(all_starts))), tuple(all_starts),
                          mode).kind == "partition"):
        # after a loss a partitioned team stays partitioned when that is nearly as good: each
        # survivor keeps to the area nearest its old part instead of all moving to cycle slots
        kind = "partition"
    if not full and all_starts and repair != "replan":
        merged = _merge_repair(patrol_map, team, all_starts, mode)
        fresh_worst = part_worst if kind == "partition" else cyc_worst
        # a fresh plan moves every survivor to a new part: it must be clearly better
        if merged is not None and (repair == "merge" or merged.worst_s <= FRESH_MARGIN * fresh_worst
                                   + EPS):
            return merged
    if kind == "cycle" or part is None:
        route = make_route(graph, cyc.walk, team)
        routes = (route,)
        route_of = {r: 0 for r in team}
        worst = cyc_worst
    else:
        slots = [p for p, k in enumerate(part.robots_per_part) for _ in range(k)]
        if full:  # start: parts to robots so that every part is covered soon
            assignment = _assign_start_parts(graph, part, list(all_starts))
        elif not all_starts:  # start vertices unknown: robot order
            assignment = [slots[i % len(slots)] for i in range(m)]
        else:  # survivors: from the full team's plan, so every survivor agrees
            assignment = _assign_survivors(patrol_map, team, all_starts, part, slots, mode)
        route_of = {r: assignment[i] for i, r in enumerate(team)}
        routes = tuple(
            make_route(graph, t.walk, [r for r in team if route_of[r] == p])
            for p, t in enumerate(part.tours)
        )
        worst = part_worst
    routes = apart_at_meetings(graph, routes, worst, speed)
    schedule = {}
    if full:
        starts = {r: int(all_starts[r]) for r in team}
        for route in routes:
            schedule.update(start_schedule(graph, route, starts, speed))
    return Plan(kind, routes, route_of, float(worst), schedule)


def retimed_routes(plan: Plan, graph) -> tuple[Route, ...]:
    """The plan's walks, each with its robots, re-timed on `graph` (a re-timed plan map's:
    lengths = plan speed x learned duration [m]): arc positions, length and uneven target gaps
    on its edge lengths. The walks themselves stay: every robot keeps the one it drives, and
    robots whose learned times differ a little still agree on the plan."""
    return tuple(make_route(graph, r.walk, r.robots, bool(graph.one_way or r.gaps))
                 for r in plan.routes)


def _assign_start_parts(graph, part, starts: list[int]) -> list[int]:
    """Part index per robot at the start: each part gets its `robots_per_part` robots, matched
    so that the longest (drive to the part + L_p / m_p) is short: the time [m at v] until the
    part has been covered once (Hungarian on its 4th power: nearly a bottleneck matching).
    Distances from one row per start vertex (no all-pairs matrix)."""
    slots = [p for p, m in enumerate(part.robots_per_part) for _ in range(m)]
    share = [part.tours[p].length / part.robots_per_part[p] for p in slots]
    rows = {s: np.asarray(graph.distances_from(s)) for s in sorted(set(starts))}
    cost = np.array([[rows[s][part.parts[p]].min() + share[j] for j, p in enumerate(slots)]
                     for s in starts])
    rows, cols = tpuaf_core.linear_sum_assignment((cost / max(float(cost.max()), EPS)) ** 4)
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
                try:
                    walk, length = tours.closed_walk(graph, sorted(g[0] | o[0]), adj, 3, 4)
                except ValueError:  # one-way arcs: the merged part cannot be toured inside
                    continue
                score = length / len(g[2])
                if best is None or score < best[0] - EPS:
                    best = (score, g, walk)
            if best is not None:
                _, g, _ = best
                g[0] |= o[0]
                g[1] = tours.closed_walk(graph, sorted(g[0]), adj)[0]
                orphans.remove(o)
                progress = True
        if not progress:  # an orphan with no surviving neighbour part: re-plan from scratch
            return None
    routes = tuple(make_route(graph, g[1], g[2]) for g in groups)
    route_of = {r: i for i, g in enumerate(groups) for r in g[2]}
    worst = max(
        tpuaf_core.walk_worst_idleness(graph, list(r.walk), len(r.robots), speed) for r in routes
    )
    routes = apart_at_meetings(graph, routes, worst, speed)
    return Plan("partition", routes, route_of, float(worst), {})


def _assign_survivors(patrol_map, team, all_starts, part, slots, mode) -> list[int]:
    """Part per survivor (in `team` order): least total distance from each survivor's route in
    the full team's plan to the part (every survivor computes the same from the map alone).
    One search per part, from all its vertices (no all-pairs matrix)."""
    graph = patrol_map.graph
    n_all = len(all_starts) if all_starts else max(team) + 1
    home = make_plan(patrol_map, tuple(range(n_all)), tuple(all_starts), mode)
    to_part = [np.asarray(graph.distances_from_set(list(q))) for q in part.parts]
    cost = np.zeros((len(team), len(slots)))
    for i, r in enumerate(team):
        walk = list(home.routes[home.route_of[r]].walk) if r in home.route_of else [0]
        for j, p in enumerate(slots):
            cost[i, j] = to_part[p][walk].min()
    rows, cols = tpuaf_core.linear_sum_assignment(cost)
    out = [0] * len(team)
    for r, c in zip(rows, cols, strict=True):
        out[r] = slots[c]
    return out


def plan_from(patrol_map, team: tuple[int, ...], starts: tuple[int, ...], mode: str) -> Plan:
    """A fresh plan for `team` alone from where its robots are (`starts`: every robot's
    vertex): `make_plan`'s for a full team of len(team) robots starting there (parts matched
    to the robots by their drive to them, no start schedule), its robots named as in `team`.
    A re-planned map: the old plan's parts may lie across a blocked lane, and which robot takes
    which part should not make robots pass each other in a lane one robot wide."""
    plan = make_plan(patrol_map, tuple(range(len(team))), tuple(starts[r] for r in team), mode,
                     "replan")
    routes = tuple(replace(r, robots=tuple(team[i] for i in r.robots)) for r in plan.routes)
    return replace(plan, routes=routes, route_of={team[i]: p for i, p in plan.route_of.items()},
                   schedule={})


def replan_starts(ctx) -> tuple[int, ...] | None:
    """Every robot's vertex when the plan map changes (a lane blocked, robot/lanes.py): the
    vertex nearest the position of its last lane claim (re-announced every second), its own
    included (the claim it sent, not where it is now: every survivor then reads the same and
    matches parts to robots alike), the dead robot's too (its body); None without lane claims
    (the run's start vertices then)."""
    locks = getattr(ctx, "lane_locks", None)
    if locks is None:
        return None
    pm = ctx.patrol_map
    out = []
    for k in range(ctx.n_robots):
        xy = locks.mine.position if k == ctx.robot else locks.claims[k].position \
            if k in locks.claims else (float("nan"), float("nan"))
        if not all(np.isfinite(xy)):
            return None
        out.append(int(pm.nearest_vertex(float(xy[0]), float(xy[1]))))
    return tuple(out)


@register
class TpuafPlus(CoreStrategyPolicy):
    """TPUAF+: shared tour plan, closed-loop spacing from timed messages (measured paces,
    phase errors), re-plan on silence."""

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
            _CORE_DEFAULTS.gain,
            "spacing gain in (0, 1]: a robot early by e [m] of its phase dwells 2 gain e / u "
            "(u: its measured pace [m/s])",
            lambda v: _positive(v) and v <= 1,
        ),
        "pace_weight": Parameter(
            _CORE_DEFAULTS.pace_weight,
            "weight in (0, 1] of a new sample in a mate's measured pace (running average)",
            lambda v: _positive(v) and v <= 1,
        ),
        "deadband_s": Parameter(
            _CORE_DEFAULTS.deadband_s, "no dwell below this [s] (keeps the spacing from "
            "chattering)", _non_negative
        ),
        "dwell_revisit_s": Parameter(
            _CORE_DEFAULTS.dwell_revisit_s,
            "a dwelling robot re-visits its vertex and re-announces every this [s]", _positive,
        ),
        "retime": Parameter(
            _CORE_DEFAULTS.retime,
            "follow learned travel times (physics, robots): the walks' arcs, lap lengths and "
            "spacing targets re-timed on the team's measured edge durations when that moves a "
            "target gap by over 10 % of L / m (off: the model's times; docs/STRATEGIES.md)",
            lambda v: isinstance(v, bool),
        ),
    }

    @classmethod
    def core_strategy(cls, params: dict, patrol_map, n_robots: int, streams: list):
        """The core's TpuafPlusStrategy (policies_tpuaf_plus.cpp: spacing, dwelling, faults,
        repair); its plans are `make_plan`'s, asked for when a robot's view of the team
        changes."""
        del streams  # TPUAF+ draws no random numbers
        speed = float(patrol_map.settings.nominal_speed)
        out = tpuaf_core.TpuafPlusParams()
        out.speed_mps = speed
        out.gain = float(params["gain"])
        out.pace_weight = float(params["pace_weight"])
        out.deadband_s = float(params["deadband_s"])
        out.dwell_revisit_s = float(params["dwell_revisit_s"])
        out.stay_s = STAY_S
        out.retime = bool(params["retime"])

        knowledge = new_knowledge(patrol_map, INTENTION_TIMEOUT_S)
        return tpuaf_core.TpuafPlusStrategy(knowledge, out,
                                            cls.plan_source(params, patrol_map, n_robots))

    @staticmethod
    def plan_source(params: dict, patrol_map, n_robots: int, starts=None):
        """`plans(team, timing)`: `make_plan`'s plan for the robots `team` on `patrol_map`, as
        the core asks for it (timing: a re-timed graph, learned travel times, or None).
        `starts`: every robot's vertex now (a re-plan on a changed map): each team's plan is
        then planned afresh from where its robots are (`plan_from`); default: the run's start
        vertices, and a smaller team's plan repairs the full team's."""
        import types

        from tpuaf.policies.cyclic import team_start_vertices

        ctx = types.SimpleNamespace(patrol_map=patrol_map, n_robots=n_robots)
        all_starts = tuple(team_start_vertices(ctx))

        def plans(team: list[int], timing=None):
            plan = (make_plan(patrol_map, tuple(team), all_starts, params["plan"],
                              params["repair"]) if starts is None
                    else plan_from(patrol_map, tuple(team), tuple(starts), params["plan"]))
            # re-timed (learned travel times): the same walks, on the timing graph's lengths
            chosen = (plan.routes if timing is None
                      else retimed_routes(plan, timing))
            routes = [(list(r.walk), list(r.arc), r.length, list(r.robots), list(r.gaps))
                      for r in chosen]
            route_of = [plan.route_of.get(k, -1) for k in range(n_robots)]
            schedule = [plan.schedule.get(k, (-1, 0.0)) for k in range(n_robots)]
            return routes, route_of, schedule

        return plans

    def replan(self, ctx) -> None:
        # A lane edge dropped (a dead robot's body on it): the walks are planned again on the
        # new map, for the team this robot believes alive, from where the robots are (the
        # old plan's parts may lie across the blocked lanes from them).
        self.host.set_graph(ctx.patrol_map.graph)
        self._call(ctx, self.strategy.replan,
                   self.plan_source(self.params, ctx.patrol_map, ctx.n_robots,
                                    replan_starts(ctx)))

    @property
    def walk(self) -> list[int]:
        """This robot's current walk (its vertices in order)."""
        return list(self.strategy.walk(self.robot))

    @property
    def team(self) -> list[int]:
        """The robots this robot believes alive (itself included)."""
        return list(self.strategy.team(self.robot))
