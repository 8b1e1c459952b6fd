"""Run metrics (SPEC section 6), shared by the batch engine, the ROS monitor and bag analysis.

`RunRecorder` accumulates a run live; the graph and physics runtimes, the fleet monitor and bag
analysis all feed one (their visits are the robots' REACHED events: arrival at the goal vertex).
Times in seconds of the run clock, positions in metres, vertices are graph indices.

Conventions (chosen where the SPEC is silent):
- a visit's interval idleness is the time since the previous visit of its vertex by any robot;
  the first visit of a vertex only starts its clock (as in patrolling_sim);
- counted visits of a vertex = its visits minus the first one; complete patrol cycles = the
  minimum over vertices of counted visits (an unvisited vertex gives 0);
- I_ins(t) and the worst idleness count a never-visited vertex from the run start;
- the 1 Hz series samples t = start + k * period, k = 1, 2, ...; time means (I_ins, X) are the
  means of those samples;
- an interference episode starts when a pair of live robots comes within d_if (centre to
  centre); the entry is counted if at least `refractory_s` passed since the pair's last counted
  episode, otherwise it is merged into that episode. Pairs already within d_if when first seen
  are not counted (they did not "come" within d_if). Entry times are exact for linear motion
  between `record_positions` calls.
"""

from __future__ import annotations

import bisect
import itertools
import math
from collections import deque
from collections.abc import Sequence
from typing import Any

import numpy as np

from tpuaf.plain import plain

# ---------------------------------------------------------------------------------------------
# Pure functions


def idleness_stats(samples: Sequence[float]) -> dict[str, float]:
    """I_avg, I_std (population), I_min, I_max [s] of interval idleness samples (NaN if none)."""
    a = np.asarray(samples, dtype=float)
    if a.size == 0:
        nan = math.nan
        return {"avg": nan, "std": nan, "min": nan, "max": nan, "count": 0}
    return {"avg": float(a.mean()), "std": float(a.std()), "min": float(a.min()),
            "max": float(a.max()), "count": int(a.size)}


def acceleration_ratio(i_avg_1: float, i_avg_n: float, n: int) -> float:
    """a(N) = I_avg(1) / (N * I_avg(N)); > 1 is super-linear (paper Fig. 8)."""
    if n <= 0 or not i_avg_n > 0:
        return math.nan
    return float(i_avg_1) / (n * float(i_avg_n))


def complete_cycles(visit_counts: Sequence[int]) -> int:
    """min over vertices of counted visits (visits after the first)."""
    return int(min(max(c - 1, 0) for c in visit_counts)) if len(visit_counts) else 0


# ---------------------------------------------------------------------------------------------
# Live recorder

TIMESERIES_COLUMNS = ["time_s", "idleness_ins_s", "worst_idleness_s", "uncertainty_mean",
                      "visits", "interferences"]


