"""Learned travel times: the team measures each edge's traversals and the plan follows them.

Every robot hears every teammate's Intention (leaving `from_vertex` for `vertex`: departure at
expected_arrival - travel_time [s]) and Visit (arrived at `vertex` at `time` [s]), and its own.
An Intention for an edge followed by the same robot's Visit of its far end is one traversal of
that edge; the team's traversals feed one EdgeDurations (navigation/travel_time.py): its
measured median replaces the model's duration once an edge was driven MIN_SAMPLES times. A
traversal is measured with the turn at its first vertex; the plan map's `turns` for the way
the robot arrived there (its previous traversal) are taken off, so that the samples are the
edge's own time whichever way robots arrive (a robot turning back is not an edge slower).
When a learned duration differs from the plan's by more than RETIME_TOLERANCE, the robot
re-times its plan map (lengths = plan speed x duration), at most once per RETIME_PERIOD_S.

The graph runtime drives each edge in exactly its planned time, so there the learning changes
nothing; it matters in physics and on robots (docs/RUNTIMES.md, "Learned travel times").
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

from tpuaf.navigation.travel_time import MIN_SAMPLES, EdgeDurations
from tpuaf.team.messages import Intention, Visit

RETIME_TOLERANCE = 0.10  # re-time when a learned duration is off the plan's by more than 10 %
RETIME_PERIOD_S = 60.0  # [s] at most one re-timing per minute of run time


class LearnedTravel:
    """The team's measured edge durations on `plan_map` (whose length / nominal speed is the
    model's duration [s] of each edge) and the re-timed plan they give."""

    def __init__(self, plan_map: Any, min_samples: int = MIN_SAMPLES):
        self.plan_map = plan_map
        self.speed = float(plan_map.settings.nominal_speed)  # [m/s]
        graph = plan_map.graph  # resolved lengths [m] (a declared NaN is the straight line)
        self._planned = {(min(int(i), int(j)), max(int(i), int(j))):
                         graph.edge_length(int(i), int(j)) / self.speed
                         for i, j, _ in plan_map.edges}
        self.durations = EdgeDurations(self._planned, min_samples=min_samples)
        # robot -> (u, v, departure [s], the turn at u [s]: plan_map.turns)
        self._legs: dict[int, tuple[int, int, float, float]] = {}
        self._arrived: dict[int, tuple[int, int]] = {}  # robot -> its last traversal (w, u)
        self._last_retime = -math.inf
        self.retimes = 0
        self.traversals = 0

    def observe(self, message: Any) -> None:
        """A team message (any robot's, its own included)."""
        if isinstance(message, Intention):
            u, v = int(message.from_vertex), int(message.vertex)
            if (min(u, v), max(u, v)) in self._planned:
                departure = float(message.expected_arrival) - float(message.travel_time)
                w, at = self._arrived.get(int(message.robot), (-1, -1))
                turn = self.plan_map.turns.get((w, u, v), 0.0) if at == u else 0.0
                self._legs[int(message.robot)] = (u, v, departure, turn)
            else:  # a multi-edge leg, or a stay: no single edge to time
                self._legs.pop(int(message.robot), None)
        elif isinstance(message, Visit):
            leg = self._legs.pop(int(message.robot), None)
            if leg is not None and leg[1] == int(message.vertex):
                self._arrived[int(message.robot)] = (leg[0], leg[1])
                seconds = float(message.time) - leg[2]
                if seconds > 0 and math.isfinite(seconds):
                    # the turn off, never below half the drive (a turn figure larger than
                    # the drive is the model's error, not the edge's time)
                    self.durations.add(leg[0], leg[1], max(seconds - leg[3], 0.5 * seconds))
                    self.traversals += 1

    def retimed_map(self, now_s: float) -> Any | None:
        """A plan map on the learned durations when one differs from the current plan's by more
        than RETIME_TOLERANCE (None: keep the plan; at most once per RETIME_PERIOD_S)."""
        if now_s - self._last_retime < RETIME_PERIOD_S:
            return None
        learned = self.durations.as_dict()
        if all(abs(learned[e] - planned) <= RETIME_TOLERANCE * planned
               for e, planned in self._planned.items()):
            return None
        self._last_retime = now_s
        self._planned = learned
        self.retimes += 1
        edges = [(i, j, self.speed * learned[(min(int(i), int(j)), max(int(i), int(j)))])
                 for i, j, _ in self.plan_map.edges]
        self.plan_map = replace(self.plan_map, edges=edges)
        return self.plan_map

    def rebase(self, plan_map: Any) -> None:
        """The plan's graph changed (a lane blocked, robot/lanes.py): re-time `plan_map` from
        the next decision on (its model durations are the plan's until then)."""
        graph = plan_map.graph
        self.plan_map = plan_map
        self._planned = {(min(int(i), int(j)), max(int(i), int(j))):
                         graph.edge_length(int(i), int(j)) / self.speed
                         for i, j, _ in plan_map.edges}
        for edge, seconds in self._planned.items():  # a new edge (a bypass): the model's time
            self.durations.model.setdefault(edge, seconds)
        self._last_retime = -math.inf

    def summary(self) -> dict:
        """How far the learned durations moved from the model's (for summaries)."""
        learned = [e for e in self.durations.model
                   if self.durations.samples(*e) >= self.durations.min_samples]
        ratios = sorted(self.durations.duration(*e) / self.durations.model[e] for e in learned)
        return {"traversals": self.traversals, "learned_edges": len(learned),
                "retimes": self.retimes,
                "median_learned_over_model": ratios[len(ratios) // 2] if ratios else None}
