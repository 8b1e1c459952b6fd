"""Liveness on a live clock (ROS-free): silent teammates, and inputs that stop advancing.

`TeammateLiveness` tracks when each teammate was last heard (any team message or heartbeat, in
seconds of run time). A teammate heard once and then silent for `timeout_s` is lost (reported
once, so the policy drops its intentions: `Policy.on_teammate_lost`); it is back at its next
message. Needs no monitor: every robot's `RobotMachine` holds its own, fed by its runtime.

`HeartbeatLinks` is the heartbeat traffic of the graph and physics runtimes: every live robot
broadcasts a heartbeat every `period_s` (the agent node's ~heartbeat_period), each recipient
loses each one independently with probability `loss` and hears the others `delay_s` later (the
TeamBus model). It is simulated lazily: the losses are drawn up front, per sender, and a runtime
asks only when a liveness check is due (`next_check_s`) and what was heard by then
(`last_arrival_s`), instead of carrying N (N - 1) deliveries a second.

`InputWatchdog` tracks the inputs an agent cannot drive without (pose, scan, clock), each fresh
while its stamp advanced within `timeout_s` of wall time. The agent stops its robot while any is
stale, says which (throttled), and resumes when all are fresh again.
"""

from __future__ import annotations

import math

import numpy as np

from tpuaf.params import LIVENESS_DEFAULTS

HEARTBEAT_PERIOD_S = LIVENESS_DEFAULTS.heartbeat_period_s  # [s] the agent node's ~heartbeat_period


class TeammateLiveness:
    """Silent-teammate detection for robot `me` of `n_robots` (see the module docstring)."""

    def __init__(self, n_robots: int, me: int,
                 timeout_s: float = LIVENESS_DEFAULTS.teammate_timeout_s):
        if not timeout_s > 0:
            raise ValueError(f"teammate timeout must be > 0 s, got {timeout_s}")
        self.n_robots = int(n_robots)
        self.me = int(me)
        self.timeout_s = float(timeout_s)
        self.last_heard = [-math.inf] * self.n_robots  # [s] run time
        self.lost: set[int] = set()

    def heard(self, robot: int, now: float) -> bool:
        """`robot` was heard at run time `now` [s]; True when it had been lost (it is back).
        Nothing newer than the last time heard changes nothing."""
        if not 0 <= robot < self.n_robots or robot == self.me or now <= self.last_heard[robot]:
            return False
        self.last_heard[robot] = float(now)
        if robot in self.lost:
            self.lost.discard(robot)
            return True
        return False

    def check(self, now: float) -> list[int]:
        """Teammates silent for `timeout_s` by run time `now` [s], not reported before (each
        is reported once)."""
        out = []
        timeout = self.timeout_s
        for r, t in enumerate(self.last_heard):
            # now >= t + timeout, computed as the runtimes compute the due time of a check
            if r != self.me and r not in self.lost and math.isfinite(t) and now >= t + timeout:
                self.lost.add(r)
                out.append(r)
        return out

    def silent_for(self, robot: int, now: float) -> float:
        return float(now) - self.last_heard[robot]