class RunRecorder:
    """Accumulates every metric of SPEC section 6 during a run.

    Feed it `record_visit` (goal arrivals, in time order), `record_positions` (true robot
    positions, any rate; motion between calls is taken as linear) and `record_robot_death`.
    Visits may run ahead of positions: the 1 Hz rows are emitted when positions reach them
    (or, without ground truth, by any call), so every row sees exactly the visits up to its time.
    """

    def __init__(self, patrol_map: Any, n_robots: int, *, sample_period_s: float = 1.0,
                 refractory_s: float = 10.0, ground_truth: bool = True,
                 start_time: float = 0.0, max_substep_s: float = 0.25,
                 field_merge_s: float = 0.5, speed_mps: float | None = None,
                 teammate_timeout_s: float | None = None):
        if n_robots <= 0:
            raise ValueError(f"need at least one robot, got {n_robots}")
        if not sample_period_s > 0:
            raise ValueError(f"sample_period_s must be > 0, got {sample_period_s}")
        self.patrol_map = patrol_map
        self.n_robots = int(n_robots)
        self.n_vertices = int(patrol_map.num_vertices)
        self.sample_period_s = float(sample_period_s)
        self.refractory_s = float(refractory_s)
        self.ground_truth = bool(ground_truth)
        self.start_time = float(start_time)
        self.max_substep_s = float(max_substep_s)
        # Consecutive position updates closer than this [s] are merged into one linear step of
        # the ground-truth field (0 = never merge); 0.5 s changes X by < 0.3 % at 1 m/s.
        self.field_merge_s = float(field_merge_s)
        # [m/s] the robots' speed, for the survivors' ideal (default: the map's nominal speed)
        self.speed_mps = float(patrol_map.settings.nominal_speed if speed_mps is None
                               else speed_mps)
        # [s] the survivors' teammate timeout: they can know of a death this long after it (the
        # floor at detection in `recovery`); None: unknown, that floor is NaN
        self.teammate_timeout_s = teammate_timeout_s
        self._field_t = self.start_time
        self._field_p: np.ndarray | None = None
        self._field_finite = True
        s = patrol_map.settings
        self.d_if = float(s.interference_distance)
        self._dif2 = self.d_if * self.d_if

        # Visit statistics: sorted visit times per vertex (visits may arrive out of order).
        self.visits: list[tuple[float, int, int]] = []  # in arrival order
        self.visit_idleness: list[float] = []  # per visit, as known at arrival; NaN = first
        self._vertex_times: list[list[float]] = [[] for _ in range(self.n_vertices)]
        self._visit_count = np.zeros(self.n_vertices, dtype=int)
        self.dwells = 0  # goals ended without a visit (VisitRule)
        self.dwell_time_s = 0.0  # [s] standing in them
        self._goals: dict[int, tuple[float, int, int]] = {}  # robot: (t [s], goal, from)

        # Sampling view: visits applied lazily up to each sample time.
        self._pending: deque[tuple[float, int]] = deque()
        self._sample_last = np.full(self.n_vertices, self.start_time)  # never visited: start
        self._sample_visits = 0
        self._sample_worst = 0.0
        self._next_sample = self.start_time + self.sample_period_s
        self._sample_k = 1
        self.timeseries: list[dict] = []
        self._ins_sum = 0.0
        self._x_sum = 0.0
        self._x_count = 0

        # Positions, interference.
        self._pos_time: float | None = None
        self._pos: np.ndarray | None = None
        self._alive = np.ones(self.n_robots, dtype=bool)
        self.deaths: list[tuple[float, int]] = []
        # Outages (silences the monitor saw): [robot, start s, end s or None, cause]; one not
        # ended by the run's end is a death (`final_deaths`)
        self.outages: list[list] = []
        self.stalls: list[tuple[float, int]] = []
        # Destinations robots announced in their team messages: (time, robot, vertex).
        self.announcements: list[tuple[float, int, int]] = []
        self._shape = (self.n_robots, 2)
        self._all_alive = True
        iu, ju = np.triu_indices(self.n_robots, k=1)
        self._iu, self._ju = iu, ju
        self._n_pairs = len(iu)
        # Row k of pair_matrix @ positions = position[iu[k]] - position[ju[k]].
        self._pair_matrix = np.zeros((len(iu), self.n_robots))
        self._pair_matrix[np.arange(len(iu)), iu] = 1.0
        self._pair_matrix[np.arange(len(iu)), ju] = -1.0
        self._none_close = np.zeros(len(iu), dtype=bool)  # shared, never written
        self._close = self._none_close
        self._last_count = np.full(len(iu), -np.inf)
        self.interferences: list[tuple[float, int, int]] = []  # (time, robot a, robot b)

        # Ground truth field.
        self.field = None
        if self.ground_truth:
            import tpuaf_core

            self.field = tpuaf_core.UncertaintyField(
                np.asarray(patrol_map.positions, dtype=float),
                np.asarray(patrol_map.importance, dtype=float),
                np.asarray(patrol_map.initial_uncertainty, dtype=float),
                patrol_map.uncertainty_model(),
            )
            self._peaks_all = np.full(self.n_robots, float(s.sensing_peak))
            self._radii_all = np.full(self.n_robots, float(s.sensing_radius))
            self._linear = hasattr(self.field, "advance_linear")

    # -- visits ---------------------------------------------------------------------------

    def record_visit(self, robot: int, vertex: int, time: float) -> None:
        """Robot `robot` reached its goal vertex `vertex` (graph index) at `time` [s].

        Visits may arrive out of time order (e.g. delayed messages): the summary is exact
        whatever the order; a 1 Hz row already emitted is not revised."""
        time = float(time)
        if not 0 <= vertex < self.n_vertices:
            raise IndexError(f"vertex index {vertex} out of range (map has {self.n_vertices})")
        times = self._vertex_times[vertex]
        if not times or time >= times[-1]:
            prev = times[-1] if times else math.nan
            times.append(time)
        else:
            k = bisect.bisect_right(times, time)
            prev = times[k - 1] if k else math.nan
            times.insert(k, time)
        self.visit_idleness.append(time - prev)
        self._visit_count[vertex] += 1
        self.visits.append((time, int(robot), int(vertex)))
        pending = self._pending
        if time <= self._next_sample - self.sample_period_s:  # its row is already out
            self._apply_visit(time, int(vertex))
        elif not pending or time >= pending[-1][0]:
            pending.append((time, int(vertex)))
        else:
            k = bisect.bisect_right([t for t, _ in pending], time)
            pending.insert(k, (time, int(vertex)))
        if not self.ground_truth:
            self._emit_until(time, None)

    def record_goal(self, robot: int, vertex: int, from_vertex: int, time: float) -> None:
        """Robot `robot` chose goal `vertex` at `time` [s], standing at `from_vertex`."""
        self._goals[int(robot)] = (float(time), int(vertex), int(from_vertex))

    def record_dwell(self, robot: int, vertex: int, time: float) -> None:
        """A goal of `robot` ended at `vertex` without a visit (a DWELL) at `time` [s]: counted
        apart, no effect on idleness; the time since its goal counts as standing when that goal
        was the vertex it stood on."""
        self.dwells += 1
        goal = self._goals.get(int(robot))
        if goal is not None and goal[1] == goal[2] == int(vertex):
            self.dwell_time_s += max(float(time) - goal[0], 0.0)

    # -- sampling -------------------------------------------------------------------------

    def _apply_pending(self, t: float) -> None:
        pending = self._pending
        while pending and pending[0][0] <= t:
            self._apply_visit(*pending.popleft())

    def _apply_visit(self, vt: float, v: int) -> None:
        last = self._sample_last
        self._sample_worst = max(self._sample_worst, vt - last[v])
        last[v] = max(last[v], vt)
        self._sample_visits += 1

    def _emit_row(self, t: float, x_mean: float) -> None:
        self._apply_pending(t)
        last = self._sample_last
        ins = t - float(last.mean())
        worst = max(self._sample_worst, t - float(last.min()))
        self._ins_sum += ins
        if not math.isnan(x_mean):
            self._x_sum += x_mean
            self._x_count += 1
        self.timeseries.append({
            "time_s": t,
            "idleness_ins_s": ins,
            "worst_idleness_s": worst,
            "uncertainty_mean": x_mean,
            "visits": self._sample_visits,
            "interferences": self._interferences_until(t),
        })

    def _interferences_until(self, t: float) -> int:
        n = len(self.interferences)
        while n and self.interferences[n - 1][0] > t:
            n -= 1
        return n

    def _emit_until(self, t: float, x_mean: float | None) -> None:
        """Rows for sample times <= t, without ground truth (X = NaN unless given)."""
        while self._next_sample <= t + 1e-9:
            self._emit_row(self._next_sample, math.nan if x_mean is None else x_mean)
            self._advance_sample()

    def _advance_sample(self) -> None:
        self._sample_k += 1
        self._next_sample = self.start_time + self._sample_k * self.sample_period_s

    # -- positions ------------------------------------------------------------------------

    def record_positions(self, time: float, positions: np.ndarray) -> None:
        """True robot positions (n_robots, 2) [m] at `time` [s]; NaN rows = robot absent/dead.

        Advances the ground-truth field, counts interference episodes and emits the 1 Hz rows
        crossed since the previous call, taking the motion in between as linear."""
        t1 = float(time)
        p1 = np.array(positions, dtype=float)
        if p1.shape != self._shape:
            p1 = p1.reshape(self._shape)
        if not self._all_alive:
            p1[~self._alive] = np.nan
        p0 = self._pos
        if p0 is None:
            t0 = self.start_time if t1 >= self.start_time else t1
            p0 = p1
            # Pairs already close at the start are not counted (they did not come close).
            d = p1[self._iu] - p1[self._ju]
            self._close = np.einsum("ij,ij->i", d, d) <= self._dif2  # NaN compares False
            finite = not np.isnan(p1).any()
        else:
            t0 = self._pos_time
            if t1 < t0:
                raise ValueError(f"positions at {t1} s are earlier than the previous ones "
                                 f"({t0} s)")
            step = float(np.abs(p1 - p0).max())  # NaN when a robot is absent at either end
            finite = step == step
            if self._n_pairs:
                if finite:
                    d1 = self._pair_matrix @ p1
                else:  # not pair_matrix @ p1: 0 * NaN would spread an absent robot's NaN
                    d1 = p1[self._iu] - p1[self._ju]
                c1 = np.einsum("ij,ij->i", d1, d1)
                # A pair that came within d_if in this interval ends within
                # d_if + 2 * (largest displacement), displacement <= sqrt(2) * step.
                reach = self.d_if + 2.8285 * step if finite else math.inf
                near = c1 <= reach * reach  # NaN (absent robot) compares False
                if near.any():
                    self._interference(t0, t1, p0, d1, c1, near)
                else:
                    self._close = self._none_close
        if self.ground_truth:
            # The field advances over chunks of >= field_merge_s (the chord of the chunk), at
            # every sample time and whenever a robot is absent.
            if (not finite or self._next_sample <= t1 + 1e-9
                    or t1 - self._field_t >= self.field_merge_s or self._field_p is None):
                fp = p0 if self._field_p is None else self._field_p
                self._advance_field(self._field_t, t1, fp, p1, finite and self._field_finite)
                self._field_t, self._field_p, self._field_finite = t1, p1, finite
        elif self._next_sample <= t1 + 1e-9:
            self._emit_until(t1, None)
        self._pos_time, self._pos = t1, p1

    def _interference(self, t0: float, t1: float, p0: np.ndarray, d1: np.ndarray,
                      c1: np.ndarray, near: np.ndarray) -> None:
        """Exact episode entries, for linear motion from p0 (t0) to p1 (t1), of the pairs
        `near` (d1 = pair differences at t1, c1 their squared lengths)."""
        dif2 = self._dif2
        close_end = c1 <= dif2
        # |d0 + s dv|^2 is convex in s: a pair close at both ends is close throughout, and a
        # pair enters at most once per interval. Candidates: near pairs apart before.
        cand = np.flatnonzero(near & ~self._close)
        new: list[tuple[float, int, int]] = []
        for k in cand.tolist():
            i, j = int(self._iu[k]), int(self._ju[k])
            x0 = float(p0[i, 0] - p0[j, 0])
            y0 = float(p0[i, 1] - p0[j, 1])
            if x0 != x0 or y0 != y0:  # absent at t0: appears now, not an entry
                continue
            vx, vy = float(d1[k, 0]) - x0, float(d1[k, 1]) - y0
            a = vx * vx + vy * vy
            b = x0 * vx + y0 * vy  # half the linear coefficient
            c0 = x0 * x0 + y0 * y0
            if c0 <= dif2:
                s_in = 0.0
            else:
                s_star = min(max(-b / a, 0.0), 1.0) if a > 0 else 0.0
                if a * s_star * s_star + 2 * b * s_star + c0 > dif2:
                    continue  # never within d_if in this interval
                # smallest root of a s^2 + 2 b s + (c0 - d^2) = 0
                s_in = (-b - math.sqrt(max(b * b - a * (c0 - dif2), 0.0))) / a
            t_in = t0 + min(max(s_in, 0.0), 1.0) * (t1 - t0)
            if t_in - self._last_count[k] >= self.refractory_s:
                self._last_count[k] = t_in
                new.append((t_in, i, j))
        if new:
            self.interferences.extend(sorted(new))  # all after t0: the list stays sorted
        self._close = close_end

    def _advance_field(self, t0: float, t1: float, p0: np.ndarray, p1: np.ndarray,
                       finite: bool) -> None:
        field = self.field
        if finite:
            peaks, radii = self._peaks_all, self._radii_all
        else:
            live = ~(np.isnan(p0[:, 0]) | np.isnan(p1[:, 0]))
            p0, p1 = p0[live], p1[live]
            peaks, radii = self._peaks_all[: len(p0)], self._radii_all[: len(p0)]
        ta, pa = t0, p0
        span = t1 - t0
        while self._next_sample <= t1 + 1e-9:
            ts = self._next_sample
            pb = p0 + (p1 - p0) * ((ts - t0) / span) if span > 0 else p1
            self._step(ts - ta, pa, pb, peaks, radii)
            self._emit_row(ts, float(np.mean(field.values)))
            self._advance_sample()
            ta, pa = ts, pb
        if t1 > ta:
            self._step(t1 - ta, pa, p1, peaks, radii)

    def _step(self, dt: float, pa: np.ndarray, pb: np.ndarray, peaks: np.ndarray,
              radii: np.ndarray) -> None:
        if dt <= 0:
            return
        if len(pa) == 0:
            self.field.advance_uncovered(dt)
        elif self._linear:
            self.field.advance_linear(dt, pa, pb, peaks, radii, self.max_substep_s)
        else:
            self.field.advance(dt, 0.5 * (pa + pb), peaks, radii)

    def record_robot_death(self, robot: int, time: float) -> None:
        """Robot `robot` stopped at `time` [s]: it no longer senses nor interferes."""
        if self._alive[robot]:
            self._alive[robot] = False
            self._all_alive = False
            self.deaths.append((float(time), int(robot)))

    def record_robot_outage(self, robot: int, time: float, cause: str) -> None:
        """Robot `robot` went out of contact at `time` [s] (it no longer senses nor interferes);
        a death unless `record_robot_back` ends the outage."""
        if self._alive[robot]:
            self._alive[robot] = False
            self._all_alive = False
            self.outages.append([int(robot), float(time), None, str(cause)])

    def record_robot_back(self, robot: int, time: float) -> None:
        """Robot `robot`, out of contact, was heard again at `time` [s]: alive again."""
        for outage in reversed(self.outages):
            if outage[0] == robot:
                if outage[2] is None and not self._alive[robot]:
                    outage[2] = float(time)
                    self._alive[robot] = True
                    self._all_alive = bool(self._alive.all())
                return

    def final_deaths(self) -> list[tuple[float, int]]:
        """(time [s], robot) of the deaths: those recorded and the outages never ended."""
        return sorted(self.deaths + [(o[1], o[0]) for o in self.outages if o[2] is None])

    def outage_list(self) -> list[dict]:
        """The outages as summary rows (end_s None: never heard again, a death)."""
        return [{"robot": r, "start_s": t0, "end_s": t1, "cause": c}
                for r, t0, t1, c in self.outages]

    def record_robot_stall(self, robot: int, time: float) -> None:
        """Robot `robot` stopped moving at `time` [s] (it still senses and talks)."""
        self.stalls.append((float(time), int(robot)))

    def record_announcement(self, robot: int, vertex: int, time: float) -> None:
        """Robot `robot` announced at `time` [s] that it heads to `vertex` (graph index)."""
        self.announcements.append((float(time), int(robot), int(vertex)))

    # -- recovery after deaths --------------------------------------------------------------

    def recovery(self, end_time: float) -> list[dict]:
        """Per death (time order), up to `end_time` [s]:

        - recovery_time_s: time from the death until every vertex has been visited again
          (None if some vertex was not by the end);
        - worst_idleness_after_s: the worst idleness (t - last visit, any vertex) at any time t
          from the death to the next death or the end (time before the death counts);
        - ideal_worst_idleness_survivors_s: the reference tours' best worst idleness (cyclic
          or partition, tpuaf.maps.tours) for the survivors on this map at `speed_mps`;
        - floor_worst_idleness_after_s: what no strategy could avoid after this death
          (`death_floor`: each vertex's idleness at the death plus the shortest drive to it
          from any survivor, at `speed_mps`); worst_idleness_ratio_to_reference: the worst
          idleness after over max(floor, ideal), 1.0 = as good as the death allows;
        - detection_floor_worst_idleness_after_s: the same floor from the state when the
          survivors could first know of the death, `teammate_timeout_s` after it (no reaction
          can start sooner; NaN without a timeout); worst_idleness_ratio_to_detection_reference:
          the worst idleness after over max(that floor, ideal);
        - intentions: the vertices the dead robot had announced as its next destination in
          the team messages it sent since its last visit (what its teammates may count on it
          for); intentions_honoured: how many of them a teammate visited after the death,
          intention_delays_s: after how long (None: never)."""
        return recovery_after_deaths(
            self.patrol_map, self.n_robots, self.speed_mps, self.start_time, self._vertex_times,
            self.visits, self.final_deaths(), self.announcements, end_time,
            teammate_timeout_s=self.teammate_timeout_s)

    # -- results --------------------------------------------------------------------------

    @property
    def interval_samples(self) -> list[float]:
        """Interval idleness samples [s], vertex by vertex in time order."""
        return [b - a for times in self._vertex_times for a, b in itertools.pairwise(times)]

    def worst_idleness(self, end_time: float) -> float:
        """max over vertices and time up to end_time of (t - last visit) [s]."""
        worst = 0.0
        for times in self._vertex_times:
            prev = self.start_time
            for t in times:
                worst = max(worst, t - prev)
                prev = t
            worst = max(worst, float(end_time) - prev)
        return worst

    @property
    def visit_counts(self) -> list[int]:
        return [int(c) for c in self._visit_count]

    @property
    def vertex_times(self) -> list[list[float]]:
        """Per vertex, its visit times [s], sorted."""
        return self._vertex_times

    @property
    def first_visit_times(self) -> list[float]:
        """Time [s] of each vertex's first visit (NaN: never visited)."""
        return [times[0] if times else math.nan for times in self._vertex_times]

    def finish(self, end_time: float) -> None:
        """Bring every accumulator to `end_time` [s] (robots held at their last positions)."""
        end_time = float(end_time)
        if not self.ground_truth:
            self._emit_until(end_time, None)
        elif self._pos is None:  # no positions ever: no robot covered anything
            self.record_positions(end_time, np.full((self.n_robots, 2), np.nan))
        elif end_time > self._pos_time:
            self.record_positions(end_time, self._pos)
        self._flush_field()

    def _flush_field(self) -> None:
        """Advance the ground-truth field over a merged chunk still pending."""
        if self.field is not None and self._pos is not None and self._field_t < self._pos_time:
            finite = self._field_finite and not np.isnan(self._pos).any()
            self._advance_field(self._field_t, self._pos_time, self._field_p, self._pos, finite)
            self._field_t, self._field_p, self._field_finite = self._pos_time, self._pos, finite

    def uncertainty(self) -> np.ndarray:
        """Ground-truth X of every target at the latest positions' time (NaN without)."""
        if self.field is None:
            return np.full(self.n_vertices, np.nan)
        self._flush_field()
        return np.asarray(self.field.values, dtype=float)

    def summary(self, end_time: float) -> dict:
        """Every metric of SPEC section 6 at `end_time` [s], JSON-serialisable (NaN -> null)."""
        self.finish(end_time)
        x_final = float(np.mean(self.field.values)) if self.field is not None else math.nan
        deaths = self.final_deaths()
        return build_summary(
            self, end_time, interval_samples=self.interval_samples, ins_sum=self._ins_sum,
            n_rows=len(self.timeseries), worst=self.worst_idleness(end_time),
            x_sum=self._x_sum, x_count=self._x_count, x_final=x_final,
            n_interferences=len(self.interferences), n_visits=len(self.visits),
            deaths=deaths, stalls=self.stalls, outages=self.outage_list(),
            recovery=self.recovery(end_time) if deaths else None)


