"""Monitor logic of a ROS run (ROS-free): ground-truth poses and agent events -> RunRecorder.

The live `monitor` node and `tpuaf analyze` (bag replay) both feed one `FleetMonitor` with the
same two streams, in arrival order, and so compute the same metrics:

- `on_pose(robot, t, x, y)`: ground-truth positions [m] at run time t [s]. Poses are grouped by
  time stamp (the simulator stamps all robots of one step alike); a group is processed when a
  pose `lag_s` newer arrives (robots missing from it keep their last position), so that the
  agent events stamped up to its time have arrived, whatever the interleaving of the streams.
- `on_event(robot, kind, vertex, t)`: AgentEvent (tpuaf.topics constants, vertex index).

Definitions (SPEC section 6):
- the run starts at the first complete pose group at or after `start_after` [s]; every robot
  standing within goal tolerance of a vertex then makes a first visit of it (as batch does);
- a visit is the first ground-truth pose stamped after a GOAL event (later by > 1 ms) within the
  goal tolerance of that goal vertex; the goal is then spent;
- a robot whose agent sent no event (heartbeats every 1 s) for `death_timeout_s` is dead from
  the first pose group after that: `RunRecorder.record_robot_death` (it no longer senses nor
  interferes);
- the run ends at start + duration_s: `finished` becomes True and later input is ignored.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np

from .metrics import RunRecorder
from .topics import GOAL

# [s] stamps closer than this are equal (run times pass through float seconds and integer ns).
STAMP_EPS_S = 1e-3


class FleetMonitor:
    def __init__(self, patrol_map: Any, n_robots: int, duration_s: float, *,
                 start_after: float = 0.0, death_timeout_s: float = 5.0,
                 sample_period_s: float = 1.0, lag_s: float = 2.0):
        self.patrol_map = patrol_map
        self.n = int(n_robots)
        self.duration_s = float(duration_s)
        self.start_after = float(start_after)
        self.death_timeout_s = float(death_timeout_s)
        self.sample_period_s = float(sample_period_s)
        self.lag_s = float(lag_s)
        self.tolerance = float(patrol_map.settings.goal_tolerance)
        self._positions = np.asarray(patrol_map.positions, dtype=float)
        self.recorder: RunRecorder | None = None
        self.start_time: float | None = None
        self.now = -math.inf  # time of the last processed pose group
        self.finished = False
        self._groups: dict[float, np.ndarray] = {}
        self._counts: dict[float, int] = {}
        self._last = np.full((self.n, 2), np.nan)
        self._alive = np.ones(self.n, dtype=bool)
        self._heard = np.full(self.n, -math.inf)  # last event stamp <= the processed time
        self._heard_q: list[deque] = [deque() for _ in range(self.n)]  # event stamps ahead
        self._goals: list[deque] = [deque() for _ in range(self.n)]  # (stamp, vertex) pending
        self._goal = [-1] * self.n  # active goal vertex, -1 = none (or spent)
        self.deaths: list[tuple[float, int]] = []
        self._idl_seen, self._idl_sum, self._idl_n, self._idl_max = 0, 0.0, 0, 0.0

    # -- inputs -----------------------------------------------------------------------------

    def on_event(self, robot: int, kind: int, vertex: int, t: float) -> None:
        if not 0 <= robot < self.n:
            return
        self._heard_q[robot].append(float(t))
        if kind == GOAL and vertex >= 0:
            q = self._goals[robot]
            q.append((float(t), int(vertex)))
            if len(q) > 1 and q[-2][0] > q[-1][0]:
                self._goals[robot] = deque(sorted(q))

    def on_pose(self, robot: int, t: float, x: float, y: float) -> None:
        if self.finished or not 0 <= robot < self.n:
            return
        t = float(t)
        if t <= self.now:
            return  # older than what was processed: too late
        group = self._groups.get(t)
        if group is None:
            group = self._groups[t] = np.full((self.n, 2), np.nan)
            self._counts[t] = 0
        if math.isnan(group[robot, 0]):
            self._counts[t] += 1
        group[robot] = (x, y)
        self._flush(t)

    # -- processing -------------------------------------------------------------------------

    def _flush(self, newest: float) -> None:
        """Process, in time order, the pose groups older than newest - lag_s: agent events
        stamped up to a group's time have arrived by then, in the live node and in a bag alike,
        so the result does not depend on the order in which the two streams interleave."""
        limit = newest - self.lag_s
        for t in sorted(t for t in self._groups if t <= limit):
            group = self._groups.pop(t)
            count = self._counts.pop(t)
            if not self.finished:
                self._process(t, group, count)

    def _process(self, t: float, group: np.ndarray, count: int) -> None:
        seen = ~np.isnan(group[:, 0])
        self._last[seen] = group[seen]
        for r in range(self.n):  # events heard up to t
            q = self._heard_q[r]
            while q and q[0] <= t:
                self._heard[r] = max(self._heard[r], q.popleft())
        if self.recorder is None:
            if t < self.start_after or count < self.n:
                self.now = t
                return
            self._start(t)
            return
        end = self.start_time + self.duration_s
        if t > end:
            self.end(end)
            return
        # Deaths: silent agents (never heard: counted from the start).
        silent = np.maximum(self._heard, self.start_time) < t - self.death_timeout_s
        for r in np.flatnonzero(silent & self._alive).tolist():
            self._alive[r] = False
            self.recorder.record_robot_death(r, t)
            self.deaths.append((t, r))
        positions = self._last.copy()
        self.recorder.record_positions(t, positions)
        self._visits(t, positions)
        self.now = t
        if t >= end:
            self.end(end)

    def _visits(self, t: float, positions: np.ndarray) -> None:
        tol2 = self.tolerance * self.tolerance
        for r in range(self.n):
            q = self._goals[r]
            while q and q[0][0] < t - STAMP_EPS_S:
                self._goal[r] = q.popleft()[1]
            g = self._goal[r]
            if g < 0 or not self._alive[r]:
                continue
            d = positions[r] - self._positions[g]
            if d[0] * d[0] + d[1] * d[1] <= tol2:
                self.recorder.record_visit(r, g, t)
                self._goal[r] = -1

    def _start(self, t: float) -> None:
        self.start_time = t
        self.recorder = RunRecorder(self.patrol_map, self.n, sample_period_s=self.sample_period_s,
                                    start_time=t)
        positions = self._last.copy()
        self.recorder.record_positions(t, positions)
        for r in range(self.n):
            v = self.patrol_map.nearest_vertex(*positions[r])
            if np.hypot(*(positions[r] - self._positions[v])) <= self.tolerance:
                self.recorder.record_visit(r, v, t)
        # Goals announced before the start count from the start on.
        for r in range(self.n):
            q = self._goals[r]
            while q and q[0][0] < t - STAMP_EPS_S:
                self._goal[r] = q.popleft()[1]
        self.now = t

    def end(self, end_time: float) -> None:
        if not self.finished and self.recorder is not None:
            self.recorder.finish(end_time)
            self.now = end_time
        self.finished = True

    # -- outputs ----------------------------------------------------------------------------

    @property
    def started(self) -> bool:
        return self.recorder is not None

    @property
    def elapsed(self) -> float:
        return 0.0 if self.start_time is None else max(0.0, self.now - self.start_time)

    def live(self) -> dict:
        """The LiveMetrics fields (NaN where not yet defined)."""
        nan = math.nan
        rec = self.recorder
        if rec is None:
            return {"start_time": nan, "elapsed": 0.0, "visits": 0, "idleness_avg": nan,
                    "idleness_max": nan, "instantaneous_idleness": nan, "worst_idleness": nan,
                    "uncertainty_mean": nan, "interferences": 0, "complete_cycles": 0,
                    "robots_alive": int(self._alive.sum())}
        new = rec.visit_idleness[self._idl_seen:]
        self._idl_seen += len(new)
        for x in new:
            if x == x:  # not NaN (a vertex's first visit)
                self._idl_sum += x
                self._idl_n += 1
                self._idl_max = max(self._idl_max, x)
        row = rec.timeseries[-1] if rec.timeseries else {}
        counts = rec.visit_counts
        return {
            "start_time": self.start_time,
            "elapsed": self.elapsed,
            "visits": len(rec.visits),
            "idleness_avg": self._idl_sum / self._idl_n if self._idl_n else nan,
            "idleness_max": self._idl_max if self._idl_n else nan,
            "instantaneous_idleness": row.get("idleness_ins_s", nan),
            "worst_idleness": row.get("worst_idleness_s", nan),
            "uncertainty_mean": row.get("uncertainty_mean", nan),
            "interferences": len(rec.interferences),
            "complete_cycles": int(min(max(c - 1, 0) for c in counts)) if counts else 0,
            "robots_alive": int(self._alive.sum()),
        }

    def summary(self) -> dict:
        """RunRecorder.summary at the run's end (or at the last processed time)."""
        if self.recorder is None:
            raise RuntimeError("the run never started: no complete set of ground-truth poses")
        end = self.start_time + self.duration_s if self.finished else self.now
        return self.recorder.summary(end)
