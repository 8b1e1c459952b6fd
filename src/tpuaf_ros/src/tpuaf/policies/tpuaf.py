"""TPUAF (SPEC section 4; paper Sec. 3, Eq. 6-14) and its any-vertex variant.

Each robot keeps the shared set Q: the latest known visit time of every vertex and the
announced intentions of the others, with stale entries dropped. It also keeps its own estimate
of every target's uncertainty X_j, grown with the model of Eq. 2 and cut at every known visit.
"""

from __future__ import annotations

import math

import numpy as np

from ..messages import Intention, Visit
from .base import Parameter, Policy, RobotContext, register


def _positive(x) -> bool:
    return isinstance(x, int | float) and x > 0


class TeamKnowledge:
    """Set Q of one robot (SPEC 4, step 3 and 6) plus its uncertainty estimate (step 7)."""

    def __init__(self, patrol_map, intention_timeout_s: float, silence_timeout_s: float):
        n = patrol_map.num_vertices
        settings = patrol_map.settings
        self.model = patrol_map.uncertainty_model()
        self.importance = np.asarray(patrol_map.importance, dtype=float)
        self.last_visit = np.zeros(n)  # [s]; the run starts with every clock at 0
        # X_j(t) = evolve(anchor_value_j, C_j, t - anchor_time_j) while nobody covers j.
        self.anchor_value = np.asarray(patrol_map.initial_uncertainty, dtype=float).copy()
        self.anchor_time = np.zeros(n)
        # One straight pass at nominal speed: mean M over the 2r/v crossing is 8G/15 (Eq. 1).
        self.pass_time_s = 2.0 * settings.sensing_radius / settings.nominal_speed
        self.pass_coverage = 8.0 * settings.sensing_peak / 15.0
        self.pending_visits: list[tuple[int, float]] = []
        self.intentions: dict[int, Intention] = {}
        self.last_heard: dict[int, float] = {}
        self.intention_timeout_s = intention_timeout_s
        self.silence_timeout_s = silence_timeout_s

    def record_visit(self, vertex: int, time: float) -> None:
        """A visit of `vertex` at `time` [s]; applied lazily (see `_apply_visits`)."""
        self.pending_visits.append((vertex, time))

    def _apply_visits(self) -> None:
        """Apply pending visits in time order, vectorised over vertices: each round takes the
        earliest pending visit of every vertex, grows X to it and applies one pass."""
        if not self.pending_visits:
            return
        pending = sorted(self.pending_visits, key=lambda vt: vt[1])
        self.pending_visits = []
        while pending:
            seen: set[int] = set()
            now_round, later = [], []
            for vertex, time in pending:
                (later if vertex in seen else now_round).append((vertex, time))
                seen.add(vertex)
            pending = later
            vertices = np.fromiter((v for v, _ in now_round), dtype=np.int64, count=len(now_round))
            times = np.fromiter((t for _, t in now_round), dtype=float, count=len(now_round))
            np.maximum.at(self.last_visit, vertices, times)
            fresh = times >= self.anchor_time[vertices]
            vertices, times = vertices[fresh], times[fresh]
            if not len(vertices):
                continue
            c = self.importance[vertices]
            x = self.model.evolve_many(
                self.anchor_value[vertices], c, times - self.anchor_time[vertices]
            )
            self.anchor_value[vertices] = self.model.evolve_many(
                x, c - self.pass_coverage, np.full(len(vertices), self.pass_time_s)
            )
            self.anchor_time[vertices] = times

    def hear(self, message, now: float) -> None:
        self.last_heard[message.robot] = now
        if type(message) is Visit:
            self.pending_visits.append((message.vertex, message.time))
            current = self.intentions.get(message.robot)
            if current is not None and current.vertex == message.vertex:
                del self.intentions[message.robot]
        elif type(message) is Intention:
            current = self.intentions.get(message.robot)
            if current is None or message.time >= current.time:
                self.intentions[message.robot] = message

    def drop_stale(self, now: float) -> None:
        for robot in list(self.intentions):
            intention = self.intentions[robot]
            late = now - intention.expected_arrival > self.intention_timeout_s
            silent = now - self.last_heard.get(robot, -math.inf) > self.silence_timeout_s
            if late or silent:
                del self.intentions[robot]

    def estimate(self, now: float) -> np.ndarray:
        self._apply_visits()
        return self.model.evolve_many(
            self.anchor_value, self.importance, np.maximum(0.0, now - self.anchor_time)
        )

    def announced(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """Earliest announced arrival per vertex [s] (+inf: none) and that robot's dt' [s]."""
        arrival = np.full(n, np.inf)
        travel = np.zeros(n)
        for intention in self.intentions.values():
            if intention.expected_arrival < arrival[intention.vertex]:
                arrival[intention.vertex] = intention.expected_arrival
                travel[intention.vertex] = intention.travel_time
        return arrival, travel


@register
class Tpuaf(Policy):
    """TPUAF as the paper states it: the next target is the neighbour of maximal utility."""

    name = "tpuaf"
    description = "TPUAF: neighbour maximising X^(t_end) * I / dt (Eq. 13) or Eq. 14"
    any_vertex = False
    parameters = {
        "utility": Parameter(
            "eq13",
            "utility form: 'eq13' (U = X^ I / dt) or 'eq14' (the paper's second form)",
            lambda v: v in ("eq13", "eq14"),
        ),
        "intention_timeout_s": Parameter(
            30.0,
            "drop an intention whose expected arrival passed more than this [s] ago",
            _positive,
        ),
        "silence_timeout_s": Parameter(
            120.0, "drop the intention of a robot not heard from for this long [s]", _positive
        ),
    }

    def start(self, ctx: RobotContext) -> None:
        import tpuaf_core

        self.knowledge = TeamKnowledge(
            ctx.patrol_map, self.params["intention_timeout_s"], self.params["silence_timeout_s"]
        )
        self.form = (
            tpuaf_core.UtilityForm.EQ14
            if self.params["utility"] == "eq14"
            else tpuaf_core.UtilityForm.EQ13
        )
        self._utilities = tpuaf_core.tpuaf_utilities
        self.last_utilities = None  # the last decision's UtilityResult, for inspection

    def candidates(self, ctx: RobotContext) -> list[int]:
        graph = ctx.patrol_map.graph
        if self.any_vertex:
            return [v for v in range(graph.num_vertices) if v != ctx.current_vertex]
        return list(graph.neighbours(ctx.current_vertex))

    def decide(self, ctx: RobotContext) -> int | None:
        now, here = ctx.now, ctx.current_vertex
        knowledge = self.knowledge
        knowledge.record_visit(here, now)
        knowledge.drop_stale(now)
        mine = knowledge.intentions.pop(ctx.robot, None)  # never count my own old intention
        del mine
        patrol_map = ctx.patrol_map
        n = patrol_map.num_vertices
        candidates = self.candidates(ctx)
        if not candidates:  # a one-vertex graph: stay
            ctx.send(Visit(ctx.robot, here, now, here))
            return here
        arrival, travel = knowledge.announced(n)
        estimate = knowledge.estimate(now)  # applies pending visits, so last_visit is current
        result = self._utilities(
            patrol_map.graph,
            knowledge.importance,
            knowledge.model,
            now,
            here,
            candidates,
            ctx.average_speed,
            knowledge.last_visit,
            estimate,
            arrival,
            travel,
            self.form,
            self.any_vertex,
        )
        self.last_utilities = result
        utility = result.utility
        best = np.flatnonzero(utility >= utility.max() - 1e-12 * max(1.0, abs(utility.max())))
        k = int(best[0]) if len(best) == 1 else int(ctx.rng.choice(best))
        target = candidates[k]
        ctx.send(Visit(ctx.robot, here, now, target))
        ctx.send(
            Intention(
                ctx.robot,
                here,
                target,
                float(result.arrival_s[k]),
                float(result.travel_time_s[k]),
                now,
            )
        )
        return target

    def on_message(self, message, ctx: RobotContext) -> None:
        self.knowledge.hear(message, ctx.now)


@register
class TpuafAnyVertex(Tpuaf):
    """Variant beyond the paper: any vertex is a candidate, travel by shortest path."""

    name = "tpuaf_any"
    description = "TPUAF variant: any vertex, d = shortest-path length (not the paper's rule)"
    any_vertex = True