class _VisitFigures:
    """A recorder's visit figures as numpy arrays, converted once for every death of a run:
    `vertex_times` (sorted visit times [s] per vertex) flattened, and `visits` (t, robot,
    vertex) as three columns (robot and vertex indices are exact as floats)."""

    def __init__(self, vertex_times, visits, start_time: float):
        self.start_time = start_time
        counts = np.fromiter((len(times) for times in vertex_times), dtype=np.intp,
                             count=len(vertex_times))
        self.counts = counts
        self.flat = np.fromiter(itertools.chain.from_iterable(vertex_times), dtype=float,
                                count=int(counts.sum()))
        self.first = np.cumsum(counts) - counts  # each vertex's first index in `flat`
        self.vertex = np.repeat(np.arange(len(counts)), counts)  # each time's vertex
        self.local = np.arange(len(self.flat)) - self.first[self.vertex]  # index in its list
        self.gap = np.full(len(self.flat), -np.inf)  # time - the vertex's previous time
        self.gap[1:] = self.flat[1:] - self.flat[:-1]
        log = np.fromiter(itertools.chain.from_iterable(visits), dtype=float,
                          count=3 * len(visits)).reshape(-1, 3)
        self.t, self.robot, self.visited = log[:, 0], log[:, 1], log[:, 2]

    def count_until(self, time: float) -> np.ndarray:
        """Per vertex, how many of its times are <= `time` (bisect_right on its list)."""
        return np.bincount(self.vertex[self.flat <= time], minlength=len(self.counts))

    def previous(self, j: np.ndarray) -> np.ndarray:
        """Per vertex, its time at index j - 1 (with j = count_until(t): its last visit at
        or before t), or the start time when j is 0."""
        out = np.full(len(self.counts), float(self.start_time))
        some = j > 0
        out[some] = self.flat[self.first[some] + j[some] - 1]
        return out

    def last_visits(self, death_s: float) -> tuple[dict, dict]:
        """Per robot, (t, vertex) of its last visit at or before `death_s` (the latest in the
        log of equal times) and of its first visit after (the earliest in the log)."""
        t, robot = self.t, self.robot
        out = []
        for rows, last in ((np.flatnonzero(t <= death_s), True),
                           (np.flatnonzero(t > death_s), False)):
            order = rows[np.lexsort((rows, t[rows], robot[rows]))]  # robot, time, log order
            r = robot[order]
            change = r[1:] != r[:-1]  # a robot's group ends / starts here
            ends = (np.append(change, len(r) > 0) if last
                    else np.insert(change, 0, len(r) > 0))
            out.append({int(robot[i]): (float(t[i]), int(self.visited[i]))
                        for i in order[ends[:len(order)]]})
        return out[0], out[1]


