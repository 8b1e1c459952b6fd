"""In-process team bus of the batch runtime: broadcast with a fixed delay and seeded loss.

The ROS runtime carries the same typed messages (tpuaf.team.messages) on topics; this bus models what
a radio does to them: every recipient independently loses a message with probability `loss`,
and the others receive it `delay_s` seconds after it was sent. The bus keeps the messages in
flight itself (`in_flight`, a heap); a runtime
releases them into `ready` when they are due (in due order, then send order) and then hands `ready` to the robots.
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections import deque
from dataclasses import dataclass

import numpy as np


@dataclass
class BusStats:
    sent: int = 0
    delivered: int = 0
    lost: int = 0


class TeamBus:
    def __init__(self, n_robots: int, delay_s: float, loss: float, rng: np.random.Generator):
        if not (delay_s >= 0 and np.isfinite(delay_s)):
            raise ValueError(f"message delay must be a finite number >= 0 s, got {delay_s}")
        if not 0.0 <= loss <= 1.0:
            raise ValueError(f"message loss probability must be in [0, 1], got {loss}")
        self.n_robots = n_robots
        self.delay_s = float(delay_s)
        self.loss = float(loss)
        self.rng = rng
        self.alive = np.ones(n_robots, dtype=bool)
        self.stats = BusStats()
        self.ready: deque = deque()  # (message, recipients) to deliver now
        self.in_flight: list = []  # heap of (due time [s], send order, message, recipients)
        self._order = itertools.count()

    def recipients(self, sender: int) -> list[int]:
        keep = self.alive.copy()
        keep[sender] = False
        if self.loss > 0:
            lost = self.rng.random(self.n_robots) < self.loss
            self.stats.lost += int(np.count_nonzero(keep & lost))
            keep &= ~lost
        return np.flatnonzero(keep).tolist()

    def send(self, sender: int, message, now: float) -> None:
        """Broadcast at time `now` [s]: ready at once without delay, else in flight."""
        self.stats.sent += 1
        recipients = self.recipients(sender)
        if not recipients:
            return
        if self.delay_s == 0:
            self.ready.append((message, recipients))
        else:
            heapq.heappush(self.in_flight,
                           (now + self.delay_s, next(self._order), message, recipients))

    def next_due_s(self) -> float:
        """[s] when the next message in flight is due (+inf if none)."""
        return self.in_flight[0][0] if self.in_flight else math.inf

    def release_next(self) -> None:
        """The next message in flight becomes ready."""
        _, _, message, recipients = heapq.heappop(self.in_flight)
        self.ready.append((message, recipients))

    def release_due(self, now: float, slack_s: float = 1e-9) -> None:
        """Every message in flight due by `now` [s] (within `slack_s`) becomes ready."""
        while self.in_flight and self.in_flight[0][0] <= now + slack_s:
            self.release_next()
