"""Team-message relay of the ROS fleet (ROS-free): the batch TeamBus model between agents.

Agent i talks on its own team namespace (/team_agents/<prefix>i); the relay node hands each
message it hears from agent s to this model, which decides, as the batch runtime's TeamBus
(tpuaf.team.bus: each recipient independently loses a message with probability `loss`, the
others get it `delay_s` seconds of run time later), who receives it and when. The node delivers
what `due(now)` returns on the recipients' namespaces and mirrors every original message on
/team (monitor, bag) unaltered.
"""

from __future__ import annotations

from typing import Any

from tpuaf.team.bus import BusStats, TeamBus, bus_stream


class RelayModel:
    def __init__(self, n_robots: int, delay_s: float, loss: float, seed: int):
        # The batch runtimes draw their losses from [seed, 1]; the relay from [seed, 1, 7].
        self.bus = TeamBus(n_robots, delay_s, loss, bus_stream(seed, 7))

    @property
    def stats(self) -> BusStats:
        return self.bus.stats

    def submit(self, sender: int, message: Any, now: float) -> None:
        """A message robot `sender` broadcast at run time `now` [s]."""
        if not 0 <= sender < self.bus.n_robots:
            return  # not one of the team (a malformed or foreign message)
        self.bus.send(sender, message, now)

    def due(self, now: float) -> list[tuple[int, Any]]:
        """(recipient, message) pairs to deliver at run time `now`, in sending order."""
        self.bus.release_due(now)
        out = []
        while self.bus.ready:
            msg, recipients = self.bus.ready.popleft()
            out += [(r, msg) for r in recipients]
        self.bus.count_delivered(len(out))
        return out

    def pending(self) -> int:
        return self.bus.in_flight
