"""Recovery after deaths (docs/RUNTIMES.md "Recovery"): per death, how long until every vertex
was visited again, the worst idleness after it, and what no strategy could have avoided
(`death_floor`). Computed after the run from a recorder's figures (the same for every runtime:
`RecorderView.recovery`). Times [s], lengths [m], vertices are graph indices.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import Any

import numpy as np


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
                          teammate_timeout_s: float | None = None,
                          closed: Sequence[int] = ()) -> list[dict]:
    """RecorderView.recovery from a recorder's figures: vertex_times sorted visit times [s] per
    vertex, visits (t, robot, vertex), deaths (t, robot), announcements (t, robot, vertex);
    teammate_timeout_s [s]: the survivors' timeout (None: the floor at detection is NaN).
    `closed`: vertex indices no robot can reach after the deaths (a dead robot's body next to
    them, robot/lanes.py); when given, each death also gets the worst idleness after it and
    its ratio to the detection reference over the other vertices (`..._reachable`)."""
    from tpuaf.maps.tours import reference_tours

    end_time = float(end_time)
    ids = list(patrol_map.vertex_ids)
    speed = speed_mps
    deaths = sorted(d for d in deaths if d[0] <= end_time)
    if not deaths:
        return []
    log = _VisitFigures(vertex_times, visits, start_time)
    dying = {r for _, r in deaths}
    announced = [a for a in announcements if a[1] in dying]
    out = []
    for k, (td, robot) in enumerate(deaths):
        until = deaths[k + 1][0] if k + 1 < len(deaths) else end_time
        survivors = n_robots - (k + 1)
        ideal = (reference_tours(patrol_map, survivors, speed)["best_worst_idleness_s"]
                 if survivors > 0 else math.nan)
        j = log.count_until(td)  # per vertex: its visits up to the death
        prev = log.previous(j)  # [s] each vertex's last visit at the death (or the start)
        recovered = _recovered_at(log, j, td, end_time)
        worst = _worst_after(log, j, log.count_until(until), prev, until)
        dead = {r for t, r in deaths if t <= td}
        survivors_now = [r for r in range(n_robots) if r not in dead]
        floor = _death_floor(patrol_map, speed, log, prev, td, until, survivors_now)
        reference = max(floor, ideal) if ideal == ideal else floor
        detect_floor, detect_reference = _detection_reference(
            patrol_map, speed, log, td, until, survivors_now, ideal, teammate_timeout_s)
        intentions, delays = _intentions(log, announced, robot, td, start_time)
        reachable = {}
        if closed:
            keep = np.ones(len(log.counts), dtype=bool)
            keep[[int(v) for v in closed]] = False
            worst_open = _worst_after(log, j, log.count_until(until), prev, until, keep)
            _, reference_open = _detection_reference(
                patrol_map, speed, log, td, until, survivors_now, ideal, teammate_timeout_s, keep)
            reachable = {
                "worst_idleness_after_reachable_s": worst_open,
                "worst_idleness_ratio_reachable":
                    worst_open / reference_open if reference_open > 0 else math.nan,
            }
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
            **reachable,
        })
    return out


def _detection_reference(patrol_map: Any, speed: float, log: _VisitFigures, death_s: float,
                         until: float, survivors: list[int], ideal: float,
                         teammate_timeout_s: float | None, keep=None) -> tuple[float, float]:
    """(floor at detection, max(it, ideal)) [s] over the vertices `keep` (None: all); NaN
    without a timeout. The survivors can first know at the death + timeout (or the window's
    end, if sooner: the same survivors, as the next death ends the window)."""
    if teammate_timeout_s is None:
        return math.nan, math.nan
    known = min(death_s + float(teammate_timeout_s), until)
    floor = _death_floor(patrol_map, speed, log, log.previous(log.count_until(known)), known,
                         until, survivors, keep)
    return floor, (max(floor, ideal) if ideal == ideal else floor)


def _recovered_at(log: _VisitFigures, j: np.ndarray, death_s: float, end_time: float) -> float:
    """[s] when every vertex had been visited again after the death (j: each vertex's visits
    up to it): the latest first visit after it, inf when some vertex had none by the end."""
    flat, first, counts = log.flat, log.first, log.counts
    nxt = np.full(len(counts), math.inf)
    later = j < counts
    at = flat[first[later] + j[later]]
    nxt[later] = np.where(at <= end_time, at, math.inf)
    return float(nxt.max()) if len(nxt) else death_s


def _worst_after(log: _VisitFigures, j: np.ndarray, upto: np.ndarray, prev: np.ndarray,
                 until: float, keep: np.ndarray | None = None) -> float:
    """[s] the worst idleness in (death, until]: the gaps between consecutive visits in the
    window, from the last visit before it (prev) and to its end (j, upto: each vertex's
    visits up to the death and up to `until`); over the vertices `keep` (a mask; None: all)."""
    flat, first = log.flat, log.first
    if keep is None:
        keep = np.ones(len(log.counts), dtype=bool)
    worst = 0.0
    inner = (log.local > j[log.vertex]) & (log.local < upto[log.vertex]) & keep[log.vertex]
    if inner.any():
        worst = max(worst, float(log.gap[inner].max()))
    seen = (upto > j) & keep
    if seen.any():
        firsts = flat[first[seen] + j[seen]] - prev[seen]
        lasts = until - flat[first[seen] + upto[seen] - 1]
        worst = max(worst, float(firsts.max()), float(lasts.max()))
    unseen = ~(upto > j) & keep
    if unseen.any():
        worst = max(worst, float((until - prev[unseen]).max()))
    return worst


def _intentions(log: _VisitFigures, announced, robot: int, death_s: float,
                start_time: float) -> tuple[list[int], list[float]]:
    """The vertices `robot` announced since its last visit up to its death, and for each how
    long after the death a teammate visited it [s] (NaN: never)."""
    own = log.t[(log.robot == robot) & (log.t <= death_s)]
    last_own = float(own.max()) if len(own) else start_time
    intentions = sorted({v for t, r, v in announced
                         if r == robot and last_own <= t <= death_s})
    delays = []
    for v in intentions:
        later_visits = log.t[(log.visited == v) & (log.robot != robot) & (log.t > death_s)]
        delays.append(float(later_visits.min()) - death_s if len(later_visits) else math.nan)
    return intentions, delays


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
                 death_s: float, until_s: float, survivors: list[int],
                 keep: np.ndarray | None = None) -> float:
    """death_floor with the visit figures converted (`prev`: [s] each vertex's last visit at
    the death, or the start time), over the vertices `keep` (a mask; None: all)."""
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
    each = np.minimum(death_s - prev + reach[:len(prev)] / speed, until_s - prev)
    if keep is not None:
        each = each[keep[:len(prev)]]
    if len(each):
        floor = max(floor, float(each.max()))
    return float(floor)

