"""TPUAF (SPEC section 4; paper Sec. 3, Eq. 6-14).

The any-vertex variant `tpuaf_any` was removed (issue 13): it was worse than TPUAF in I_max and X
on every map and team size of the canonical comparison and under faults (docs/STRATEGIES.md).
`any_vertex` stays a class switch, mirrored by the C++ decision path.

Each robot keeps the shared set Q (latest known visit of every vertex, announced intentions of
the others, stale entries dropped) and its own estimate of every target's uncertainty X_j,
grown with the model of Eq. 2 and cut at every known visit. That bookkeeping and the utility
evaluation live in the C++ core (`tpuaf_core.TpuafKnowledge`); this class only decides.

Late messages and platoons (issue 12, "delay hurts more than total loss"): robots that reach a
vertex at the same time decide from the same knowledge, and with delayed messages neither hears
the other's intention before deciding, so both pick the same neighbour, arrive together again,
and travel as one platoon for the rest of the run (k robots patrolling like one; with no
messages at all their knowledge differs and they split). Reservations were never the problem:
an announced arrival that has passed counts as the visit it was, and stale ones expire. The fix
(`colocation`, default on): a robot that knows a teammate reached its vertex within the measured
message latency, and has not heard that teammate's next decision, lets the lower-indexed one
decide first: it computes that teammate's choice with the same utility and counts it as an
announced intention before choosing. Teammates whose late visits show they followed the same
vertices at the same times ("shadows") are treated the same way until a message shows they split.
"""

from __future__ import annotations

import numpy as np

from tpuaf.policies.base import Parameter, Policy, RobotContext, register
from tpuaf.team.messages import Intention, Visit


def _positive(x) -> bool:
    return isinstance(x, int | float) and x > 0