def recovery_after_deaths(patrol_map: Any, n_robots: int, speed_mps: float, start_time: float,
                          vertex_times, visits, deaths, announcements, end_time: float,
                          teammate_timeout_s: float | None = None) -> list[dict]:
    """RunRecorder.recovery from a recorder's figures (the Python recorder's and the C++ event
    loop's): vertex_times sorted visit times [s] per vertex, visits (t, robot, vertex),
    deaths (t, robot), announcements (t, robot, vertex); teammate_timeout_s [s]: the
    survivors' timeout (None: the floor at detection is NaN)."""
    from tpuaf.maps.tours import reference_tours

    end_time = float(end_time)
    ids = list(patrol_map.vertex_ids)
    speed = speed_mps
    deaths = sorted(d for d in deaths if d[0] <= end_time)
    if not deaths:
        return []
    log = _VisitFigures(vertex_times, visits, start_time)
    flat, first, counts = log.flat, log.first, log.counts
    dying = {r for _, r in deaths}
    announced = [a for a in announcements if a[1] in dying]
    out = []
    for k, (td, robot) in enumerate(deaths):
        until = deaths[k + 1][0] if k + 1 < len(deaths) else end_time
        survivors = n_robots - (k + 1)
        ideal = (reference_tours(patrol_map, survivors, speed)["best_worst_idleness_s"]
                 if survivors > 0 else math.nan)
        j = log.count_until(td)  # per vertex: its visits up to the death
        upto = log.count_until(until)  # ... up to the window's end
        prev = log.previous(j)  # [s] each vertex's last visit at the death (or the start)
        # every vertex visited again: the first visit after the death, up to the end
        nxt = np.full(len(counts), math.inf)
        later = j < counts
        at = flat[first[later] + j[later]]
        nxt[later] = np.where(at <= end_time, at, math.inf)
        recovered = float(nxt.max()) if len(nxt) else td
        # worst idleness in (death, until]: the gaps between consecutive times in the window,
        # from the last visit before it, and to its end
        worst = 0.0
        inner = (log.local > j[log.vertex]) & (log.local < upto[log.vertex])
        if inner.any():
            worst = max(worst, float(log.gap[inner].max()))
        seen = upto > j
        if seen.any():
            firsts = flat[first[seen] + j[seen]] - prev[seen]
            lasts = until - flat[first[seen] + upto[seen] - 1]
            worst = max(worst, float(firsts.max()), float(lasts.max()))
        if (~seen).any():
            worst = max(worst, float((until - prev[~seen]).max()))
        dead = {r for t, r in deaths if t <= td}
        survivors_now = [r for r in range(n_robots) if r not in dead]
        floor = _death_floor(patrol_map, speed, log, prev, td, until, survivors_now)
        reference = max(floor, ideal) if ideal == ideal else floor
        detect_floor = detect_reference = math.nan
        if teammate_timeout_s is not None:
            # the survivors can first know at td + timeout (or the window's end, if sooner:
            # the same survivors, as the next death ends the window)
            known = min(td + float(teammate_timeout_s), until)
            detect_floor = _death_floor(patrol_map, speed, log, log.previous(log.count_until(known)),
                                        known, until, survivors_now)
            detect_reference = max(detect_floor, ideal) if ideal == ideal else detect_floor
        own = log.t[(log.robot == robot) & (log.t <= td)]
        last_own = float(own.max()) if len(own) else start_time
        intentions = sorted({v for t, r, v in announced
                             if r == robot and last_own <= t <= td})
        delays = []
        for v in intentions:
            later_visits = log.t[(log.visited == v) & (log.robot != robot) & (log.t > td)]
            delays.append(float(later_visits.min()) - td if len(later_visits) else math.nan)
        out.append({
            "robot": robot,
            "time_s": td,
            "survivors": survivors,
            "recovery_time_s": recovered - td if math.isfinite(recovered) else math.nan,
            "worst_idleness_after_s": worst,
            "window_end_s": until,
            "ideal_worst_idleness_survivors_s": ideal,
            "worst_idleness_ratio": worst / ideal if ideal > 0 else math.nan,
            "floor_worst_idleness_after_s": floor,
            "worst_idleness_ratio_to_reference": worst / reference if reference > 0 else math.nan,
            "detection_floor_worst_idleness_after_s": detect_floor,
            "worst_idleness_ratio_to_detection_reference":
                worst / detect_reference if detect_reference > 0 else math.nan,
            "intentions": [int(ids[v]) for v in intentions],
            "intentions_honoured": sum(1 for d in delays if d == d),
            "intention_delays_s": delays,
        })
    return out


