"""Robot health at fleet level (ROS-free), per robot: stuck episodes and recoveries (STUCK
events: a navigator recovery; an episode is the recoveries between two goals), failed goals
(FAILED), give-way waits (GIVE_WAY), lane waits (LANE_WAIT, stamped at the request, to
LANE_ENTER: their count and seconds, as the physics runtime's summary), the time since its last
visit, and no-progress spells: a robot alive that neither moved PROGRESS_M nor visited for
`stuck_after_s` (ground-truth poses).

FleetMonitor feeds it the events at arrival, the visits and the processed pose groups; times
are ROS time [s] in, run time [s] out (summary rows, live arrays).
"""

from __future__ import annotations

import math

import numpy as np

from tpuaf.topics import FAILED, GIVE_WAY, GOAL, LANE_ENTER, LANE_WAIT, STUCK

PROGRESS_M = 0.25  # [m] a robot this far from where its spell began made progress
COUNTED = {STUCK: "recoveries", FAILED: "failed_goals", GIVE_WAY: "give_ways",
           LANE_WAIT: "lane_waits"}


class FleetHealth:
    def __init__(self, n_robots: int, stuck_after_s: float):
        self.n = int(n_robots)
        self.stuck_after_s = float(stuck_after_s)  # [s] no progress this long: reported
        # per robot and figure: event stamps [s] (ROS time)
        self.stamps = [{k: [] for k in (*COUNTED.values(), "stuck_episodes")}
                       for _ in range(self.n)]
        self._episode = [False] * self.n  # a stuck episode open (no GOAL since the last STUCK)
        self._anchor = np.full((self.n, 2), np.nan)  # [m] where the robot stood since ...
        self._anchor_t = np.full(self.n, np.nan)  # ... this time [s]
        self.last_visit = np.full(self.n, np.nan)  # [s] each robot's last visit
        self.spells: list[list] = []  # [robot, start s, end s or None] of no progress
        self._open = [-1] * self.n  # index in spells of a robot's open spell
        self.lane_waits: list[list[list]] = [[] for _ in range(self.n)]  # [request s, end s|None]

    def on_event(self, robot: int, kind: int, t: float) -> None:
        if kind == GOAL:
            self._episode[robot] = False
            return
        waits = self.lane_waits[robot]
        if kind == LANE_WAIT:
            waits.append([float(t), None])
        elif kind == LANE_ENTER:
            if waits and waits[-1][1] is None:
                waits[-1][1] = float(t)
            return
        name = COUNTED.get(kind)
        if name is None:
            return
        self.stamps[robot][name].append(float(t))
        if kind == STUCK and not self._episode[robot]:
            self._episode[robot] = True
            self.stamps[robot]["stuck_episodes"].append(float(t))

    def on_visit(self, robot: int, t: float) -> None:
        if not t <= self.last_visit[robot]:
            self.last_visit[robot] = t
        if t > self._anchor_t[robot]:  # a visit is progress
            self._anchor_t[robot] = t

    def observe(self, t: float, positions: np.ndarray, alive: np.ndarray) -> list[str]:
        """Positions (n, 2) [m] at t [s] (NaN: unknown); returns what to report."""
        news = []
        for r in range(self.n):
            x, y = positions[r]
            if not alive[r] or math.isnan(x):
                self._anchor_t[r] = math.nan  # from scratch when back
                self._close(r, t)
                continue
            ax, ay = self._anchor[r]
            if math.isnan(self._anchor_t[r]) or math.hypot(x - ax, y - ay) > PROGRESS_M:
                self._anchor[r] = (x, y)
                if self._close(r, t):
                    news.append(f"robot {r} moves again")
                if math.isnan(self._anchor_t[r]) or self._anchor_t[r] < t:
                    self._anchor_t[r] = t
            elif self._open[r] < 0 and t - self._anchor_t[r] >= self.stuck_after_s:
                self._open[r] = len(self.spells)
                self.spells.append([r, float(self._anchor_t[r]), None])
                news.append(f"robot {r} made no progress for {t - self._anchor_t[r]:.0f} s "
                            f"(at x = {x:.2f}, y = {y:.2f} m, no visit): stuck?")
        return news

    def _close(self, robot: int, t: float) -> bool:
        k = self._open[robot]
        if k < 0:
            return False
        self.spells[k][2] = float(t)
        self._open[robot] = -1
        return True

    # -- outputs ----------------------------------------------------------------------------

    def counts(self, robot: int, start: float, end: float) -> dict[str, int]:
        return {name: sum(1 for s in stamps if start <= s <= end)
                for name, stamps in self.stamps[robot].items()}

    def lane_wait_s(self, robot: int, start: float, end: float) -> float:
        """[s] robot's lane waits within [start, end] (one still open: to `end`)."""
        total = 0.0
        for s0, s1 in self.lane_waits[robot]:
            s1 = end if s1 is None else min(s1, end)
            total += max(0.0, s1 - max(s0, start))
        return total

    def live(self, start: float, now: float) -> dict[str, list]:
        """The LiveMetrics per-robot arrays at ROS time `now` [s]."""
        rows = [self.counts(r, start, now) for r in range(self.n)]
        out = {name: [row[name] for row in rows] for name in self.stamps[0]}
        out["lane_wait_s"] = [self.lane_wait_s(r, start, now) for r in range(self.n)]
        out["since_last_visit"] = [now - (v if v == v else start) for v in self.last_visit]
        out["no_progress"] = [k >= 0 for k in self._open]
        return out

    def summary(self, start: float, end: float) -> dict:
        """Summary fields at ROS time `end` [s] (the run started at `start`): totals and one
        row per robot, in run time."""
        rows = []
        for r in range(self.n):
            last = self.last_visit[r]
            rows.append({
                "robot": r, **self.counts(r, start, end),
                "lane_wait_s": round(self.lane_wait_s(r, start, end), 3),
                "last_visit_s": last - start if last == last else None,
                "since_last_visit_s": end - (last if last == last else start),
                "no_progress": [{"start_s": s0 - start,
                                 "end_s": None if s1 is None else s1 - start}
                                for rr, s0, s1 in self.spells if rr == r and s0 <= end],
            })
        totals = {name: sum(row[name] for row in rows) for name in self.stamps[0]}
        totals["lane_wait_s"] = round(sum(row["lane_wait_s"] for row in rows), 3)
        return {**totals, "no_progress_spells": sum(len(row["no_progress"]) for row in rows),
                "stuck_after_s": self.stuck_after_s, "robot_health": rows}
