"""In-process team bus of the batch runtime: broadcast with a fixed delay and seeded loss.

The ROS runtime carries the same typed messages (tpuaf.team.messages) on topics; this bus models what
a radio does to them: every recipient independently loses a message with probability `loss`,
and the others receive it `delay_s` seconds after it was sent.
"""

from __future__ import annotations

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

    def recipients(self, sender: int) -> list[int]:
        keep = self.alive.copy()
        keep[sender] = False
        if self.loss > 0:
            lost = self.rng.random(self.n_robots) < self.loss
            self.stats.lost += int(np.count_nonzero(keep & lost))
            keep &= ~lost
        return np.flatnonzero(keep).tolist()

    def send(self, sender: int, message, now: float, schedule) -> None:
        """Broadcast; `schedule(time, message, recipients)` queues a delayed delivery."""
        self.stats.sent += 1
        recipients = self.recipients(sender)
        if not recipients:
            return
        if self.delay_s == 0:
            self.ready.append((message, recipients))
        else:
            schedule(now + self.delay_s, message, recipients)
