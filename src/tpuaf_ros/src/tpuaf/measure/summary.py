"""The run summary of SPEC section 6, from a recorder's accumulated figures (one layout for
every runtime: `RecorderView.summary`), and the pure helpers it shares with the reports.
Times in seconds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from tpuaf.plain import plain


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


def first_coverage(rec: Any, end_time: float) -> dict[str, float]:
    """first_coverage_s: time [s] from the start until every vertex had been visited once (NaN
    when some vertex was not by `end_time`); first_coverage_bound_s: the lower bound of any
    strategy from the run's start vertices at nominal speed (tours.first_coverage_bound)."""
    from tpuaf.maps import start_vertices
    from tpuaf.maps.tours import first_coverage_bound

    first = rec.first_visit_times
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
    """The summary of SPEC section 6 from a recorder's accumulated figures (`rec`: a
    RecorderView: patrol_map, n_robots, n_vertices, start_time, d_if, visit_counts, dwells,
    dwell_time_s, sample_period_s). Times [s]; NaN -> null."""
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
