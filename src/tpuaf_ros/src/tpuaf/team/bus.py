"""The team bus of the physics runtime and the fleet's relay: the core's one bus, with Python
messages.

The ROS runtime carries the same typed messages (tpuaf.team.messages) on topics; the bus models
what a radio does to them: every recipient independently loses a message with probability
`loss`, and the others receive it `delay_s` seconds after it was sent. The loss draws, the
counters, the live robots and the messages in flight are the core's `tpuaf_core.TeamBus` (the
graph loop's bus too); this adapter keeps each Python message under the id the core carries. A
runtime releases the messages in flight into `ready` when they are due (in due order, then send
order) and then hands `ready` to the robots, counting what it delivered; in runs with faults
the team's `tpuaf_core.TeamLiveness` hands them over instead (`deliver_through`), feeding each
recipient's liveness. The ready messages stay in the core until `ready` is asked for.
"""

from __future__ import annotations

import itertools
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np
import tpuaf_core

BUS_STREAM_KEY = 1  # the bus's losses: numpy default_rng([seed, 1, *subkey])


@dataclass
class BusStats:
    sent: int = 0
    delivered: int = 0
    lost: int = 0


def bus_stream(seed: int, *subkey: int) -> tpuaf_core.NumpyPcg64:
    """The loss stream of a run's bus: numpy default_rng([seed, 1, *subkey]) (the graph loop's
    and the physics runtime's; the fleet relay adds its own subkey)."""
    generator = np.random.default_rng([int(seed), BUS_STREAM_KEY, *map(int, subkey)])
    return tpuaf_core.NumpyPcg64(generator.bit_generator.state)


class TeamBus:
    def __init__(self, n_robots: int, delay_s: float, loss: float,
                 stream: tpuaf_core.NumpyPcg64):
        self._core = tpuaf_core.TeamBus(int(n_robots), float(delay_s), float(loss), stream)
        self.n_robots = int(n_robots)
        self.delay_s = float(delay_s)
        self.loss = float(loss)
        self._ready: deque[tuple[Any, list[int]]] = deque()  # (message, recipients) taken
        self._messages: dict[int, Any] = {}  # id -> message in flight
        self._ids = itertools.count()

    @property
    def core(self) -> tpuaf_core.TeamBus:
        """The core's bus (what TeamLiveness drops a dead robot from and delivers from)."""
        return self._core

    @property
    def ready(self) -> deque[tuple[Any, list[int]]]:
        """(message, recipients) to deliver now, in order (messages sent while these are
        delivered join at the next look)."""
        if self._core.ready_count:
            self._take_ready()
        return self._ready

    @property
    def has_ready(self) -> bool:
        return bool(self._ready) or self._core.ready_count > 0

    def deliver_through(self, team: tpuaf_core.TeamLiveness, now: float, deliver) -> None:
        """Every ready message through the team's delivery rule (TeamLiveness.deliver_ready:
        each live recipient hears the sender, then `deliver(recipient, message)`), counted."""
        if self._ready:
            raise RuntimeError("messages taken from the bus must be delivered by their taker")
        messages = self._messages
        team.deliver_ready(now, lambda key: getattr(messages[key], "robot", -1),
                           lambda r, key: deliver(r, messages[key]), messages.pop)

    @property
    def stats(self) -> BusStats:
        sent, delivered, lost = self._core.stats
        return BusStats(sent=sent, delivered=delivered, lost=lost)

    def count_delivered(self, pairs: int) -> None:
        """(message, recipient) pairs handed to live robots."""
        self._core.count_delivered(int(pairs))

    def set_dead(self, robot: int) -> None:
        """Robot `robot` died: it receives nothing sent from now on."""
        self._core.set_alive(int(robot), False)

    @property
    def in_flight(self) -> int:
        """Messages sent and not yet due."""
        return self._core.in_flight

    def send(self, sender: int, message, now: float) -> None:
        """Broadcast at time `now` [s]: ready at once without delay, else in flight."""
        key = next(self._ids)
        if not self._core.send(sender, key, now):
            return  # nobody is to receive it
        self._messages[key] = message

    def next_due_s(self) -> float:
        """[s] when the next message in flight is due (+inf if none)."""
        return self._core.next_due_s()

    def release_next(self) -> None:
        """The next message in flight becomes ready."""
        self._core.release_next()

    def release_due(self, now: float, slack_s: float = 1e-9) -> None:
        """Every message in flight due by `now` [s] (within `slack_s`) becomes ready."""
        if self._core.next_due_s() <= now + slack_s:
            self._core.release_due(now, slack_s)

    def _take_ready(self) -> None:
        messages = self._messages
        for key, recipients in self._core.take_ready():
            self._ready.append((messages.pop(key), recipients))
