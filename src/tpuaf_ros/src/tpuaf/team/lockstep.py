"""Team messages in a lock-step fleet, handled the same way run after run (ROS-free).

In lock-step the simulator waits after each pose tick until every live agent has answered it,
and, with the team barrier (tpuaf_stage `~lockstep_team`), until every team message sent before
those answers has reached every live teammate: each agent reports its counts (`counts`: the tick
answered last, the team messages it sent, those it received from each teammate's own node) after
each answer and each receipt. An agent handles the messages at its next tick, not in the
callbacks' arbitrary interleaving: `due(t)` gives, in one order (stamp, sender, topic, order of
arrival on that topic), every message stamped before the tick at run time t [s] - those sent
while the teammates handled earlier ticks (a message is stamped with the run time of the tick it
was sent at); one sent at tick t itself waits for the next tick, whether or not it has come yet.
docs/FLEET.md "Reproducibility of lock-step runs".
"""

from __future__ import annotations

import heapq
from typing import Any

TIME_EPS_S = 1e-6  # [s] stamps go through ROS Time (ns): equal ticks compare equal within this


class LockstepTeam:
    """Counts and the queue of team messages of robot `me` in a team of `n_robots`; a message
    stamped more than `max_ahead_s` [s] after the last tick handled is refused at once (it would
    wait in the queue for ever: the clock check, tpuaf.team.inbox.clock_problem)."""

    def __init__(self, n_robots: int, me: int, max_ahead_s: float = float("inf")):
        self.n_robots = int(n_robots)
        self.me = int(me)
        self.max_ahead_s = float(max_ahead_s)
        self._tick: float | None = None  # run time [s] of the last tick handled
        self.sent = 0  # team messages published
        self.received = [0] * self.n_robots  # from each teammate's own node
        self._queue: list = []  # heap of (stamp [s], sender, topic, arrival, item)
        self._arrivals = 0

    def on_sent(self) -> None:
        self.sent += 1

    def on_received(self, robot: int) -> None:
        """A team message from `robot`'s own node (the sender check passed) arrived."""
        if 0 <= robot < self.n_robots:
            self.received[robot] += 1

    def put(self, stamp_s: float, robot: int, topic: int, item: Any) -> bool:
        """Queue `item` (a team message or a heartbeat) stamped `stamp_s` [s of run time] from
        `robot`; `topic`: its topic's rank (the order of messages of one sender and stamp).
        False (not queued): stamped too far ahead of the last tick, or not a finite time."""
        if not stamp_s == stamp_s or (self._tick is not None
                                      and not stamp_s <= self._tick + self.max_ahead_s):
            return False
        self._arrivals += 1
        heapq.heappush(self._queue, (float(stamp_s), int(robot), int(topic), self._arrivals,
                                     item))
        return True

    def due(self, t: float) -> list[tuple[float, int, Any]]:
        """(stamp, sender, item) of every queued message stamped before run time t [s], in order."""
        self._tick = float(t)
        out = []
        while self._queue and self._queue[0][0] < t - TIME_EPS_S:
            stamp, robot, _, _, item = heapq.heappop(self._queue)
            out.append((stamp, robot, item))
        return out

    def __len__(self) -> int:
        return len(self._queue)

    def counts(self, tick_ns: int) -> list[int]:
        """The simulator's team barrier data (std_msgs/Int64MultiArray): the stamp [ns] of the
        tick answered last, the messages sent, those received from robot 0..n-1."""
        return [int(tick_ns), self.sent, *self.received]
