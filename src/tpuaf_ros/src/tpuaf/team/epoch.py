"""The run's epoch (ROS time [s] of run time 0) as a team agrees on it, ROS-free.

Every agent that knows the epoch keeps it and re-announces it (latched on /fleet/start), so an
agent that restarts, or joins late, adopts the running epoch instead of starting a new run. Two
announcements can cross (two agents announce before hearing each other): the earliest start
wins, everywhere, so the team converges on one epoch whatever the order of arrival. Crossing
announcements lie seconds apart: a start more than CROSS_WINDOW_S before the one kept is not a
crossing but a stray or hostile announcement (a rogue /fleet/start): ours is KEPT and the
stray start counted in `ignored`.
"""

from __future__ import annotations

import math

# What `RunEpoch.offer` did with a start.
ADOPTED = "adopted"  # the first start heard
EARLIER = "earlier"  # an earlier start than ours: ours moves back to it
KEPT = "kept"  # the same start, or a later one: ours stays
INVALID = "invalid"  # not a finite, non-negative time

# [s] two starts announced before hearing each other lie this close (agents announce
# floor(now) on hearing none within ~start_wait; the master and the network take < 1 s)
CROSS_WINDOW_S = 10.0

# [s] starts closer than this are the same start (float seconds <-> integer ns stamps)
SAME_START_S = 1e-6


class RunEpoch:
    def __init__(self, epoch_s: float | None = None, announcer: str = ""):
        self.epoch_s = epoch_s
        self.announcer = announcer  # who first announced the epoch we keep
        self.ignored = 0  # starts far earlier than ours, not adopted (KEPT)

    @property
    def known(self) -> bool:
        return self.epoch_s is not None

    def offer(self, start_s: float, announcer: str = "") -> str:
        """A start heard (or our own): ADOPTED, EARLIER, KEPT or INVALID."""
        start_s = float(start_s)
        if not math.isfinite(start_s) or start_s < 0:
            return INVALID
        if self.epoch_s is None:
            self.epoch_s, self.announcer = start_s, announcer
            return ADOPTED
        if start_s < self.epoch_s - CROSS_WINDOW_S:
            self.ignored += 1
            return KEPT
        if start_s < self.epoch_s - SAME_START_S:
            self.epoch_s, self.announcer = start_s, announcer
            return EARLIER
        return KEPT
