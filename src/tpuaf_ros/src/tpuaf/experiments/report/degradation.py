"""The degradation curves: one fault factor at a time (message loss, delay, robot deaths at half
the run), the others at no fault; level 0 is the fault-free run. A figure, the curves' numbers
and a note on monotonicity per (map, N)."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np

from tpuaf.experiments.plots import headless_pyplot
from tpuaf.experiments.report.common import FIGURES, _strategy_order, fmt, label, stat
from tpuaf.experiments.report.data import Data
from tpuaf.experiments.report.figures import _colors

# Degradation curves: the factor of a scenario row and its level.
FACTORS = [("loss", "message loss probability", "loss"),
           ("delay", "message delay [s]", "delay_s"),
           ("deaths", "robots that die at half the run", "deaths")]


def _factor_of(row: dict) -> tuple[str, float] | None:
    """(factor, level) of a one-factor scenario; the nominal row is level 0 of every factor."""
    active = [(f, float(row[c])) for f, _, c in FACTORS if row.get(c)]
    if row["runtime"] != "graph" or len(active) > 1:
        return None
    return active[0] if active else ("base", 0.0)


def degradation_points(data: Data, m: str, n: int, factor: str) -> dict[str, dict[float, list]]:
    """strategy -> level -> rows, for one factor at one (map, N)."""
    out: dict[str, dict[float, list]] = defaultdict(lambda: defaultdict(list))
    for r in data.rows:
        if r["map"] != m or r["robots"] != n:
            continue
        f = _factor_of(r)
        if f is None or f[0] not in (factor, "base"):
            continue
        out[r["strategy"]][f[1]].append(r)
    return out


def degradation_cases(data: Data) -> list[tuple[str, int]]:
    """(map, N) with at least two non-zero levels of some factor."""
    cases = []
    for m in data.maps():
        for n in data.robots(m):
            for factor, _, _ in FACTORS:
                pts = degradation_points(data, m, n, factor)
                levels = {lv for per in pts.values() for lv in per if lv}
                if len(levels) >= 2:
                    cases.append((m, n))
                    break
    return cases


def degradation_figure(data: Data, m: str, n: int, path: Path) -> Path | None:
    plt = headless_pyplot()

    factors = []
    for factor, xlabel, _ in FACTORS:
        pts = degradation_points(data, m, n, factor)
        if len({lv for per in pts.values() for lv in per if lv}) >= 2:
            factors.append((factor, xlabel, pts))
    if not factors:
        return None
    strategies = _strategy_order({s for _, _, pts in factors for s in pts})
    colors = _colors(strategies)
    fig, axes = plt.subplots(3, len(factors), figsize=(4.6 * len(factors), 10.0), squeeze=False)
    for j, (_factor, xlabel, pts) in enumerate(factors):
        for i, (col, name) in enumerate((("idleness_max_s", "I_max [s]"),
                                         ("worst_idleness_s", "worst idleness [s]"),
                                         ("uncertainty_mean", "X (time mean)"))):
            ax = axes[i][j]
            for s in strategies:
                per = pts.get(s)
                if not per or len(per) < 2:
                    continue
                levels = sorted(per)
                st = [stat(r[col] for r in per[lv]) for lv in levels]
                means = np.array([t.mean for t in st])
                lo = np.array([min(t.values) if t.values else np.nan for t in st])
                hi = np.array([max(t.values) if t.values else np.nan for t in st])
                # bars: min..max over seeds (a t interval of 2 or 3 seeds says little)
                yerr = [np.maximum(means - lo, 0.0), np.maximum(hi - means, 0.0)]  # rounding
                ax.errorbar(levels, means, yerr=yerr, marker="o",
                            ms=3, capsize=2, color=colors[s], label=label(s))
            ax.set_yscale("log")
            ax.set_xlabel(xlabel)
            ax.set_ylabel(name)
            ax.grid(alpha=0.3, which="both")
    axes[0][0].legend(fontsize=7, ncol=2)
    fig.suptitle(f"Degradation on {m}, N = {n} (one factor at a time; mean over seeds, bars: "
                 "min to max)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def degradation_table(data: Data, m: str, n: int, col: str = "idleness_max_s") -> str:
    """The curves' numbers: a row per strategy, a column per (factor, level)."""
    cols = []
    for factor, _, _ in FACTORS:
        pts = degradation_points(data, m, n, factor)
        levels = sorted({lv for per in pts.values() for lv in per if lv})
        if len(levels) >= 2:
            cols += [(factor, lv) for lv in levels]
    head = ["strategy", "no fault"] + [
        f"{'loss ' + format(lv, 'g') if f == 'loss' else f + ' ' + format(lv, 'g')}"
        for f, lv in cols]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for s in data.strategies(m):
        base = degradation_points(data, m, n, "loss").get(s, {}).get(0.0, [])
        cells = [fmt(stat(r[col] for r in base).mean) if base else ""]
        for f, lv in cols:
            rows = degradation_points(data, m, n, f).get(s, {}).get(lv, [])
            cells.append(fmt(stat(r[col] for r in rows).mean) if rows else "")
        if any(cells):
            lines.append("| " + " | ".join([label(s)] + cells) + " |")
    return "\n".join(lines)


def monotone_note(data: Data, m: str, n: int, col: str = "idleness_max_s",
                  name: str = "I_max") -> str:
    """Which curves are not roughly monotone (a later level more than 10 % below an earlier one)."""
    bad = []
    for factor, _, _ in FACTORS:
        for s, per in degradation_points(data, m, n, factor).items():
            levels = sorted(per)
            if len([lv for lv in levels if lv]) < 2:
                continue
            means = [stat(r[col] for r in per[lv]).mean for lv in levels]
            for k in range(1, len(means)):
                if means[k] < 0.9 * max(means[:k]):
                    bad.append(f"{label(s)} {factor} {levels[k]:g} ({fmt(means[k])} < "
                               f"{fmt(max(means[:k]))})")
                    break
    return (f"Not roughly monotone in {name} (a level more than 10 % below an earlier one): "
            + "; ".join(bad) + ".") if bad else f"Every curve is roughly monotone in {name}."


def degradation_section(data: Data, figures: Path) -> list[str]:
    """## Degradation curves of every (map, N) with at least two levels of a factor; writes
    figures/degradation_MAP_NN.png."""
    cases = degradation_cases(data)
    if not cases:
        return []
    md = ["## Degradation curves", "",
          "One factor at a time (message loss, delay, robot deaths at half the run), the "
          "others at no fault; level 0 is the fault-free run.", ""]
    for m, n in cases:
        p = degradation_figure(data, m, n, figures / f"degradation_{m}_N{n}.png")
        if p:
            md += [f"### {m}, N = {n}", "", f"![degradation, {m}, N = {n}]({FIGURES / p.name})",
                   "", "I_max [s] (means over seeds):", "",
                   degradation_table(data, m, n), "",
                   "Worst idleness [s] (means over seeds; counts a vertex never visited "
                   "again):", "", degradation_table(data, m, n, "worst_idleness_s"), "",
                   "X (means over seeds):", "",
                   degradation_table(data, m, n, "uncertainty_mean"), "",
                   monotone_note(data, m, n), "",
                   monotone_note(data, m, n, "worst_idleness_s", "worst idleness"), ""]
    return md
