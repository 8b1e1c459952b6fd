"""What the monitor accepts of the agents' traffic (ROS-free): the agents' own rules
(tpuaf.team.inbox: the clock check, the rate limit) plus the sender, duplicates and starts.

Threat model (docs/FLEET.md "Hostile traffic"): ROS 1 has no authentication; any node on the
master can publish as any robot. `TrafficGuard.check` refuses an agent event

- `unknown_robot`: whose robot index is outside the team;
- `vertex`: a START, GOAL, REACHED or DWELL naming no vertex of the map;
- `sender`: published by another node than the robot's (the publisher's caller id, from the
  connection header, live and in a bag): a node in a robot's namespace (/robot_1/...) speaks
  for that robot only; outside every namespace the first node heard for a robot is its sender
  (tpuaf.team.inbox.SenderCheck, the agents' rule for team messages too);
- `clock`: stamped more than `max_skew_s` after its receipt (the live node's clock, a bag's
  record time; else the newest pose), or more than MAX_PAST_S before it;
- `duplicate`: the same event (kind, vertices, stamp) of the same robot again (a bag written
  twice, a replayed message);
- `rate`: beyond `rate_per_s` of the sender's stamps after a burst of `burst`;

and counts every refusal per robot and reason, with the monitor's own: `implausible` (a
reported visit while the robot's pose is farther than twice the visit radius from the vertex)
and `start` (a run start after the first). Still possible for a hostile node: publish from a
node named in a robot's namespace before the robot's agent (or kill and replace the agent),
within the rate and the clock; ground-truth poses are trusted.
"""

from __future__ import annotations

import math
from collections import deque

from tpuaf.team.inbox import InboxConfig, RateLimit, SenderCheck, clock_problem
from tpuaf.topics import DWELL, GOAL, LANE_ENTER, LANE_WAIT, REACHED, START, VERTEX_CLOSED

REASONS = ("unknown_robot", "vertex", "sender", "clock", "duplicate", "rate", "implausible", "start")
NEEDS_VERTEX = (START, GOAL, REACHED, DWELL, LANE_WAIT, LANE_ENTER, VERTEX_CLOSED)
# [s] how far behind its receipt an event may be stamped: the monitor's callbacks and rosbag's
# recorder trail a fast lock-step clock by tens of seconds (ahead: the agents' max_skew_s)
MAX_PAST_S = 300.0
DUPLICATE_MEMORY = 64  # events remembered per robot for the duplicate check
# summary `suspect_traffic`: more refusals than this share of the accepted events (or than
# SUSPECT_MIN when few were accepted): the figures may be affected
SUSPECT_SHARE = 0.01
SUSPECT_MIN = 10


class TrafficGuard:
    def __init__(self, n_robots: int, n_vertices: int, names: list[str] | None = None,
                 config: InboxConfig | None = None):
        self.n = int(n_robots)
        self.n_vertices = int(n_vertices)
        self.config = config or InboxConfig()
        self.senders = SenderCheck(self.n, names)
        self._recent = [(deque(), set()) for _ in range(self.n)]  # duplicate memory
        self.rate = RateLimit(self.config.rate_per_s, self.config.burst)
        self.counts: dict[tuple[int, str], int] = {}  # (robot or -1, reason) -> refusals
        self.accepted = 0

    def count(self, robot: int, reason: str) -> str:
        key = (int(robot) if 0 <= robot < self.n else -1, reason)
        self.counts[key] = self.counts.get(key, 0) + 1
        return reason

    def check(self, robot: int, kind: int, vertex: int, from_vertex: int, t: float,
              clock: float, sender: str | None = None) -> str | None:
        """Why the event is refused (counted), or None (accepted). `clock`: the monitor's time
        [s] (NaN or -inf: not known yet)."""
        if not 0 <= robot < self.n:
            return self.count(robot, "unknown_robot")
        if kind in NEEDS_VERTEX and not 0 <= vertex < self.n_vertices:
            return self.count(robot, "vertex")
        if sender and not self.senders.ok(robot, sender):
            return self.count(robot, "sender")
        if math.isfinite(clock) and clock_problem(t, clock, self.config.max_skew_s,
                                                  MAX_PAST_S):
            return self.count(robot, "clock")
        if not math.isfinite(t):
            return self.count(robot, "clock")
        # a START is a robot's first visit report: a copy of it may come as a REACHED
        key = (REACHED if kind == START else int(kind), int(vertex), int(from_vertex),
               round(float(t), 6))
        order, seen = self._recent[robot]
        if key in seen:
            return self.count(robot, "duplicate")
        # the rate on the sender's stamps, once checked against a clock (one far ahead would
        # stall the refill): receipts come in bursts when callbacks trail a fast lock-step clock
        if math.isfinite(clock) and not self.rate.allow((robot, sender), float(t)):
            return self.count(robot, "rate")
        order.append(key)
        seen.add(key)
        if len(order) > DUPLICATE_MEMORY:
            seen.discard(order.popleft())
        self.accepted += 1
        return None

    # -- outputs ----------------------------------------------------------------------------

    @property
    def total(self) -> int:
        return sum(self.counts.values())

    def by_reason(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for (_, reason), k in self.counts.items():
            out[reason] = out.get(reason, 0) + k
        return {r: out[r] for r in REASONS if r in out}

    @property
    def suspect(self) -> bool:
        return self.total > max(SUSPECT_MIN, SUSPECT_SHARE * self.accepted)

    def summary(self) -> dict:
        """summary.json fields: `rejected` (total, by reason, by robot: -1 = no robot of the
        team) and `suspect_traffic`."""
        robots: dict[int, dict[str, int]] = {}
        for (r, reason), k in sorted(self.counts.items()):
            robots.setdefault(r, {})[reason] = k
        return {"rejected": {"total": self.total, "accepted": self.accepted,
                             "by_reason": self.by_reason(),
                             "by_robot": [{"robot": r, **c} for r, c in robots.items()]},
                "suspect_traffic": self.suspect}
