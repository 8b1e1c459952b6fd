"""Team messages from the bus, checked and put on our clock before a policy sees them (ROS-free).

ROS 1 has no authentication: anything on the team topics reaches every agent. `TeamInbox.accept`
refuses what cannot be true: an unknown robot (index outside 0..N-1, or our own index), vertices
outside the map, non-finite numbers, negative travel times or bids, an estimate of the wrong
length, times farther than `max_skew_s` from our clock (far future or far past: `clock_problem`,
the monitor's check too), and a sender's messages beyond `rate_per_s` after a burst of `burst`
(`RateLimit`, a flood).

Clock skew: each teammate's offset is estimated from its stamps as the median, over the last
`window` messages, of (stamp - our time at receipt) (= its clock offset minus the transport
delay). With `correct_skew` (wall clock; a shared /clock cannot skew) every time of the message
is shifted by that offset (when above `deadband_s`), and a time still in our future is clamped to our now, so a robot whose
clock runs ahead can no longer suppress our own visits. `skewed()` names the teammates whose
offset exceeds `skew_warn_s` (the agent warns; docs/HARDWARE.md: chrony).
"""

from __future__ import annotations

import dataclasses
import math
from collections import deque
from dataclasses import dataclass
from typing import Any

from tpuaf.team import messages as m


@dataclass
class InboxConfig:
    """Limits of the team message checks (units in the comments)."""

    skew_warn_s: float = 1.0  # [s] a teammate clock offset above this is named in a warning
    max_skew_s: float = 30.0  # [s] a message time farther than this from our clock is refused
    max_horizon_s: float = 86400.0  # [s] an expected arrival this far from sending is refused
    window: int = 15  # messages per teammate in the median offset estimate
    correct_skew: bool = True  # shift teammates' times by their estimated offset
    deadband_s: float = 0.05  # [s] offsets below this (transport delay) are left alone
    rate_per_s: float = 20.0  # [msg/s] a sender's sustained rate beyond which ...
    burst: int = 40  # ... (after a burst of this many messages) its messages are refused


def clock_problem(t: float, now: float, max_skew_s: float,
                  max_past_s: float | None = None) -> str | None:
    """Why a message time `t` [s] cannot be true at our time `now` [s] (None: it can): farther
    than `max_skew_s` from our clock (`max_past_s` in the past, when given: a receiver that may
    trail the clock). The one clock check of the agents (TeamInbox) and the monitor
    (tpuaf.measure.traffic)."""
    if not math.isfinite(t):
        return f"time {t!r} is not finite"
    past = max_skew_s if max_past_s is None else max_past_s
    if t - now > max_skew_s or now - t > past:
        return (f"time {t:.3f} s is {t - now:+.1f} s from our clock (beyond "
                f"{max_skew_s:g} s ahead or {past:g} s behind)")
    return None


class RateLimit:
    """Token bucket per sender: `burst` messages at once, then `rate_per_s` [msg/s] of the
    clock given (the sender's stamps); `allow(sender, now)` is False for a message beyond it."""

    def __init__(self, rate_per_s: float, burst: int):
        self.rate_per_s = float(rate_per_s)
        self.burst = float(burst)
        self._tokens: dict = {}  # sender -> (tokens, time [s])

    def allow(self, sender: Any, now: float) -> bool:
        tokens, then = self._tokens.get(sender, (self.burst, now))
        tokens = min(self.burst, tokens + max(0.0, now - then) * self.rate_per_s)
        ok = tokens >= 1.0
        self._tokens[sender] = (tokens - 1.0 if ok else tokens, max(now, then))
        return ok


class SenderCheck:
    """Which ROS node may speak for each robot (ROS 1 has no authentication; the publisher's
    caller id comes in the connection header, live and in a bag): a node in a robot's namespace
    (`/robot_1/...`) speaks for that robot only and (re)binds it; outside every robot namespace,
    the first node heard for a robot is its sender (a relay, a bag of unknown names). The one
    sender rule of the agents (TeamInbox) and the monitor (tpuaf.measure.traffic)."""

    def __init__(self, n_robots: int, names: list[str] | None = None):
        # "/robot_1/": the namespace of each robot's nodes (None: names unknown)
        self.spaces = [f"/{name.strip('/')}/" for name in names] if names else None
        self._sender: list[str | None] = [None] * int(n_robots)  # bound sender of each robot

    def ok(self, robot: int, sender: str) -> bool:
        """May node `sender` speak for `robot` (0 <= robot < n)?"""
        node = sender if sender.endswith("/") else sender + "/"
        if self.spaces is not None:
            owner = next((r for r, space in enumerate(self.spaces) if node.startswith(space)),
                         None)
            if owner is not None:
                if owner == robot:
                    self._sender[robot] = sender  # the robot's own node (re)binds
                return owner == robot
        if self._sender[robot] is None:
            self._sender[robot] = sender
        return self._sender[robot] == sender


