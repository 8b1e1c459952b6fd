"""TPUAF+'s routes (tpuaf_plus.py): the plan's closed walks, their arc positions and the
target gaps between the robots that share one (`uneven_gaps`,
`apart_at_meetings`)."""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np

EPS = 1e-6


@dataclass(frozen=True)
class Route:
    """One closed walk of the plan and the robots that share it."""

    walk: tuple[int, ...]  # vertex indices; consecutive entries adjacent, last -> first too
    arc: tuple[float, ...]  # [m] arc position of each walk entry from walk[0]
    length: float  # [m] L
    robots: tuple[int, ...]  # robot indices on this walk, sorted
    gaps: tuple[float, ...] = ()  # [m] uneven target gaps (`uneven_gaps`); () = even, L / m


@dataclass(frozen=True)
class Plan:
    kind: str  # "cycle" or "partition"
    routes: tuple[Route, ...]
    route_of: dict  # robot -> route index
    worst_s: float  # predicted steady-state worst idleness [s]
    # Start schedule (only for the full team): robot -> (entry walk index, departure time [s]).
    schedule: dict


def make_route(graph, walk, robots, uneven: bool | None = None) -> Route:
    """The route of `robots` on `walk`; with `uneven` (default: on one-way maps) its target
    gaps keep robots from reaching a vertex at once from its two passes (`uneven_gaps`).
    Arc positions are the edges' lengths alone: with a timed map's turns added, physics was
    worse in 6 of 7 cases once no robot parked (docs/STRATEGIES.md, "Turns in the plan")."""
    arc, s = [], 0.0
    n = len(walk)
    for i, v in enumerate(walk):
        arc.append(s)
        if n > 1:
            s += graph.edge_length(v, walk[(i + 1) % n])
    if uneven is None:
        uneven = bool(graph.one_way)
    gaps = uneven_gaps(arc, walk, float(s), len(robots)) if uneven else ()
    return Route(tuple(int(v) for v in walk), tuple(arc), float(s), tuple(sorted(robots)), gaps)


def gapped_worst_idleness(route: Route, speed: float) -> float:
    """[s] the longest interval between two passes of a vertex of `route` when its robots
    keep its target gaps (L / m apart without them) at `speed` [m/s]: as
    tpuaf_core.walk_worst_idleness, on uneven gaps and the route's arcs."""
    m, length = len(route.robots), route.length
    if m < 1 or length <= 0:
        return 0.0
    gaps = route.gaps or (length / m,) * m
    phases = np.concatenate(([0.0], np.cumsum(gaps[:-1])))
    passes: dict[int, list[float]] = {}
    for v, a in zip(route.walk, route.arc, strict=True):
        passes.setdefault(int(v), []).extend(((a - phases) % length).tolist())
    worst = 0.0
    for times in passes.values():
        t = np.unique(np.round(times, 9))
        worst = max(worst, float(np.max(np.diff(np.append(t, t[0] + length)))))
    return worst / speed


def apart_at_meetings(graph, routes: tuple[Route, ...], worst_s: float,
                      speed: float) -> tuple[Route, ...]:
    """On a two-way map, the routes whose evenly spaced robots would reach a vertex at once
    from its two passes (a walk back and forth along a corridor: head-on at its middle
    vertex, where both aim at one point) get uneven target gaps, where those cost the plan
    nothing: the route's worst idleness on them stays within the plan's worst (`worst_s` [s],
    or its routes' on their arcs, if higher): a part with slack, never the
    bottleneck's."""
    if graph.one_way:
        return routes  # _route spaces them already
    worst_s = max(worst_s, *(gapped_worst_idleness(r, speed) for r in routes))
    out = []
    for route in routes:
        if len(route.robots) >= 2 and not route.gaps:
            gaps = uneven_gaps(route.arc, route.walk, route.length, len(route.robots))
            apart = replace(route, gaps=gaps)
            if gaps and gapped_worst_idleness(apart, speed) <= worst_s + EPS:
                route = apart
        out.append(route)
    return tuple(out)


MEET_CLEARANCE_M = 1.2  # [m of plan travel] robots reaching one vertex from two passes: apart
GAP_STEPS = 3  # uneven_gaps shifts each phase by up to this many half clearances either way


def uneven_gaps(arc, walk, length: float, m: int) -> tuple[float, ...]:
    """Target gaps [m] between m robots on a one-way closed walk that passes some vertex twice
    (the lab's figure eight: the middle aisle, once per loop). Evenly spaced robots whose
    phases differ by the arc between two passes of a vertex reach it at once, one from each
    pass, and merge there in a convoy. The phases j L / m + x_j (x_j in steps of half
    `MEET_CLEARANCE_M`, at most `GAP_STEPS` of them) are chosen so that no two robots' phases
    differ by such an arc within the clearance, with the least longest gap (then the least sum
    of squared gaps): exhaustively up to 4 robots, else one phase at a time. () when even
    spacing has no such meeting (or m < 2)."""
    passes: dict[int, list[float]] = {}
    for v, a in zip(walk, arc, strict=True):
        passes.setdefault(int(v), []).append(float(a))
    apart = sorted({(q - p) % length for ps in passes.values() for p in ps for q in ps if p != q})
    if m < 2 or not apart or length <= 0:
        return ()

    def meetings(phases) -> int:
        out = 0
        for i in range(m):
            for j in range(i + 1, m):
                d = phases[j] - phases[i]
                out += sum(min(abs(d - a), length - abs(d - a)) < MEET_CLEARANCE_M - 1e-9
                           for a in apart)
        return out

    def score(shifts):
        phases = [j * length / m + x for j, x in enumerate(shifts)]
        gaps = [b - a for a, b in zip(phases, phases[1:] + [phases[0] + length], strict=True)]
        if min(gaps) <= 0:
            return (np.inf,), gaps
        return (meetings(phases), round(max(gaps), 9), round(sum(g * g for g in gaps), 9)), gaps

    steps = [k * MEET_CLEARANCE_M / 2 for k in range(-GAP_STEPS, GAP_STEPS + 1)]
    best = [0.0] * m
    if score(best)[0][0] == 0:
        return ()
    if m <= 4:
        best = min(([0.0, *rest] for rest in itertools.product(steps, repeat=m - 1)),
                   key=lambda shifts: score(shifts)[0])
    else:
        for _ in range(3):
            for j in range(1, m):
                best[j] = min(steps, key=lambda x: score(best[:j] + [x] + best[j + 1:])[0])
    return tuple(float(g) for g in score(best)[1])