def new_knowledge(patrol_map, intention_timeout_s: float, silence_timeout_s: float):
    """TpuafKnowledge for a map. A known visit applies one straight pass at nominal speed: the
    mean perception over the 2r/v crossing is 8G/15 (integral of Eq. 1 along a diameter)."""
    import tpuaf_core

    s = patrol_map.settings
    return tpuaf_core.TpuafKnowledge(
        np.asarray(patrol_map.importance, dtype=float),
        np.asarray(patrol_map.initial_uncertainty, dtype=float),
        patrol_map.uncertainty_model(),
        pass_coverage=8.0 * s.sensing_peak / 15.0,
        pass_time_s=2.0 * s.sensing_radius / s.nominal_speed,
        intention_timeout_s=intention_timeout_s,
        silence_timeout_s=silence_timeout_s,
    )


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
        "colocation": Parameter(
            True,
            "resolve robots that arrive together before late messages tell (true) or not, "
            "the paper's rule as such (false; platoons form under delay)",
            lambda v: isinstance(v, bool) or v in (0, 1, "true", "false"),
        ),
    }

    def start(self, ctx: RobotContext) -> None:
        import tpuaf_core

        self.knowledge = new_knowledge(
            ctx.patrol_map, self.params["intention_timeout_s"], self.params["silence_timeout_s"]
        )
        self.form = (
            tpuaf_core.UtilityForm.EQ14
            if self.params["utility"] == "eq14"
            else tpuaf_core.UtilityForm.EQ13
        )
        self.last_utilities = None  # the last decision's UtilityResult, for inspection
        self.colocation = self.params["colocation"] in (True, 1, "true")
        self.latency_s = 0.0  # [s] largest message latency seen (receive time - send time)
        self.my_visits: dict[int, list[tuple[float, int]]] = {}  # vertex -> [(time, next)]
        self.shadows: set[int] = set()  # teammates seen following my vertices at my times

    def candidates(self, ctx: RobotContext) -> list[int]:
        graph = ctx.patrol_map.graph
        if self.any_vertex:
            return [v for v in range(graph.num_vertices) if v != ctx.current_vertex]
        return list(graph.neighbours(ctx.current_vertex))

    def decide(self, ctx: RobotContext) -> int | None:
        now, here = ctx.now, ctx.current_vertex
        knowledge = self.knowledge
        knowledge.record_visit(here, now)
        knowledge.forget_intention(ctx.robot)  # never count my own old intention
        candidates = self.candidates(ctx)
        if not candidates:  # a one-vertex graph: stay
            ctx.send(Visit(ctx.robot, here, now, here))
            return here
        if self.colocation and self.latency_s > 0:  # no late messages: nothing to resolve
            for mate in self.colocated(ctx):  # lower-indexed teammates here decide first
                if mate < ctx.robot:
                    self._presume_choice(ctx, mate, candidates)
        result = knowledge.utilities(
            ctx.patrol_map.graph, now, here, candidates, ctx.average_speed, self.form,
            self.any_vertex,
        )
        self.last_utilities = result
        utility = result.utility
        top = utility.max()
        best = np.flatnonzero(utility >= top - 1e-12 * max(1.0, abs(top)))
        k = int(best[0]) if len(best) == 1 else int(ctx.rng.choice(best))  # seeded tie-break
        target = candidates[k]
        mine = self.my_visits.setdefault(here, [])
        mine.append((now, target))
        del mine[:-4]
        ctx.send(Visit(ctx.robot, here, now, target))
        ctx.send(
            Intention(
                ctx.robot, here, target, float(result.arrival_s[k]),
                float(result.travel_time_s[k]), now,
            )
        )
        return target

    def colocated(self, ctx: RobotContext) -> list[int]:
        """Teammates that reached my vertex within the message latency of now and whose next
        decision I have not heard (their intention for it still held), and my shadows."""
        now, here = ctx.now, ctx.current_vertex
        window = self.latency_s + 1e-6
        mates = {
            robot for robot, _, vertex, arrival, _, _ in self.knowledge.intentions
            if robot != ctx.robot and vertex == here and now - window <= arrival <= now + 1e-6
        }
        return sorted(mates | (self.shadows - {ctx.robot}))

    def _presume_choice(self, ctx: RobotContext, mate: int, candidates: list[int]) -> None:
        """Count teammate `mate`'s presumed choice here (argmax of the same utility, lowest
        index on ties) as its announced intention."""
        now, here = ctx.now, ctx.current_vertex
        result = self.knowledge.utilities(
            ctx.patrol_map.graph, now, here, candidates, ctx.average_speed, self.form,
            self.any_vertex,
        )
        k = int(np.argmax(result.utility))
        self.knowledge.hear_intention(
            mate, here, candidates[k], float(result.arrival_s[k]),
            float(result.travel_time_s[k]), now, now,
        )

    def _track_shadow(self, message: Visit) -> None:
        """A teammate's visit at (about) my own visit of that vertex, followed by the same next
        vertex, makes it my shadow; any other visit of it ends that."""
        tol = max(1.0, 0.1 * self.latency_s)
        same = [nxt for t, nxt in self.my_visits.get(message.vertex, ())
                if abs(t - message.time) <= tol]
        if same and message.next_vertex in same:
            self.shadows.add(message.robot)
        else:
            self.shadows.discard(message.robot)

    def on_teammate_lost(self, robot: int, ctx: RobotContext) -> None:
        self.knowledge.forget_intention(robot)
        self.shadows.discard(robot)

    def on_message(self, message, ctx: RobotContext) -> None:
        kind = type(message)
        if kind in (Visit, Intention):
            self.latency_s = max(self.latency_s, ctx.now - message.time)
        if kind is Visit:
            self.knowledge.hear_visit(message.robot, message.vertex, message.time, ctx.now)
            if self.colocation:
                self._track_shadow(message)
        elif kind is Intention:
            self.knowledge.hear_intention(
                message.robot, message.from_vertex, message.vertex, message.expected_arrival,
                message.travel_time, message.time, ctx.now,
            )