class SkewEstimator:
    """Median lead (message time - receipt time [s]) of each robot over the last `window`."""

    def __init__(self, window: int = 15):
        self.window = int(window)
        self._leads: dict[int, deque] = {}
        self._offset: dict[int, float] = {}

    def add(self, robot: int, lead_s: float) -> None:
        q = self._leads.get(robot)
        if q is None:
            q = self._leads[robot] = deque(maxlen=self.window)
        q.append(float(lead_s))
        s = sorted(q)
        k = len(s)
        self._offset[robot] = s[k // 2] if k % 2 else 0.5 * (s[k // 2 - 1] + s[k // 2])

    def offset(self, robot: int) -> float:
        """[s] how far `robot`'s clock runs ahead of ours (0 until heard)."""
        return self._offset.get(robot, 0.0)

    def offsets(self) -> dict[int, float]:
        return dict(self._offset)


class TeamInbox:
    """Checks and re-times team messages for robot `me` of a team of `n_robots` on a map of
    `n_vertices` vertices; see the module docstring."""

    def __init__(self, n_robots: int, n_vertices: int, me: int,
                 config: InboxConfig | None = None, names: list[str] | None = None):
        self.n_robots = int(n_robots)
        self.n_vertices = int(n_vertices)
        self.n_lanes = 0  # the team's lanes, when this robot runs the lane layer (LaneClaim)
        self.me = int(me)
        self.config = config or InboxConfig()
        self.skew = SkewEstimator(self.config.window)
        self.rate = RateLimit(self.config.rate_per_s, self.config.burst)
        self.senders = SenderCheck(self.n_robots, names)
        self.rejected = 0
        self.rejections: dict[str, int] = {}  # reason (tpuaf.measure.traffic.REASONS) -> count

    def reject(self, reason: str) -> None:
        """Count a refusal (`reason`: sender, malformed, unknown_robot, clock, rate)."""
        self.rejected += 1
        self.rejections[reason] = self.rejections.get(reason, 0) + 1

    def sender_problem(self, robot: int, sender: str | None) -> str | None:
        """Why node `sender` may not speak for `robot` (counted), or None (SenderCheck; no
        caller id known: None)."""
        if not sender or not 0 <= robot < self.n_robots or self.senders.ok(robot, sender):
            return None
        self.reject("sender")
        return f"published by node {sender}, not by robot {robot}'s"

    # -- checks ---------------------------------------------------------------------------

    def problem(self, msg: Any, now: float) -> str | None:
        """Why `msg` cannot be true at our time `now` [s], or None. Does not learn the skew.
        Structure (ids, vertices, finite values): messages.problem; here: our own index and
        the clock (times too far from ours)."""
        return self._problem(msg, now)[1]

    def _problem(self, msg: Any, now: float) -> tuple[str, str | None]:
        """(counted reason, why) of problem()."""
        why = m.problem(msg, self.n_robots, self.n_vertices, self.n_lanes)
        if why is not None:
            return "malformed", why
        if msg.robot == self.me:
            return "unknown_robot", f"robot index {msg.robot} is ours"
        t = msg.time
        why = clock_problem(t, now, self.config.max_skew_s)
        if why is not None:
            return "clock", why
        if type(msg) is m.Intention and abs(msg.expected_arrival - t) > self.config.max_horizon_s:
            return "clock", f"expected arrival {msg.expected_arrival - t:+.1f} s after sending"
        return "", None

    # -- intake ---------------------------------------------------------------------------

    def observe(self, robot: int, stamp_time: float, now: float) -> None:
        """A stamp of `robot` (any message, e.g. a heartbeat) received at our time `now` [s]."""
        if 0 <= robot < self.n_robots and robot != self.me and math.isfinite(stamp_time):
            lead = stamp_time - now
            if abs(lead) <= self.config.max_skew_s:
                self.skew.add(robot, lead)

    def accept(self, msg: Any, now: float) -> tuple[Any | None, str | None]:
        """(message on our clock, None) or (None, the reason it is refused)."""
        reason, why = self._problem(msg, now)
        # the rate on the sender's stamps (within max_skew_s of ours): receipts come in bursts
        if why is None and not self.rate.allow(msg.robot, msg.time):
            reason, why = "rate", (f"robot {msg.robot} sends beyond {self.config.rate_per_s:g} "
                                   f"messages/s (after a burst of {self.config.burst})")
        if why is not None:
            self.reject(reason)
            return None, why
        r = msg.robot
        self.skew.add(r, msg.time - now)
        shift = self.skew.offset(r) if self.config.correct_skew else 0.0
        if abs(shift) < self.config.deadband_s:
            shift = 0.0
        changes = {"time": min(msg.time - shift, now)}
        if type(msg) is m.Intention:
            changes["expected_arrival"] = msg.expected_arrival - shift
        elif type(msg) is m.LaneClaim:
            changes["stamp"] = msg.stamp - shift  # the request, on the sender's clock too
        return dataclasses.replace(msg, **changes), None

    def skewed(self) -> dict[int, float]:
        """{robot: offset [s]} of the teammates whose clock offset exceeds skew_warn_s."""
        lim = self.config.skew_warn_s
        return {r: o for r, o in self.skew.offsets().items() if abs(o) > lim}