def death_floor(patrol_map: Any, speed_mps: float, start_time: float, vertex_times, visits,
                death_s: float, until_s: float, survivors: Sequence[int]) -> float:
    """[s] the worst idleness that no strategy could avoid from a death at `death_s` up to
    `until_s`, from the state at the death: max over vertices v of the idleness of v at the
    death plus the shortest drive to v from any survivor at `speed_mps`, capped at `until_s`
    (NaN without survivors). `vertex_times`: sorted visit times [s] per vertex; `visits`:
    (t, robot, vertex) (a recorder's figures).

    A survivor's position at the death is bounded from its own visits alone, by
    the triangle inequality on the graph's shortest-path lengths d [m]: it stood on vertex a at
    t_a <= death and reaches vertex b at t_b > death, so its distance to v is at least
    max(d(a, v) - speed (death - t_a), d(b, v) - speed (t_b - death), 0). Exact in the graph
    runtime (robots drive the graph); in the physics runtime d is the planned length."""
    survivors = list(survivors)
    if not survivors:
        return math.nan
    log = _VisitFigures(vertex_times, visits, start_time)
    return _death_floor(patrol_map, speed_mps, log, log.previous(log.count_until(death_s)),
                        death_s, until_s, survivors)


def _death_floor(patrol_map: Any, speed_mps: float, log: _VisitFigures, prev: np.ndarray,
                 death_s: float, until_s: float, survivors: list[int]) -> float:
    """death_floor with the visit figures converted (`prev`: [s] each vertex's last visit at
    the death, or the start time)."""
    if not survivors:
        return math.nan
    speed = float(speed_mps)
    dist = np.asarray(patrol_map.graph.distances, dtype=float)
    n_vertices = len(dist)
    before, after = log.last_visits(death_s)
    reach = np.full(n_vertices, np.inf)  # [m] least drive to each vertex, any survivor
    for r in survivors:
        lower = np.zeros(n_vertices)
        known = False
        if r in before:
            t, a = before[r]
            lower = np.maximum(lower, dist[a] - speed * (death_s - t))
            known = True
        if r in after:
            t, b = after[r]
            lower = np.maximum(lower, dist[b] - speed * (t - death_s))
            known = True
        reach = np.minimum(reach, lower if known else 0.0)
    floor = 0.0
    if len(prev):
        worst = float(np.minimum(death_s - prev + reach[:len(prev)] / speed,
                                 until_s - prev).max())
        floor = max(floor, worst)
    return float(floor)


