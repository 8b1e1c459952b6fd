"""Liveness on a live clock (ROS-free): silent teammates, and inputs that stop advancing.

`TeammateLiveness` tracks when each teammate was last heard (any team message or heartbeat, in
seconds of run time). A teammate heard once and then silent for more than `timeout_s` is lost
(reported once, so the policy drops its intentions: `Policy.on_teammate_lost`); it is back at its
next message. Needs no monitor: every agent runs its own.

`InputWatchdog` tracks the inputs an agent cannot drive without (pose, scan, clock), each fresh
while its stamp advanced within `timeout_s` of wall time. The agent stops its robot while any is
stale, says which (throttled), and resumes when all are fresh again.
"""

from __future__ import annotations

import math


class TeammateLiveness:
    """Silent-teammate detection for robot `me` of `n_robots` (see the module docstring)."""

    def __init__(self, n_robots: int, me: int, timeout_s: float = 10.0):
        if not timeout_s > 0:
            raise ValueError(f"teammate timeout must be > 0 s, got {timeout_s}")
        self.n_robots = int(n_robots)
        self.me = int(me)
        self.timeout_s = float(timeout_s)
        self.last_heard = [-math.inf] * self.n_robots  # [s] run time
        self.lost: set[int] = set()

    def heard(self, robot: int, now: float) -> bool:
        """`robot` was heard at run time `now` [s]; True when it had been lost (it is back)."""
        if not 0 <= robot < self.n_robots or robot == self.me:
            return False
        self.last_heard[robot] = max(self.last_heard[robot], float(now))
        if robot in self.lost:
            self.lost.discard(robot)
            return True
        return False

    def check(self, now: float) -> list[int]:
        """Teammates that went silent since the last check (each reported once)."""
        out = []
        for r, t in enumerate(self.last_heard):
            if r != self.me and r not in self.lost and math.isfinite(t) and now - t > self.timeout_s:
                self.lost.add(r)
                out.append(r)
        return out

    def silent_for(self, robot: int, now: float) -> float:
        return float(now) - self.last_heard[robot]


class InputWatchdog:
    """Freshness of named inputs on the wall clock (see the module docstring)."""

    def __init__(self, names: tuple[str, ...], timeout_s: float = 1.0):
        if not timeout_s > 0:
            raise ValueError(f"input timeout must be > 0 s, got {timeout_s}")
        self.timeout_s = float(timeout_s)
        self._stamp = dict.fromkeys(names, -math.inf)  # last stamp [s] seen
        self._fresh_at = dict.fromkeys(names, -math.inf)  # [s wall] when it last advanced
        self.stale: tuple[str, ...] = ()

    def fed(self, name: str, stamp: float, wall: float) -> None:
        """Input `name` arrived with stamp `stamp` [s] at wall time `wall` [s]; it counts as
        fresh only when its stamp advanced."""
        if stamp > self._stamp[name]:
            self._stamp[name] = stamp
            self._fresh_at[name] = wall

    def check(self, wall: float) -> tuple[tuple[str, ...], bool]:
        """(stale inputs, whether that set changed since the last check)."""
        stale = tuple(n for n, t in self._fresh_at.items() if wall - t > self.timeout_s)
        changed = stale != self.stale
        self.stale = stale
        return stale, changed

    def age(self, name: str, wall: float) -> float:
        """[s] since `name` last advanced (inf if never)."""
        return wall - self._fresh_at[name]
