"""Lane locks, decentralised (ROS-free; the argument is in docs/LANES.md).

Every robot keeps its own `LaneLocks`: its claim (the lane it asks for or holds, the request's
stamp) and the latest `LaneClaim` heard from each teammate. The rule, the same on every robot:

- a robot holds at most one lane and asks for a lane only at a waiting spot, outside every
  lane, holding none (it releases the lane it held when it reaches a waiting spot);
- the claims on a lane are ordered holders first, then by request stamp, then robot index;
  a robot enters (and holds) the lane when its own claim is first of those it knows, not
  earlier than `settle_s` after its request (claims sent meanwhile arrive);
- a claim is sent on every change and re-announced every `reannounce_s` (message loss);
  the claims of a teammate the liveness rule calls lost (team/liveness.py) are ignored, so a
  dead holder's lane is free after the teammate timeout.

Waiting robots hold nothing, so no robot waits for a waiting robot to release a lock: the
waits-for graph has edges only from waiting robots to holders, or to waiting robots of an
earlier (stamp, index), and has no cycle.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from tpuaf.team.messages import LaneClaim

SETTLE_S = 0.5  # [s] after a request before entering: claims sent meanwhile arrive
REANNOUNCE_S = 1.0  # [s] a robot repeats its claim this often (the heartbeat period)


def claim_order(claim: LaneClaim) -> tuple:
    """The queue order on a lane: holders first, then earliest request, then lowest robot."""
    return (not claim.held, claim.stamp, claim.robot)


class LaneLocks:
    """Robot `robot`'s view of the team's lane claims (see the module docstring)."""

    def __init__(self, robot: int, send: Callable[[LaneClaim], None],
                 is_lost: Callable[[int], bool] = lambda r: False,
                 settle_s: float = SETTLE_S, reannounce_s: float = REANNOUNCE_S):
        self.robot = int(robot)
        self._send = send
        self._is_lost = is_lost
        self.settle_s = float(settle_s)
        self.reannounce_s = float(reannounce_s)
        self.mine = LaneClaim(self.robot, -1, 0.0, False, 0.0)
        self.claims: dict[int, LaneClaim] = {}  # teammate -> its latest claim
        self.previous: dict[int, LaneClaim] = {}  # teammate -> the claim before (where it was)
        self._next_announce = -math.inf
        self.waits = 0  # requests that were not granted at once
        self.wait_s = 0.0  # [s] from those requests to their grant
        self.entries = 0  # lanes entered (granted)
        self._waiting = False
        self.position = (math.nan, math.nan)  # [m] the robot's, sent with every claim

    @property
    def held(self) -> int:
        """The lane held, -1 when none."""
        return self.mine.lane if self.mine.held else -1

    def _set(self, lane: int, stamp: float, held: bool, now: float,
             leg: tuple[int, int] = (-1, -1)) -> None:
        self.mine = LaneClaim(self.robot, int(lane), float(stamp), bool(held), float(now),
                              (int(leg[0]), int(leg[1])), self.position)
        self.announce(now)

    def announce(self, now: float) -> None:
        """Send the claim (stamped now) and schedule the next re-announcement."""
        m = self.mine
        self.mine = LaneClaim(m.robot, m.lane, m.stamp, m.held, float(now), m.leg, self.position)
        self._next_announce = now + self.reannounce_s
        self._send(self.mine)

    def tick(self, now: float) -> None:
        """Re-announce when due."""
        if now >= self._next_announce:
            self.announce(now)

    def hold(self, lane: int, now: float) -> None:
        """Hold `lane` at once (a robot that starts inside it)."""
        self._set(lane, -math.inf if lane >= 0 else 0.0, lane >= 0, now)

    def drive(self, lane: int, leg: tuple[int, int], now: float) -> None:
        """The robot drives the edge `leg` (u, v) of `lane`: announce it (a held lane's leg, or
        a one-way lane entered without a lock, then held: no teammate asks for it)."""
        m = self.mine
        if m.lane == lane and m.held:
            if m.leg != tuple(leg):
                self._set(lane, m.stamp, True, now, leg)
        elif m.lane < 0 or not m.held:
            if self._waiting:
                self._waiting = False
            self._set(lane, now, True, now, leg)

    def lost_in(self, robot: int) -> LaneClaim | None:
        """Teammate `robot`'s last claim when it held a lane, driving a known leg (where its
        body lies if it died), else None."""
        claim = self.claims.get(int(robot))
        if claim is None or not claim.held or claim.lane < 0 or min(claim.leg) < 0:
            return None
        return claim

    def release(self, now: float) -> None:
        """Leave every lane (at a waiting spot): the claim becomes 'none'."""
        if self.mine.lane >= 0:
            if self._waiting:
                self._waiting = False
            self._set(-1, now, False, now)

    def on_claim(self, claim: LaneClaim) -> None:
        """A teammate's claim; an older one than we have is ignored (delayed messages)."""
        if claim.robot == self.robot:
            return
        old = self.claims.get(claim.robot)
        if old is None or claim.time >= old.time:
            self.claims[claim.robot] = claim
            if old is not None:
                self.previous[claim.robot] = old

    def last_positions(self, robot: int) -> list[tuple[float, float]]:
        """Where teammate `robot` announced it was in its last two claims [m] (fewer when not
        heard twice; NaN positions left out)."""
        claims = [self.previous.get(int(robot)), self.claims.get(int(robot))]
        return [c.position for c in claims
                if c is not None and all(math.isfinite(x) for x in c.position)]

    def queue(self, lane: int) -> list[LaneClaim]:
        """The known live claims on `lane` (own included), in the queue's order."""
        out = [c for r, c in self.claims.items() if c.lane == lane and not self._is_lost(r)]
        if self.mine.lane == lane:
            out.append(self.mine)
        return sorted(out, key=claim_order)

    def may_enter(self, lane: int, now: float) -> bool:
        """At a waiting spot, wanting `lane`: ask for it if not yet asked (releasing any other),
        and True when it is ours to enter (then held)."""
        m = self.mine
        if m.lane == lane and m.held:
            return True
        if m.lane != lane:
            self._set(lane, now, False, now)
            m = self.mine
        first = self.queue(lane)[0]
        if now - m.stamp < self.settle_s or first.robot != self.robot:
            if not self._waiting and now - m.stamp >= self.settle_s:
                self._waiting = True
                self.waits += 1
            return False
        if self._waiting:
            self.wait_s += now - m.stamp
            self._waiting = False
        self.entries += 1
        self._set(lane, m.stamp, True, now, m.leg)
        return True
