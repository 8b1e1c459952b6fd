"""Monitor logic of a ROS run (ROS-free): ground-truth poses and agent events -> RunRecorder.

The live `monitor` node and `tpuaf analyze` (bag replay) both feed one `FleetMonitor` with the
same two streams, in arrival order, and so compute the same metrics:

- `on_pose(robot, t, x, y)`: ground-truth positions [m] at run time t [s]. Poses are grouped by
  time stamp (the simulator stamps all robots of one step alike); a group is processed when a
  pose `lag_s` newer arrives (robots missing from it keep their last position), so that the
  agent events stamped up to its time have arrived, whatever the interleaving of the streams.
- `on_event(robot, kind, vertex, t)`: AgentEvent (tpuaf.topics constants, vertex index).

Definitions (SPEC section 6):
- the run starts at the first complete pose group at or after `start_after` [s]; with
  `exact_start` (an announced start: /fleet/start) at `start_after` itself, once a pose group
  at or after it is processed and every robot's position is known (a pose dropped by a loaded
  subscriber cannot delay it: the live node and the bag's analysis start alike);
- a visit is the one rule of every runtime (tpuaf_core.VisitRule, docs/RUNTIMES.md "Visits")
  applied to the ground-truth poses (`visit_source="poses"`, the default): a pose within the
  map's visit radius of the robot's goal (its GOAL events; a goal just ended stays one for
  GOAL_GRACE_S, as the poses may trail the agent's localisation) after the robot was farther
  than twice the radius from it, stamped with the pose; standing on a vertex never visits it again.
  A START event is the robot's first visit of its start vertex (at the run start if stamped
  before it), as in the graph runtime. With `visit_source="reports"` (bags without the agents'
  events: their Visit messages) the REACHED reports are the visits, at their stamps. DWELL
  events (a goal ended without a visit) are counted apart (summary `dwells`, `dwell_time_s`);
  patrolling_sim's count of every goal arrival is `visits_patrolling_sim`;
- a robot whose agent sent no event (heartbeats every 1 s) for `death_timeout_s` (default: the
  teammate timeout, tpuaf.params.LIVENESS_DEFAULTS) is out of contact from the first pose
  group after that (it no longer senses nor interferes): an outage, dated by the recorder from
  the last event heard. Heard again (a restarted agent), it is alive from that event: the
  outage ends (summary `outages`: robot, start_s, end_s, cause). Only an outage never ended is
  a death (summary `deaths`, `dead_robots`; the recovery metrics count from its start, over
  the robots that really survived);
- `on_announcement(robot, vertex, t)`: a destination a robot announced in a team message
  (tpuaf.robot.machine.announced_vertex), for the recovery metrics' intentions;
- the run ends at start + duration_s: `finished` becomes True and later input is ignored;
- robot health (tpuaf.measure.health): STUCK, FAILED and GIVE_WAY events, visits and the
  processed poses give per-robot counts, the time since the last visit and no-progress spells
  (none for `stuck_after_s`), in `live()` and the summary (`robot_health`); `news` holds lines
  for the operator (outages, spells), drained by the live node.

- what it is told is checked first (tpuaf.measure.traffic.TrafficGuard: sender, clock,
  duplicates, rate, unknown robots and vertices; reported visits far from the robot's pose):
  a refused event has no effect and is counted (summary `rejected`, `suspect_traffic`).

Time base: inputs are ROS time (stamps); the recorder, and so every results file, works in run
time, 0 at the run start (docs/RESULTS.md); the summary's `start_time_s` is the ROS time [s] of
run time 0 and `time_base` says so.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from typing import Any

import numpy as np

from tpuaf.measure.health import FleetHealth
from tpuaf.measure.metrics import RunRecorder, complete_cycles
from tpuaf.measure.traffic import TrafficGuard
from tpuaf.params import CONTROLLER_DEFAULTS, HEALTH_DEFAULTS, LIVENESS_DEFAULTS
from tpuaf.plain import plain
from tpuaf.topics import DWELL, GOAL, HEARTBEAT, REACHED, START, VERTEX_CLOSED

# [s] stamps closer than this are equal (run times pass through float seconds and integer ns).
STAMP_EPS_S = 1e-3
# summary.json `time_base`: every time_s of the results is run time since start_time_s.
# [s] a goal the agent ended stays a visit candidate this long after its next GOAL: the
# monitor's poses may trail the agent's localisation (tf stamps grouped on 0.1 s ticks, latency)
GOAL_GRACE_S = 1.0
TIME_BASE = "run time [s] since start_time_s (ROS time)"
# the cause of an outage: no agent event (heartbeat) for death_timeout_s
OUTAGE_SILENT = "silent"


class FleetMonitor:
    def __init__(self, patrol_map: Any, n_robots: int, duration_s: float, *,
                 start_after: float = 0.0, death_timeout_s: float | None = None,
                 sample_period_s: float = 1.0, lag_s: float = 2.0,
                 teammate_timeout_s: float = LIVENESS_DEFAULTS.teammate_timeout_s,
                 visit_source: str = "poses",
                 stuck_after_s: float = HEALTH_DEFAULTS.stuck_after_s,
                 robot_names: list[str] | None = None, exact_start: bool = False,
                 hold_s: float = 0.0, body_radius_m: float | None = None,
                 safety_margin_m: float = CONTROLLER_DEFAULTS.safety_margin):
        if visit_source not in ("poses", "reports"):
            raise ValueError(f"visit_source must be 'poses' or 'reports', not {visit_source!r}")
        self.visit_source = visit_source
        self.patrol_map = patrol_map
        # [m] the robots' radius: a dead robot's body stays where it stopped (the simulator's,
        # a real robot's) and may lie on a vertex (recovery); default: the map's robot radius
        self.body_radius_m = float(patrol_map.settings.robot_radius if body_radius_m is None
                                   else body_radius_m)
        self.safety_margin_m = float(safety_margin_m)  # [m] the agents' controller's
        self.n = int(n_robots)
        self.duration_s = float(duration_s)
        self.start_after = float(start_after)
        self.exact_start = bool(exact_start)  # run time 0 is start_after itself
        # [s] live: a pose group waits (up to this long) until every robot in contact sent a
        # heartbeat and a pose stamped at or after it: its earlier events and poses have
        # arrived (one connection each, in order), however far the callbacks trail a fast
        # lock-step clock
        self.hold_s = float(hold_s)
        self._beat = np.full(self.n, -math.inf)  # each robot's newest heartbeat stamp [s]
        self._seen = np.full(self.n, -math.inf)  # each robot's newest pose stamp [s]
        # [s] the agents' teammate timeout (the recovery metrics' floor at detection)
        self.teammate_timeout_s = float(teammate_timeout_s)
        # [s] silence that makes an agent dead; None: the teammate timeout (one liveness rule)
        self.death_timeout_s = LIVENESS_DEFAULTS.death_timeout_for(self.teammate_timeout_s,
                                                                   death_timeout_s)
        self.sample_period_s = float(sample_period_s)
        self.lag_s = float(lag_s)
        self.tolerance = float(patrol_map.settings.goal_tolerance)
        self._rules = [patrol_map.visit_rule() for _ in range(self.n)]  # one per robot
        # (stamp, kind, vertex, from) of START, GOAL and DWELL events not yet applied, per robot
        self._goal_q: list[list[tuple[float, int, int, int]]] = [[] for _ in range(self.n)]
        self._goal = [-1] * self.n  # each robot's goal (vertex index; -1: none)
        self._ended: list[dict[int, float]] = [{} for _ in range(self.n)]  # goal: grace end [s]
        self._positions = np.asarray(patrol_map.positions, dtype=float)
        self.recorder: RunRecorder | None = None
        self.start_time: float | None = None
        self.now = -math.inf  # time of the last processed pose group
        self.finished = False
        self._groups: dict[float, np.ndarray] = {}
        self._oldest_group = math.inf  # the oldest time in _groups [s]
        self._counts: dict[float, int] = {}
        self._last = np.full((self.n, 2), np.nan)
        self._alive = np.ones(self.n, dtype=bool)
        self._heard = np.full(self.n, -math.inf)  # last event stamp <= the processed time
        self._heard_q: list[deque] = [deque() for _ in range(self.n)]  # event stamps ahead
        # (stamp, robot, vertex, is START) of visits not yet recorded, in stamp order
        self._visits: list[tuple[float, int, int, bool]] = []
        self._announcements: list[tuple[int, int, float]] = []  # until the recorder exists
        self._closed: set[int] = set()  # VERTEX_CLOSED vertices (indices)
        self._back = np.full(self.n, math.inf)  # first event after an outage began [s]
        # [detection time s, robot, end s (first event heard again) or None]
        self.outages: list[list] = []
        self.health = FleetHealth(self.n, stuck_after_s)  # stuck, recoveries, ... per robot
        # what is accepted of the agents' events (the agents' rules), refusals counted
        self.traffic = TrafficGuard(self.n, patrol_map.num_vertices, robot_names)
        self._clock = -math.inf  # [s] the newest pose stamp: the monitor's clock
        # [m] a reported visit farther than this from the robot's pose is implausible
        self.plausible_m = 2.0 * self.tolerance
        self.news: list[str] = []  # what an operator should hear (outages, ...); drained by nodes
        self._idl_seen, self._idl_sum, self._idl_n, self._idl_max = 0, 0.0, 0, 0.0

    # -- inputs -----------------------------------------------------------------------------

    def on_event(self, robot: int, kind: int, vertex: int, t: float,
                 from_vertex: int = -1, sender: str | None = None,
                 received: float | None = None) -> bool:
        """An agent event; False when refused (tpuaf.measure.traffic: counted, no effect).
        `sender`: the publishing node (caller id), when known; `received` [s]: when it was
        received (the live node's clock, a bag's record time), else the newest pose's stamp."""
        clock = self._clock if received is None else float(received)
        if self.traffic.check(robot, kind, vertex, from_vertex, t, clock, sender):
            return False
        self._accept_event(robot, kind, vertex, float(t), from_vertex)
        if kind == HEARTBEAT and t > self._beat[robot]:
            self._beat[robot] = float(t)
        return True

    def reject(self, robot: int, reason: str) -> None:
        """A refusal decided outside (a second run start): counted with the others."""
        self.traffic.count(robot, reason)

    def _accept_event(self, robot: int, kind: int, vertex: int, t: float,
                      from_vertex: int) -> None:
        q = self._heard_q[robot]
        if q and q[-1] > t:  # out of order (a late message): kept sorted, none blocks another
            q.insert(bisect.bisect_right(q, t), float(t))
        else:
            q.append(float(t))
        self.health.on_event(robot, kind, float(t))
        if not 0 <= vertex < self.patrol_map.num_vertices:
            return
        if kind in (START, GOAL, DWELL):
            q = self._goal_q[robot]
            q.append((float(t), int(kind), int(vertex), int(from_vertex)))
            if len(q) > 1 and q[-2][0] > q[-1][0]:
                q.sort(key=lambda e: e[0])
        if kind == VERTEX_CLOSED:  # cut off by a lost teammate's body (robot/lanes.py)
            self._closed.add(int(vertex))
            if self.recorder is not None:
                self.recorder.record_closed(vertex)
        if kind == START or (kind == REACHED and self.visit_source == "reports"):
            t = float(t)
            if kind == START and self.start_time is not None:
                t = max(t, self.start_time)
            self._visits.append((t, int(robot), int(vertex), kind == START))
            if len(self._visits) > 1 and self._visits[-2][0] > t:
                self._visits.sort()

    def on_announcement(self, robot: int, vertex: int, t: float) -> None:
        """Robot `robot` announced at t [s] that it heads to `vertex` (index)."""
        if 0 <= robot < self.n and 0 <= vertex < self.patrol_map.num_vertices:
            if self.recorder is None:
                self._announcements.append((int(robot), int(vertex), float(t)))
            else:
                self.recorder.record_announcement(int(robot), int(vertex), self.run_time(t))

    def on_pose(self, robot: int, t: float, x: float, y: float) -> None:
        if self.finished or not 0 <= robot < self.n:
            return
        t = float(t)
        if t > self._clock:
            self._clock = t
        if t > self._seen[robot]:
            self._seen[robot] = t
        if t <= self.now:
            return  # older than what was processed: too late
        group = self._groups.get(t)
        if group is None:
            group = self._groups[t] = np.full((self.n, 2), np.nan)
            self._counts[t] = 0
            self._oldest_group = min(self._oldest_group, t)
        if math.isnan(group[robot, 0]):
            self._counts[t] += 1
        group[robot] = (x, y)
        self._flush(t)

    # -- processing -------------------------------------------------------------------------

    def drain(self) -> None:
        """Process every pose group up to the newest but lag_s, holding none (the stream ended)."""
        if self._groups:
            self._flush(max(self._groups), force=True)

    def _flush(self, newest: float, force: bool = False) -> None:
        """Process, in time order, the pose groups older than newest - lag_s: agent events
        stamped up to a group's time have arrived by then, in the live node and in a bag alike,
        so the result does not depend on the order in which the two streams interleave."""
        limit = newest - self.lag_s
        if self.hold_s > 0 and not force:
            # every robot in contact heard (heartbeat) and seen (pose) at or after the group
            beats = np.minimum(self._beat, self._seen)[self._alive]
            mark = float(beats.min()) if beats.size else math.inf
            limit = min(limit, max(mark, newest - self.hold_s))
            limit = self._hold_the_end(limit, newest)
        if limit < self._oldest_group:
            return  # nothing old enough (most poses)
        for t in sorted(t for t in self._groups if t <= limit):
            group = self._groups.pop(t)
            count = self._counts.pop(t)
            if not self.finished:
                self._process(t, group, count)
        self._oldest_group = min(self._groups, default=math.inf)

    def _hold_the_end(self, limit: float, newest: float) -> float:
        """Live: the run's end waits (up to hold_s) until every robot ever heard, dead ones
        too, sent a heartbeat lag_s past the end, so a visit stamped just before the end that a
        loaded machine delivers late is still counted."""
        if self.start_time is None:
            return limit
        end = self.start_time + self.duration_s
        if limit <= end:
            return limit
        heard = np.isfinite(self._beat)
        mark = float(self._beat[heard].min()) if heard.any() else math.inf
        if mark >= end + self.lag_s or newest - end >= self.hold_s:
            return limit
        return end

    def _process(self, t: float, group: np.ndarray, count: int) -> None:
        seen = ~np.isnan(group[:, 0])
        self._last[seen] = group[seen]
        self._apply_visit_rule(t, seen)
        for r in range(self.n):  # events heard up to t
            q = self._heard_q[r]
            while q and q[0] <= t:
                s = q.popleft()
                if not self._alive[r] and s > self._heard[r] and s < self._back[r]:
                    self._back[r] = s  # the first event after the silence
                self._heard[r] = max(self._heard[r], s)
        if self.recorder is None:
            known = not np.isnan(self._last[:, 0]).any()
            if t < self.start_after or not (known if self.exact_start else count == self.n):
                self.now = t
                return
            self._start(self.start_after if self.exact_start else t, t)
            return
        end = self.start_time + self.duration_s
        if t > end:
            self._record_visits(end)  # those stamped after the last group, up to the end
            self.end(end)
            return
        self._liveness(t)
        self._record_visits(t)
        self.recorder.record_positions(self.run_time(t), self._last.copy())
        self.news += self.health.observe(t, self._last, self._alive)
        self.now = t
        if t >= end:
            self.end(end)

    def _liveness(self, t: float) -> None:
        """Outages: an agent silent for death_timeout_s (never heard: counted from the start) is
        out from its last event; heard again, it is alive from that event. An outage not ended
        by the run's end is a death."""
        for r in np.flatnonzero(~self._alive & (self._back <= t)).tolist():
            back = float(self._back[r])
            self._alive[r] = True
            self._back[r] = math.inf
            self.recorder.record_robot_back(r, self.run_time(max(back, self.start_time)))
            next(o for o in reversed(self.outages) if o[1] == r)[2] = back
            self.news.append(f"robot {r} heard again at run time {self.run_time(back):.1f} s: "
                             "alive")
        silent = np.maximum(self._heard, self.start_time) < t - self.death_timeout_s
        for r in np.flatnonzero(silent & self._alive).tolist():
            self._alive[r] = False
            began = max(float(self._heard[r]), self.start_time)
            self.recorder.record_robot_outage(r, self.run_time(began), OUTAGE_SILENT)
            self.outages.append([t, r, None])
            self.news.append(f"robot {r} silent since run time {self.run_time(began):.1f} s "
                             f"(no agent event for {self.death_timeout_s:g} s): out of contact")

    @property
    def deaths(self) -> list[tuple[float, int]]:
        """(detection time [s], robot) of the robots out of contact now (never heard again)."""
        return [(t, r) for t, r, end in self.outages if end is None]

    def _apply_visit_rule(self, t: float, seen: np.ndarray) -> None:
        """The START, GOAL and DWELL events stamped up to t [s], then each robot's VisitRule on
        its pose at t against every goal it held since the last pose group (a goal reached at t
        is followed by the next GOAL stamped t) or ended within GOAL_GRACE_S."""
        for r in range(self.n):
            q = self._goal_q[r]
            ended = self._ended[r]
            goals = [self._goal[r], *ended]
            k = 0
            while k < len(q) and q[k][0] <= t + STAMP_EPS_S:
                stamp, kind, vertex, from_vertex = q[k]
                k += 1
                if kind == START:
                    x, y = (self._last[r] if seen[r] or not math.isnan(self._last[r, 0])
                            else self._positions[vertex])
                    self._rules[r].start(vertex, float(x), float(y))
                    self._goal[r] = -1
                elif kind == GOAL:
                    if self._goal[r] >= 0:
                        ended[self._goal[r]] = stamp + GOAL_GRACE_S
                    self._goal[r] = vertex
                    goals.append(vertex)
                    if self.recorder is not None:
                        self.recorder.record_goal(r, vertex, from_vertex, self.run_time(stamp))
                elif self.recorder is not None and stamp <= self.start_time + self.duration_s:
                    self.recorder.record_dwell(r, vertex, self.run_time(stamp))  # DWELL
            del q[:k]
            for g in [g for g, until in ended.items() if until < t]:
                del ended[g]
            if not seen[r] or self.visit_source != "poses":
                continue
            x, y = float(self._last[r, 0]), float(self._last[r, 1])
            rule = self._rules[r]
            rule.observe(x, y)
            for g in dict.fromkeys(goals):
                if g >= 0 and rule.arrive(g, x, y):
                    self._visits.append((t, r, g, False))
        if len(self._visits) > 1:
            self._visits.sort()

    def _record_visits(self, t: float) -> None:
        """Visits stamped up to t [s] (within the run), in stamp order."""
        q = self._visits
        k = 0
        end = self.start_time + self.duration_s
        while k < len(q) and q[k][0] <= t + STAMP_EPS_S:
            stamp, robot, vertex, first = q[k]
            k += 1
            if not first and self.visit_source == "reports" and not self._plausible(robot,
                                                                                     vertex):
                self.traffic.count(robot, "implausible")
                continue
            if self.start_time - STAMP_EPS_S <= stamp <= end:
                stamp = min(max(stamp, self.start_time), end)
                self.recorder.record_visit(robot, vertex, self.run_time(stamp))
                self.health.on_visit(robot, stamp)
        del q[:k]

    def _plausible(self, robot: int, vertex: int) -> bool:
        """A reported visit: the robot's last pose (when known) within plausible_m of it."""
        x, y = self._last[robot]
        if math.isnan(x):
            return True
        vx, vy = self._positions[vertex]
        return math.hypot(x - vx, y - vy) <= self.plausible_m

    def _start(self, start: float, t: float) -> None:
        """The run starts at `start` [s], processed with the pose group at t >= start."""
        self.start_time = start
        self.recorder = RunRecorder(self.patrol_map, self.n, sample_period_s=self.sample_period_s,
                                    teammate_timeout_s=self.teammate_timeout_s,
                                    body_radius_m=self.body_radius_m,
                                    safety_margin_m=self.safety_margin_m)
        # START events before the run start: first visits at the start; REACHED before it
        # belong to no run.
        self._visits = sorted((max(s, start) if first else s, r, v, first)
                              for s, r, v, first in self._visits
                              if first or s >= start - STAMP_EPS_S)
        self._record_visits(t)
        self.recorder.record_positions(0.0, self._last.copy())
        for robot, vertex, stamp in self._announcements:
            self.recorder.record_announcement(robot, vertex, self.run_time(stamp))
        self._announcements.clear()
        for vertex in self._closed:
            self.recorder.record_closed(vertex)
        self.now = t

    def end(self, end_time: float) -> None:
        if not self.finished and self.recorder is not None:
            self.recorder.finish(self.run_time(end_time))
            self.now = end_time
        self.finished = True

    # -- outputs ----------------------------------------------------------------------------

    def run_time(self, t: float) -> float:
        """Run time [s] of ROS time t [s] (0 at the run start), to the ns of the stamps."""
        return round(float(t) - self.start_time, 9)

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
                    "robots_alive": int(self._alive.sum()), **self._traffic_live(),
                    **self.health.live(self.now, self.now)}
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
            "complete_cycles": complete_cycles(counts),
            "robots_alive": int(self._alive.sum()), **self._traffic_live(),
            **self.health.live(self.start_time, max(self.now, self.start_time)),
        }

    def _traffic_live(self) -> dict:
        """The LiveMetrics fields of the refused traffic (tpuaf.measure.traffic)."""
        reasons = self.traffic.by_reason()
        return {"rejected": self.traffic.total, "suspect_traffic": self.traffic.suspect,
                "rejected_reasons": list(reasons), "rejected_counts": list(reasons.values())}

    def summary(self) -> dict:
        """RunRecorder.summary at the run's end (or at the last processed time)."""
        if self.recorder is None:
            raise RuntimeError("the run never started: no complete set of ground-truth poses")
        end = self.start_time + self.duration_s if self.finished else self.now
        summary = self.recorder.summary(self.run_time(end))
        summary.update(plain(self.health.summary(self.start_time, end)))
        summary.update(self.traffic.summary())
        return with_epoch(summary, self.start_time)


def with_epoch(summary: dict, epoch_s: float) -> dict:
    """A run-time summary of a run whose run time 0 is ROS time `epoch_s` [s]."""
    summary["start_time_s"] = float(epoch_s)
    summary["time_base"] = TIME_BASE
    return summary
