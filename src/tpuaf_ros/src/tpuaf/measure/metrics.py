"""Run metrics (SPEC section 6), shared by the graph and physics runtimes, the ROS monitor and bag
analysis.

The one recorder is the C++ core's `tpuaf_core.GroundTruthRecorder` (recorder.cpp): the graph
runtime's event loop feeds it in C++; the physics runtime, the fleet monitor and bag analysis feed
it through `RunRecorder` (their visits are the robots' REACHED events: arrival at the goal
vertex). `RecorderView` is the read side both share (visits, 1 Hz rows, summary, recovery).
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

import math
from typing import Any

import numpy as np
import tpuaf_core

from tpuaf.measure.recovery import death_floor, recovery_after_deaths
from tpuaf.measure.summary import (
    acceleration_ratio,
    build_summary,
    complete_cycles,
    first_coverage,
    idleness_stats,
)
from tpuaf.navigation.bodies import vertices_cut_off
from tpuaf.params import CONTROLLER_DEFAULTS
from tpuaf.topics import DWELL, GOAL, REACHED, START, VERTEX_CLOSED

__all__ = ["TIMESERIES_COLUMNS", "RecorderView", "RunRecorder", "acceleration_ratio",
           "build_summary", "complete_cycles", "death_floor", "first_coverage", "idleness_stats",
           "recovery_after_deaths"]

TIMESERIES_COLUMNS = ["time_s", "idleness_ins_s", "worst_idleness_s", "uncertainty_mean",
                      "visits", "interferences"]

# The recorder's defaults, declared once in the core (recorder.hpp: RecorderConfig).
_DEFAULTS = tpuaf_core.RecorderConfig()


def _caught_up(copy: list, count: int, read_from) -> list:
    """`copy` of a log of the core that only grows, extended to its `count` entries
    (`read_from(first)`: the entries from index first on)."""
    if len(copy) < count:
        copy.extend(read_from(len(copy)))
    return copy


class RecorderView:
    """The read side of a `tpuaf_core.GroundTruthRecorder` (`_core`), what the results writer,
    the monitor and the summaries read. A subclass sets `_core` and patrol_map, n_robots,
    n_vertices, start_time, sample_period_s, d_if, ground_truth, speed_mps [m/s] (the
    survivors' ideal of the recovery metrics) and teammate_timeout_s [s] (their timeout: the
    floor at detection; None: NaN), then calls `_start_view`."""

    _core: Any
    patrol_map: Any
    n_robots: int
    n_vertices: int
    start_time: float
    sample_period_s: float
    d_if: float
    ground_truth: bool
    speed_mps: float
    teammate_timeout_s: float | None
    # [m] the robots' radius where dead robots' bodies stay in the world (physics, fleets,
    # robots): `bodies_closed`; None: point robots (the graph runtime)
    body_radius_m: float | None = None
    last_seen: np.ndarray | None = None  # [m] (n_robots, 2) each robot's last known position
    planner: Any = None  # the robots' PathPlanner (bodies_closed; None: the map's default)
    # [m] what the robots' controller keeps from obstacles, a body too (bodies_closed)
    safety_margin_m: float = CONTROLLER_DEFAULTS.safety_margin

    def _start_view(self) -> None:
        # Python copies of the logs, extended on read (the core only ever appends to them).
        self._visits: list[tuple[float, int, int]] = []
        self._idleness: list[float] = []
        self._rows: list[dict] = []
        self._interferences: list[tuple[float, int, int]] = []
        # vertices no robot can reach after a death (VERTEX_CLOSED events: a dead robot's body
        # next to them, robot/lanes.py); the recovery also counts without them
        self.closed: set[int] = set()
        self._cut_off: tuple | None = None  # (deaths and bodies, bodies_closed for them)

    def record_closed(self, vertex: int) -> None:
        """A survivor reported vertex `vertex` (index) cut off by a lost teammate's body."""
        self.closed.add(int(vertex))

    def bodies_closed(self) -> set[int]:
        """The vertices dead robots' bodies cut off, in truth (navigation/bodies.py): no survivor,
        from its last known position, can plan a path ending within the visit radius of them
        round the bodies at the dead robots' last known positions (the planner the robots
        drive with: `planner`, else the map's for `body_radius_m`). Empty without bodies. The
        robots' own closures (`closed`, VERTEX_CLOSED) never enter the figures."""
        deaths = self.final_deaths()
        last = self.last_seen
        if self.body_radius_m is None or not deaths or last is None:
            return set()
        dead = sorted({int(robot) for _, robot in deaths})
        bodies = last[dead]
        survivors = np.delete(last, dead, axis=0)
        # once per set of bodies (a live monitor asks every second): the survivors as they
        # stood then are the sources, any of them reaching a vertex will do
        key = (tuple(dead), bodies.tobytes())
        cached = self._cut_off
        if cached is None or cached[0] != key:
            from tpuaf.navigation.planner import shared_planner

            planner = self.planner or shared_planner(self.patrol_map, float(self.body_radius_m))
            cut = vertices_cut_off(planner, self.patrol_map.positions,
                                   float(self.patrol_map.visit_radius_m), bodies,
                                   float(self.body_radius_m), survivors,
                                   float(self.safety_margin_m))
            self._cut_off = cached = (key, cut)
        return set(cached[1])

    def bodies_located(self) -> bool:
        """Whether every dead robot's body has a known position (`bodies_closed` is then the
        truth; without positions, as in a bag with no poses, it is empty)."""
        deaths = self.final_deaths()
        return (self.body_radius_m is not None and bool(deaths) and self.last_seen is not None
                and all(np.isfinite(self.last_seen[int(r)]).all() for _, r in deaths))

    def finish(self, end_time: float) -> None:
        """Bring every accumulator to `end_time` [s] (robots held at their last positions)."""
        self._core.finish(float(end_time))

    def _flush(self) -> None:
        """The field brought to the latest positions' time."""
        self._core.flush_field()

    # -- logs -------------------------------------------------------------------------------

    @property
    def visits(self) -> list[tuple[float, int, int]]:
        """(time [s], robot, vertex) of every visit, in arrival order."""
        return _caught_up(self._visits, self._core.visit_count, self._core.visits)

    @property
    def visit_idleness(self) -> list[float]:
        """Per visit, its interval idleness [s] as known at arrival (NaN: a first visit)."""
        return _caught_up(self._idleness, self._core.visit_count, self._core.visit_idleness)

    @property
    def timeseries(self) -> list[dict]:
        """The 1 Hz rows (dicts of TIMESERIES_COLUMNS)."""
        return _caught_up(self._rows, self._core.row_count, self._core.timeseries)

    @property
    def interferences(self) -> list[tuple[float, int, int]]:
        """(entry time [s], robot a, robot b) of every counted episode, in time order."""
        return _caught_up(self._interferences, self._core.interference_count,
                          self._core.interferences)

    # -- per-vertex figures and faults --------------------------------------------------------

    @property
    def interval_samples(self) -> list[float]:
        """Interval idleness samples [s], vertex by vertex in time order."""
        return self._core.interval_samples.tolist()

    @property
    def visit_counts(self) -> list[int]:
        return [int(c) for c in self._core.visit_counts]

    @property
    def vertex_times(self) -> list[list[float]]:
        """Per vertex, its visit times [s], sorted."""
        return self._core.vertex_times

    @property
    def first_visit_times(self) -> list[float]:
        """Time [s] of each vertex's first visit (NaN: never visited)."""
        return list(self._core.first_visit_times)

    def worst_idleness(self, end_time: float) -> float:
        """max over vertices and time up to end_time of (t - last visit) [s]."""
        return self._core.worst_idleness(float(end_time))

    @property
    def deaths(self) -> list[tuple[float, int]]:
        """(time [s], robot) of the recorded deaths."""
        return self._core.deaths

    def final_deaths(self) -> list[tuple[float, int]]:
        """(time [s], robot) of the deaths: those recorded and the outages never ended."""
        return self._core.final_deaths()

    def outage_list(self) -> list[dict]:
        """The outages as summary rows (end_s None: never heard again, a death)."""
        return self._core.outages

    @property
    def stalls(self) -> list[tuple[float, int]]:
        return self._core.stalls

    @property
    def announcements(self) -> list[tuple[float, int, int]]:
        """(time [s], robot, vertex) of the destinations robots announced."""
        return self._core.announcements

    @property
    def dwells(self) -> int:
        """Goals ended without a visit (VisitRule)."""
        return int(self._core.dwells)

    @property
    def dwell_time_s(self) -> float:
        """[s] standing in those dwells."""
        return float(self._core.dwell_time_s)

    @property
    def _pos_time(self) -> float | None:
        """[s] the latest positions' time (None: none yet)."""
        return self._core.positions_time

    @property
    def last_positions(self) -> np.ndarray | None:
        """The latest positions (n_robots, 2) [m], absent robots NaN (None: none yet)."""
        return self._core.positions

    def uncertainty(self) -> np.ndarray:
        """Ground-truth X of every target at the latest positions' time (NaN without)."""
        if not self.ground_truth:
            return np.full(self.n_vertices, np.nan)
        self._flush()
        return np.asarray(self._core.field_values, dtype=float)

    # -- results ----------------------------------------------------------------------------

    def recovery(self, end_time: float, closed=()) -> list[dict]:
        """Per death (time order), up to `end_time` [s] (docs/RUNTIMES.md "Recovery"):

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
          intention_delays_s: after how long (None: never);
        - with `closed` (vertex indices no robot can reach after the deaths: a dead robot's
          body next to them, robot/lanes.py) also worst_idleness_after_reachable_s and
          worst_idleness_ratio_reachable: the same over the other vertices."""
        return recovery_after_deaths(
            self.patrol_map, self.n_robots, self.speed_mps, self.start_time, self.vertex_times,
            self.visits, self.final_deaths(), self.announcements, end_time,
            teammate_timeout_s=self.teammate_timeout_s, closed=closed)

    def summary(self, end_time: float) -> dict:
        """Every metric of SPEC section 6 at `end_time` [s], JSON-serialisable (NaN -> null);
        with vertices cut off by dead robots' bodies in truth (`bodies_closed`:
        `vertices_under_bodies`, their ids), the recovery over the other vertices too. The
        vertices the robots reported closed (`record_closed`) are listed apart
        (`lane_vertices_closed`; `closed_but_reachable`: those a survivor could still reach)
        and never leave the figures."""
        end_time = float(end_time)
        self.finish(end_time)
        core = self._core
        x_final = float(np.mean(core.field_values)) if self.ground_truth else math.nan
        deaths = self.final_deaths()
        under = self.bodies_closed()
        closed = sorted(under)
        summary = build_summary(
            self, end_time, interval_samples=core.interval_samples, ins_sum=core.ins_sum,
            n_rows=core.row_count, worst=core.worst_idleness(end_time), x_sum=core.x_sum,
            x_count=core.x_count, x_final=x_final, n_interferences=core.interference_count,
            n_visits=core.visit_count, deaths=deaths, stalls=self.stalls,
            outages=self.outage_list(),
            recovery=self.recovery(end_time, closed) if deaths else None)
        ids = self.patrol_map.vertex_ids
        if self.closed:
            summary["lane_vertices_closed"] = [ids[v] for v in sorted(self.closed)]
            if self.bodies_located():  # else the truth is not known
                summary["closed_but_reachable"] = [ids[v] for v in sorted(self.closed - under)]
        if under:
            summary["vertices_under_bodies"] = [ids[v] for v in sorted(under)]
        return summary