def first_coverage(rec: Any, end_time: float) -> dict[str, float]:
    """first_coverage_s: time [s] from the start until every vertex had been visited once (NaN
    when some vertex was not by `end_time`); first_coverage_bound_s: the lower bound of any
    strategy from the run's start vertices at nominal speed (tours.first_coverage_bound)."""
    from tpuaf.maps import start_vertices
    from tpuaf.maps.tours import first_coverage_bound

    first = getattr(rec, "first_visit_times", None)
    if first is None:  # a recorder without per-vertex times: from its visit log
        first = [math.nan] * rec.n_vertices
        for t, _, v in rec.visits:
            if not t >= first[v]:  # NaN or later
                first[v] = t
    last = max(first, default=rec.start_time)
    covered = all(t == t and t <= end_time for t in first)
    pm = rec.patrol_map
    bound = first_coverage_bound(pm, start_vertices(pm, rec.n_robots),
                                 float(pm.settings.nominal_speed))
    return {"first_coverage_s": last - rec.start_time if covered else math.nan,
            "first_coverage_bound_s": bound}


def build_summary(rec: Any, end_time: float, *, interval_samples, ins_sum: float, n_rows: int,
                  worst: float, x_sum: float, x_count: int, x_final: float,
                  n_interferences: int, n_visits: int, deaths=(), stalls=(),
                  recovery: list | None = None, outages: list | None = None) -> dict:
    """The summary of SPEC section 6 from a recorder's accumulated figures; one layout for the
    Python recorder and the C++ event loop's (`rec`: patrol_map, n_robots, n_vertices,
    start_time, d_if, visit_counts, sample_period_s). Times [s]; NaN -> null."""
    duration = float(end_time) - rec.start_time
    stats = idleness_stats(interval_samples)
    counts = rec.visit_counts
    ids = list(rec.patrol_map.vertex_ids)
    out = {
        "map": rec.patrol_map.name,
        "n_robots": rec.n_robots,
        "n_vertices": rec.n_vertices,
        "start_time_s": rec.start_time,
        "duration_s": duration,
        "idleness_avg_s": stats["avg"],
        "idleness_std_s": stats["std"],
        "idleness_min_s": stats["min"],
        "idleness_max_s": stats["max"],
        "idleness_samples": stats["count"],
        "idleness_ins_mean_s": ins_sum / n_rows if n_rows else math.nan,
        "worst_idleness_s": worst,
        "uncertainty_mean": x_sum / x_count if x_count else math.nan,
        "uncertainty_final_mean": x_final,
        "interferences": n_interferences,
        "interference_rate_per_min": (n_interferences / (duration / 60.0)
                                      if duration > 0 else math.nan),
        "interference_distance_m": rec.d_if,
        "visits": n_visits,
        # VisitRule (docs/RUNTIMES.md "Visits"): goals ended without a visit, counted apart;
        # patrolling_sim's count: every goal arrival (start and dwells included)
        "dwells": int(rec.dwells),
        "dwell_time_s": float(rec.dwell_time_s),
        "visits_patrolling_sim": n_visits + int(rec.dwells),
        "counted_visits": sum(max(c - 1, 0) for c in counts),
        "visits_per_vertex": {str(v): c for v, c in zip(ids, counts, strict=True)},
        "unvisited_vertices": int(sum(1 for c in counts if c == 0)),
        "complete_cycles": complete_cycles(counts),
        **first_coverage(rec, end_time),
        "deaths": len(deaths),
        "dead_robots": [r for _, r in deaths],
        # silences of robots heard again (end_s) or never (end_s None: the deaths)
        **({"outages": outages} if outages else {}),
        **({"stalled_robots": [r for _, r in stalls]} if stalls else {}),
        **({"recovery": recovery} if recovery is not None else {}),
        "sample_period_s": rec.sample_period_s,
        "timeseries_rows": n_rows,
    }
    return plain(out)
