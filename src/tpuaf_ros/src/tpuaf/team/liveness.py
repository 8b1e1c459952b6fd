"""Liveness on a live clock (ROS-free): silent teammates, and inputs that stop advancing.

`TeammateLiveness` (the C++ core's) tracks when each teammate was last heard (any team message
or heartbeat, in seconds of run time). A teammate heard once and then silent for `timeout_s` is lost (reported
once, so the policy drops its intentions: `Policy.on_teammate_lost`); it is back at its next
message. Needs no monitor: every robot's `RobotMachine` holds its own, fed by its runtime.

`heartbeat_links` is the heartbeat traffic of the graph and physics runtimes: every live robot
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


def TeammateLiveness(n_robots: int, me: int,  # noqa: N802 (it makes the core's class)
                     timeout_s: float = LIVENESS_DEFAULTS.teammate_timeout_s):
    """Silent-teammate detection for robot `me` of `n_robots` (see the module docstring): the
    core's `tpuaf_core.TeammateLiveness` (robot_protocol.cpp), the one every robot's protocol
    holds (`heard(robot, t)`, `check(now)`, `lost`, `last_heard`, `silent_for(robot, now)`)."""
    import tpuaf_core

    if not timeout_s > 0:
        raise ValueError(f"teammate timeout must be > 0 s, got {timeout_s}")
    return tpuaf_core.TeammateLiveness(int(n_robots), int(me), float(timeout_s))


def heartbeat_streams(n_robots: int, seed: int, loss: float) -> list:
    """Each sender's random stream of heartbeat losses, numpy default_rng([seed, 4, sender])
    (apart from the team messages' stream); none without loss (nothing is drawn)."""
    import tpuaf_core

    if not loss > 0:
        return []
    return [tpuaf_core.NumpyPcg64(np.random.default_rng([seed, 4, j]).bit_generator.state)
            for j in range(n_robots)]


def heartbeat_links(n_robots: int, duration_s: float, timeout_s: float, delay_s: float = 0.0,
                    loss: float = 0.0, seed: int = 0, period_s: float = HEARTBEAT_PERIOD_S):
    """The heartbeats of `n_robots` robots over a run of `duration_s` [s] (see the module
    docstring): the core's `tpuaf_core.HeartbeatLinks` (heartbeats.cpp), the one the graph
    runtime's loop runs.

    Robot j sends heartbeat k at k * period_s [s] for every k with k * period_s <= its death
    time (a robot dying at t has sent the heartbeat of that instant) and <= duration_s. Robot i
    hears it at k * period_s + delay_s unless lost (one draw per sender, recipient and
    heartbeat, `heartbeat_streams`). Memory: about 4 (1 - loss) N^2 duration_s / period_s bytes
    (1.3 MB at N = 12 for 1 h)."""
    import tpuaf_core

    if not (period_s > 0 and math.isfinite(period_s)):
        raise ValueError(f"heartbeat period must be a finite number > 0 s, got {period_s}")
    if not timeout_s > 0:
        raise ValueError(f"teammate timeout must be > 0 s, got {timeout_s}")
    if not 0.0 <= loss <= 1.0:
        raise ValueError(f"heartbeat loss probability must be in [0, 1], got {loss}")
    return tpuaf_core.HeartbeatLinks(int(n_robots), float(duration_s), float(timeout_s),
                                     float(delay_s), float(loss), float(period_s),
                                     heartbeat_streams(int(n_robots), int(seed), float(loss)))


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
