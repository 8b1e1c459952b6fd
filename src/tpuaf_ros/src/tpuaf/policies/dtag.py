"""DTAG of BASELINES.md: greedy dynamic task assignment over a shared idleness estimate."""

from __future__ import annotations

import numpy as np

from tpuaf.policies.base import Parameter, Policy, register
from tpuaf.policies.common import pick_max, wait_nowhere_to_go
from tpuaf.team.messages import IdlenessEstimate


def _nonneg(x) -> bool:
    return isinstance(x, int | float) and x >= 0


class SharedEstimate:
    """E[v] [s]: grows with time, 0 at a visit, merged with others' estimates by minimum."""

    def __init__(self, n: int, initial: float, t0: float):
        self.values = np.full(n, float(initial))
        self.updated = float(t0)

    def advance(self, now: float) -> np.ndarray:
        self.values += max(0.0, float(now) - self.updated)
        self.updated = max(self.updated, float(now))
        return self.values

    def merge(self, received, sent_at: float, now: float) -> None:
        """E[v] = min(E[v] + elapsed, received[v] + transit time) (the transit term is ours:
        0 without delay, the reference has none)."""
        self.advance(now)
        r = np.asarray(received, dtype=float)
        if r.shape != self.values.shape:
            return  # a message for another map: ignore
        np.minimum(self.values, r + max(0.0, float(now) - float(sent_at)), out=self.values)

    def message(self, robot: int, now: float, next_vertex: int) -> IdlenessEstimate:
        sent = self.values.copy()
        sent[next_vertex] = 0.0  # reservation
        return IdlenessEstimate(robot, float(now), tuple(float(x) for x in sent), int(next_vertex))


@register
class DynamicTaskAssignmentGreedy(Policy):
    """DTAG: argmax over all vertices of U = a E[v] - b path(cv, v) - c |pos(v) - origin|."""

    name = "dtag"
    description = (
        "Dynamic task assignment, greedy: argmax over all vertices of 1.0 E[v] - 10 s/m path "
        "length - 5 s/m distance from the start position; estimates shared, next reserved."
    )
    parameters = {
        "initial_estimate": Parameter(100.0, "initial idleness estimate E[v] [s]", _nonneg),
        "w_idleness": Parameter(1.0, "weight of E[v] in the utility (unitless)", _nonneg),
        "w_path": Parameter(10.0, "cost of the shortest-path length to v [s/m]", _nonneg),
        "w_origin": Parameter(
            5.0, "cost of the straight distance from v to the start [s/m]", _nonneg
        ),
    }

    def start(self, ctx):
        g = ctx.patrol_map.graph
        self.estimate = SharedEstimate(g.num_vertices, self.params["initial_estimate"], ctx.now)
        self.origin = np.asarray(ctx.start_position, dtype=float)
        self.next: int | None = None
        self.replans = 0  # conflicts resolved by re-planning (for tests and logs)
        self.replanned = False  # this decision already yielded once

    def _ensure(self, ctx):
        if not hasattr(self, "estimate"):
            self.start(ctx)

    def utility(self, ctx, here: int) -> np.ndarray:
        g = ctx.patrol_map.graph
        pos = np.asarray(ctx.patrol_map.positions, dtype=float)
        p = self.params
        return (
            p["w_idleness"] * self.estimate.values
            - p["w_path"] * np.asarray(g.distances)[here]
            - p["w_origin"] * np.hypot(*(pos - self.origin).T)
        )

    def choose(self, ctx, here: int, exclude: set[int]) -> int | None:
        u = self.utility(ctx, here)
        cands = [v for v in range(u.size) if v not in exclude]
        if not cands:
            return None
        return pick_max(cands, u[cands], ctx.rng)

    def decide(self, ctx):
        self._ensure(ctx)
        here, now = ctx.current_vertex, ctx.now
        self.estimate.advance(now)
        self.estimate.values[here] = 0.0
        nxt = self.choose(ctx, here, {here})
        self.next = nxt
        if nxt is None:
            wait_nowhere_to_go(ctx)
            return None
        self.replanned = False
        ctx.send(self.estimate.message(ctx.robot, now, nxt))
        return nxt

    def on_message(self, message, ctx):
        self._ensure(ctx)
        if not isinstance(message, IdlenessEstimate) or message.robot == ctx.robot:
            return
        self.estimate.merge(message.estimate, message.time, ctx.now)
        # Only the higher-id robot yields, once per decision: two robots that both yielded on
        # every clash could swap goals forever within one instant (seen with zero delay).
        if (
            self.next is not None
            and message.next_vertex == self.next
            and message.robot < ctx.robot
            and not self.replanned
        ):
            self.replanned = True
            self.replan(ctx, exclude_vertex=self.next)

    def replan(self, ctx, exclude_vertex: int) -> None:
        """The sender heads to my goal: choose again without it, from the vertex last passed.

        Redirecting a moving robot needs the runtime's optional `ctx.change_goal(v)`; without
        it the new goal is only announced and the robot keeps its current goal."""
        here = ctx.current_vertex
        nxt = self.choose(ctx, here, {here, exclude_vertex})
        change = getattr(ctx, "change_goal", None)
        if nxt is None or change is None:
            return
        self.replans += 1
        self.next = nxt
        change(nxt)
        ctx.send(self.estimate.message(ctx.robot, ctx.now, nxt))