class RunRecorder(RecorderView):
    """Accumulates every metric of SPEC section 6 during a run, in the core's recorder.

    Feed it `record_visit` (goal arrivals, in time order or not), `record_positions` (true robot
    positions, any rate; motion between calls is taken as linear; a NaN row: robot absent) and
    the faults. Visits may run ahead of positions: the 1 Hz rows are emitted when positions
    reach them (or, without ground truth, by any call), so every row sees exactly the visits up
    to its time. `field_merge_s` [s]: consecutive position updates closer than this are merged
    into one linear step of the ground-truth field (0 = never merge)."""

    def __init__(self, patrol_map: Any, n_robots: int, *,
                 sample_period_s: float = _DEFAULTS.sample_period_s,
                 refractory_s: float = _DEFAULTS.refractory_s, ground_truth: bool = True,
                 start_time: float = _DEFAULTS.start_time_s,
                 max_substep_s: float = _DEFAULTS.max_substep_s,
                 field_merge_s: float = _DEFAULTS.field_merge_s, speed_mps: float | None = None,
                 teammate_timeout_s: float | None = None, body_radius_m: float | None = None,
                 safety_margin_m: float = CONTROLLER_DEFAULTS.safety_margin):
        if n_robots <= 0:
            raise ValueError(f"need at least one robot, got {n_robots}")
        if not sample_period_s > 0:
            raise ValueError(f"sample_period_s must be > 0, got {sample_period_s}")
        s = patrol_map.settings
        self.patrol_map = patrol_map
        self.n_robots = int(n_robots)
        self.n_vertices = int(patrol_map.num_vertices)
        self.sample_period_s = float(sample_period_s)
        self.refractory_s = float(refractory_s)
        self.ground_truth = bool(ground_truth)
        self.start_time = float(start_time)
        self.max_substep_s = float(max_substep_s)
        self.field_merge_s = float(field_merge_s)
        # [m/s] the robots' speed, for the survivors' ideal (default: the map's nominal speed)
        self.speed_mps = float(s.nominal_speed if speed_mps is None else speed_mps)
        self.teammate_timeout_s = teammate_timeout_s
        self.body_radius_m = None if body_radius_m is None else float(body_radius_m)
        self.safety_margin_m = float(safety_margin_m)
        self.d_if = float(s.interference_distance)
        config = tpuaf_core.RecorderConfig()
        config.robots = self.n_robots
        config.start_time_s = self.start_time
        config.sample_period_s = self.sample_period_s
        config.refractory_s = self.refractory_s
        config.max_substep_s = self.max_substep_s
        config.field_merge_s = self.field_merge_s
        config.interference_distance_m = self.d_if
        config.sensing_peak = float(s.sensing_peak)
        config.sensing_radius_m = float(s.sensing_radius)
        config.ground_truth = self.ground_truth
        field = tpuaf_core.UncertaintyField(
            np.asarray(patrol_map.positions, dtype=float),
            np.asarray(patrol_map.importance, dtype=float),
            np.asarray(patrol_map.initial_uncertainty, dtype=float),
            patrol_map.uncertainty_model(),
        )
        self._core = tpuaf_core.GroundTruthRecorder(config, field)
        self._shape = (self.n_robots, 2)
        self.last_seen = np.full(self._shape, np.nan)  # [m] each robot's last known position
        self._start_view()

    @property
    def core(self) -> Any:
        """The core's recorder (tpuaf_core.GroundTruthRecorder: the team's faults are noted in
        it by tpuaf_core.TeamLiveness)."""
        return self._core

    def record_visit(self, robot: int, vertex: int, time: float) -> None:
        """Robot `robot` reached its goal vertex `vertex` (graph index) at `time` [s].

        Visits may arrive out of time order (e.g. delayed messages): the summary is exact
        whatever the order; a 1 Hz row already emitted is not revised."""
        self._core.record_visit(int(robot), int(vertex), float(time))

    def record_positions(self, time: float, positions: np.ndarray) -> None:
        """True robot positions (n_robots, 2) [m] at `time` [s]; NaN rows = robot absent/dead.

        Advances the ground-truth field, counts interference episodes and emits the 1 Hz rows
        crossed since the previous call, taking the motion in between as linear."""
        p = np.asarray(positions, dtype=float)
        if p.shape != self._shape:
            p = p.reshape(self._shape)
        seen = np.isfinite(p).all(axis=1)
        self.last_seen[seen] = p[seen]
        self._core.record_positions(float(time), p)

    def record_goal(self, robot: int, vertex: int, from_vertex: int, time: float) -> None:
        """Robot `robot` chose goal `vertex` at `time` [s], standing at `from_vertex`."""
        self._core.record_goal(int(robot), int(vertex), int(from_vertex), float(time))

    def record_dwell(self, robot: int, vertex: int, time: float) -> None:
        """A goal of `robot` ended at `vertex` without a visit (a DWELL) at `time` [s]: counted
        apart, no effect on idleness; the time since its goal counts as standing when that goal
        was the vertex it stood on."""
        self._core.record_dwell(int(robot), int(vertex), float(time))

    def record_event(self, robot: int, kind: int, vertex: int, from_vertex: int,
                     time: float) -> bool:
        """One of a robot's events (tpuaf.topics, the agents' `emit` and event topic) at
        `time` [s] to the record, the same in every runtime and `tpuaf analyze`: START (the
        start vertex's first visit) and REACHED are visits, GOAL and DWELL go to the goal and
        dwell logs, VERTEX_CLOSED to the closed vertices; the rest (heartbeats, lanes) and a
        vertex < 0 are not recorded. Returns True for a visit."""
        if vertex < 0:
            return False
        if kind == REACHED or kind == START:
            self._core.record_visit(int(robot), int(vertex), float(time))
            return True
        if kind == GOAL:
            self.record_goal(robot, vertex, from_vertex, time)
        elif kind == DWELL:
            self.record_dwell(robot, vertex, time)
        elif kind == VERTEX_CLOSED:
            self.record_closed(vertex)
        return False

    def record_robot_death(self, robot: int, time: float) -> None:
        """Robot `robot` stopped at `time` [s]: it no longer senses nor interferes."""
        self._core.record_robot_death(int(robot), float(time))

    def record_robot_outage(self, robot: int, time: float, cause: str) -> None:
        """Robot `robot` went out of contact at `time` [s] (it no longer senses nor interferes);
        a death unless `record_robot_back` ends the outage."""
        self._core.record_robot_outage(int(robot), float(time), str(cause))

    def record_robot_back(self, robot: int, time: float) -> None:
        """Robot `robot`, out of contact, was heard again at `time` [s]: alive again."""
        self._core.record_robot_back(int(robot), float(time))

    def record_robot_stall(self, robot: int, time: float) -> None:
        """Robot `robot` stopped moving at `time` [s] (it still senses and talks)."""
        self._core.record_robot_stall(int(robot), float(time))

    def record_announcement(self, robot: int, vertex: int, time: float) -> None:
        """Robot `robot` announced at `time` [s] that it heads to `vertex` (graph index)."""
        self._core.record_announcement(int(robot), int(vertex), float(time))
