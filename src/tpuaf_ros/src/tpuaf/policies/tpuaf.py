"""TPUAF (SPEC section 4; paper Sec. 3, Eq. 6-14).

The any-vertex variant `tpuaf_any` was removed (issue 13): it was worse than TPUAF in I_max and X
on every map and team size of the canonical comparison and under faults (docs/STRATEGIES.md).
`any_vertex` stays a switch of the core strategy.

Each robot keeps the shared set Q (latest known visit of every vertex, announced intentions of
the others, stale entries dropped) and its own estimate of every target's uncertainty X_j,
grown with the model of Eq. 2 and cut at every known visit. The bookkeeping, the utility
evaluation and the decision live in the C++ core (`tpuaf_core.TpuafStrategy`,
policies_tpuaf.cpp), the one implementation every runtime runs; this class declares the
parameters and builds it.

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

from tpuaf.policies.base import Parameter, register
from tpuaf.policies.core import CoreStrategyPolicy


def _positive(x) -> bool:
    return isinstance(x, int | float) and x > 0


def new_knowledge(patrol_map, intention_timeout_s: float):
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
    )


@register
class Tpuaf(CoreStrategyPolicy):
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
        "colocation": Parameter(
            True,
            "resolve robots that arrive together before late messages tell (true) or not, "
            "the paper's rule as such (false; platoons form under delay)",
            lambda v: isinstance(v, bool) or v in (0, 1, "true", "false"),
        ),
    }

    @classmethod
    def core_strategy(cls, params: dict, patrol_map, n_robots: int, streams: list):
        import tpuaf_core

        knowledge = new_knowledge(patrol_map, params["intention_timeout_s"])
        form = (tpuaf_core.UtilityForm.EQ14 if params["utility"] == "eq14"
                else tpuaf_core.UtilityForm.EQ13)
        colocation = params["colocation"] in (True, 1, "true")
        return tpuaf_core.TpuafStrategy(knowledge, form, cls.any_vertex, streams, colocation)

    @property
    def knowledge(self):
        """What this robot knows (a copy of the core's TpuafKnowledge: Q, X estimates)."""
        return self.strategy.knowledge(self.robot)
