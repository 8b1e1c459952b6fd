"""What every section of the report shares: its error, the metric and strategy lists, the
orderings, number formatting and the mean +- 95 % CI statistic."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tpuaf.errors import TpuafError


class ReportError(TpuafError):
    """A report cannot be made (missing or malformed inputs); the message names the file."""


# (our column, label, paper's metric key, reference tour column or None)
METRICS = [
    ("idleness_ins_mean_s", "I_ins [s]", "I_ins", "avg_idleness_time_s"),
    ("idleness_max_s", "I_max [s]", "I_max", "worst_idleness_s"),
    ("idleness_std_s", "I_std [s] (paper: I_G^avg)", "I_std", None),
    ("uncertainty_mean", "X", "X", None),
    ("interference_rate_per_min", "If_rate [1/min]", "If_rate", None),
    # No reference figure: I_avg is a mean over visits (frequent vertices weigh more), the tours'
    # mean interval is a mean over vertices.
    ("idleness_avg_s", "I_avg [s]", None, None),
]
ALL_METRICS = [m for m in METRICS]  # every table metric, one column each
PAPER_STRATEGIES = ["gbs", "dtag", "dtap", "tpuaf"]  # the paper's comparison set
ORDER = ["gbs", "sebs", "cbls", "dtag", "dtap", "tpuaf", "tpuaf_plus", "tpuaf_any", "cgg", "msp",
         "cr", "hcr", "hpcc", "rand"]
PAPER_TABLE = {"cumberland": 2, "grid": 3, "lab": 4}
NOMINAL = "nominal"  # tpuaf.experiments.sweep.grid.NOMINAL: the fault-free graph runs
# The fault scenarios of the canonical comparison (issue 13): a quarter of the team dies at half
# the run, 30 % message loss, 5 s delay. Other scenarios appear in the degradation curves only.
FAULT_SCENARIOS = ["deaths1of4", "loss0.3", "delay5"]
FAULT_TITLES = {"deaths1of4": "a quarter of the team dies at half the run",
                "loss0.3": "30 % message loss", "delay5": "5 s message delay"}
PLUS = "tpuaf_plus"  # the strategy with the issue-13 targets
TARGET_RATIO = 1.3  # issue 13: I_max within 1.3x of the best-known tour
# Under faults I_max alone hides a vertex nobody visits any more (it has no interval after the
# last visit): the worst idleness (max over vertices and time of t - last visit) shows it.
FAULT_METRICS = [("idleness_max_s", "I_max"), ("worst_idleness_s", "worst idleness"),
                 ("uncertainty_mean", "X")]
FIGURES = Path("figures")  # the figures' folder, relative to report.md


def _strategy_order(names) -> list[str]:
    return sorted(set(names), key=lambda s: (ORDER.index(s) if s in ORDER else len(ORDER), s))


def _map_order(names) -> list[str]:
    return sorted(set(names), key=lambda m: (PAPER_TABLE.get(m, 99), m))


def label(strategy: str) -> str:
    return strategy.upper()


def fmt(x: float | None) -> str:
    if x is None or not np.isfinite(x):
        return "n/a"
    a = abs(x)
    if a >= 1000:
        return f"{x:.0f}"
    if a >= 100:
        return f"{x:.1f}"
    if a >= 1:
        return f"{x:.2f}"
    return f"{x:.3g}"


@dataclass
class Stat:
    mean: float
    ci: float  # 95 % CI half-width (NaN with one seed)
    n: int
    values: list[float] = field(default_factory=list)

    def interval(self) -> tuple[float, float]:
        ci = self.ci if np.isfinite(self.ci) else 0.0
        return self.mean - ci, self.mean + ci


def stat(values) -> Stat:
    a = np.asarray([v for v in values if np.isfinite(v)], dtype=float)
    if a.size == 0:
        return Stat(math.nan, math.nan, 0, [])
    if a.size == 1:
        return Stat(float(a[0]), math.nan, 1, a.tolist())
    from scipy.stats import t

    half = float(t.ppf(0.975, a.size - 1) * a.std(ddof=1) / math.sqrt(a.size))
    return Stat(float(a.mean()), half, int(a.size), a.tolist())


def _overlap(a: Stat, b: Stat) -> bool:
    lo_a, hi_a = a.interval()
    lo_b, hi_b = b.interval()
    return lo_a <= hi_b and lo_b <= hi_a


def _ratio(a: float, b: float) -> float:
    """a / b, NaN when b is 0 (e.g. a tour with one robot per vertex: no interval at all)."""
    return a / b if b else math.nan