class HeartbeatLinks:
    """Heartbeats of `n_robots` robots over a run of `duration_s` [s] (see the module docstring).

    Robot j sends heartbeat k at k * period_s [s] for every k with k * period_s <= its death
    time (a robot dying at t has sent the heartbeat of that instant) and <= duration_s. Robot i
    hears it at k * period_s + delay_s unless lost. Losses: one draw per (sender, recipient,
    heartbeat) from rng stream [seed, 4, sender], apart from the team messages' stream.
    Memory: about 4 (1 - loss) N^2 duration_s / period_s bytes (1.3 MB at N = 12 for 1 h).
    """

    def __init__(self, n_robots: int, duration_s: float, timeout_s: float, delay_s: float = 0.0,
                 loss: float = 0.0, seed: int = 0, period_s: float = HEARTBEAT_PERIOD_S):
        if not (period_s > 0 and math.isfinite(period_s)):
            raise ValueError(f"heartbeat period must be a finite number > 0 s, got {period_s}")
        if not timeout_s > 0:
            raise ValueError(f"teammate timeout must be > 0 s, got {timeout_s}")
        if not 0.0 <= loss <= 1.0:
            raise ValueError(f"heartbeat loss probability must be in [0, 1], got {loss}")
        self.n_robots = int(n_robots)
        self.period_s = float(period_s)
        self.delay_s = float(delay_s)
        self.timeout_s = float(timeout_s)
        self.loss = float(loss)
        self.seed = int(seed)
        self.count = int(math.floor(float(duration_s) / self.period_s + 1e-9)) + 1  # per sender
        self.last_sent = [self.count - 1] * self.n_robots  # last heartbeat index sent
        # Received heartbeat indices per (recipient, sender) and the positions in them after
        # which the next one comes later than the timeout (a silence); filled per sender.
        self._received: list[list[np.ndarray] | None] = [None] * self.n_robots
        self._silences: list[list[np.ndarray] | None] = [None] * self.n_robots
        self._every: tuple[np.ndarray, np.ndarray] | None = None

    def _arrival(self, k):
        """[s] arrival time of heartbeat index k (an int or an array)."""
        return k * self.period_s + self.delay_s

    def _draw(self, sender: int) -> None:
        n = self.n_robots
        if self.loss == 0.0:  # every heartbeat heard: one array for every link
            if self._every is None:
                every = np.arange(self.count)
                self._every = (every, self._silences_of(every))
            self._received[sender] = [self._every[0]] * n
            self._silences[sender] = [self._every[1]] * n
            return
        rng = np.random.default_rng([self.seed, 4, sender])
        heard = rng.random((n, self.count)) >= self.loss
        received = [np.flatnonzero(row).astype(np.int32) for row in heard]
        self._received[sender] = received
        self._silences[sender] = [self._silences_of(idx) for idx in received]

    def _silences_of(self, received: np.ndarray) -> np.ndarray:
        """Positions p of `received` whose next heartbeat arrives later than the timeout."""
        arrival = self._arrival(received)
        return np.flatnonzero(arrival[1:] > arrival[:-1] + self.timeout_s)

    def _of(self, recipient: int, sender: int) -> tuple[np.ndarray, np.ndarray]:
        if self._received[sender] is None:
            self._draw(sender)
        return self._received[sender][recipient], self._silences[sender][recipient]

    def died(self, robot: int, t: float) -> None:
        """Robot `robot` died at run time t [s]: its heartbeats stop after that instant."""
        k = int(math.floor(t / self.period_s + 1e-9))
        if k * self.period_s > t:
            k -= 1
        self.last_sent[robot] = min(self.last_sent[robot], k)

    def _heard_by(self, recipient: int, sender: int, t: float) -> int:
        """Position in the received indices of the last heartbeat heard by t [s], or -1."""
        received, _ = self._of(recipient, sender)
        k = min(self.last_sent[sender], int(math.floor((t - self.delay_s) / self.period_s + 1e-9)))
        pos = int(np.searchsorted(received, k, side="right")) - 1
        if pos >= 0 and self._arrival(int(received[pos])) > t:
            pos -= 1  # the rounding of the floor above
        return pos

    def last_arrival_s(self, recipient: int, sender: int, t: float) -> float:
        """[s] when `recipient` last heard a heartbeat of `sender` by run time t (-inf: never)."""
        if recipient == sender:
            return -math.inf
        pos = self._heard_by(recipient, sender, t)
        received, _ = self._of(recipient, sender)
        return self._arrival(int(received[pos])) if pos >= 0 else -math.inf

    def next_check_s(self, recipient: int, sender: int, last_heard: float, lost: bool,
                     now: float) -> float:
        """[s] the next time `recipient`'s view of `sender` can change from heartbeats alone,
        after every heartbeat heard by `now` was fed to its liveness (`last_heard` [s], the
        latest of them and of the team messages; `lost`: reported lost). Team messages only
        make a silence start later, so this time is never late (+inf: never)."""
        if recipient == sender:
            return math.inf
        received, silences = self._of(recipient, sender)
        pos = self._heard_by(recipient, sender, now)
        last = int(np.searchsorted(received, self.last_sent[sender], side="right")) - 1
        nxt = pos + 1 if pos + 1 <= last else -1  # the next heartbeat to be heard, if any
        if lost:  # back at the next heartbeat heard
            return self._arrival(int(received[nxt])) if nxt >= 0 else math.inf
        if math.isfinite(last_heard):
            due = last_heard + self.timeout_s
            if nxt < 0 or self._arrival(int(received[nxt])) > due:
                return due  # silent from last_heard on
        elif nxt < 0:
            return math.inf  # never heard, and never will be
        # The first silence after the next heartbeat: one longer than the timeout before the
        # one after it, or the sender's last heartbeat.
        s = int(np.searchsorted(silences, nxt, side="left"))
        end = int(silences[s]) if s < len(silences) and silences[s] < last else last
        return self._arrival(int(received[end])) + self.timeout_s


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
