"""The strategy comparison beyond the paper's claims (fault-free runs): where TPUAF loses and
to what, the ratio of I_max to the best-known tour (patrol_bounds.csv), and the issue-13
targets of tpuaf_plus (also under the fault scenarios)."""

from __future__ import annotations

import math
from collections import defaultdict

import numpy as np

from tpuaf.experiments.report.common import (
    FAULT_METRICS,
    FAULT_TITLES,
    PLUS,
    TARGET_RATIO,
    _overlap,
    fmt,
    label,
)
from tpuaf.experiments.report.data import Data


def ratio_table(data: Data) -> tuple[str, list[str]]:
    """Mean I_max / best-known tour's worst idleness (patrol_bounds.csv) per strategy and (map, N);
    also the reference tours' analytic worst idleness. Returns (table, notes)."""
    notes = []
    cols = []
    for m in data.maps():
        if not any(k[0] == m for k in data.bounds):
            notes.append(f"{m}: not in {data.bounds_path.name if data.bounds_path else 'the bounds'}"
                         ", so no ratio")
            continue
        for n in data.robots(m):
            b = data.bounds.get((m, n), {}).get("best_known_worst_idleness_s")
            if b is None:
                notes.append(f"{m} N={n}: no best-known tour in the bounds")
            elif b <= 0:
                notes.append(f"{m} N={n}: the best-known worst idleness is {b:g} s (at least one "
                             "robot per vertex: every vertex can be guarded), so no ratio")
            else:
                cols.append((m, n, b))
    if not cols:
        return "", notes
    head = ["strategy"] + [f"{m} N={n}" for m, n, _ in cols]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head),
             "| best-known tour [s] | " + " | ".join(fmt(b) for *_, b in cols) + " |"]
    for s in data.strategies():
        cells = []
        for m, n, b in cols:
            st = data.stat(m, s, n, "idleness_max_s")
            if not st.n:
                cells.append("")
                continue
            r = st.mean / b
            cells.append(f"**{r:.2f}**" if r <= TARGET_RATIO else f"{r:.2f}")
        lines.append("| " + " | ".join([label(s)] + cells) + " |")
    for kind in ("cyclic", "partition"):
        cells = []
        for m, n, b in cols:
            ref = data.reference.get((m, n))
            cells.append(f"{ref[f'{kind}_worst_idleness_s'] / b:.2f}" if ref else "")
        lines.append("| " + " | ".join([f"{kind} tour (analytic)"] + cells) + " |")
    return "\n".join(lines), notes


def ratio_of(data: Data, m: str, s: str, n: int) -> float:
    b = data.bounds.get((m, n), {}).get("best_known_worst_idleness_s")
    st = data.stat(m, s, n, "idleness_max_s")
    return st.mean / b if b and b > 0 and st.n else math.nan


def losses_table(data: Data, metrics=(("idleness_max_s", "I_max"),
                                       ("uncertainty_mean", "X"),
                                       ("idleness_ins_mean_s", "I_ins"))) -> str | None:
    """Per (map, N): TPUAF's mean and every strategy with a lower mean (ratio to TPUAF)."""
    if "tpuaf" not in data.strategies():
        return None
    head = ["map", "N"] + [f"{name}: TPUAF → lower (× TPUAF)" for _, name in metrics]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for m in data.maps():
        for n in data.robots(m):
            cells = []
            for col, _ in metrics:
                t = data.stat(m, "tpuaf", n, col)
                if not t.n:
                    cells.append("")
                    continue
                better = []
                for s in data.strategies(m):
                    st = data.stat(m, s, n, col)
                    if s != "tpuaf" and st.n and st.mean < t.mean:
                        better.append((st.mean / t.mean if t.mean else math.nan, s,
                                       _overlap(st, t)))
                better.sort()
                text = fmt(t.mean) + " → " + (", ".join(
                    f"{label(s)} {r:.2f}" + ("~" if ov else "") for r, s, ov in better)
                    if better else "none (TPUAF lowest)")
                cells.append(text)
            lines.append("| " + " | ".join([m, str(n)] + cells) + " |")
    return "\n".join(lines)


def loss_summary(data: Data) -> list[str]:
    """Plain sentences: where TPUAF is not the lowest on I_max and X, and what beats it most."""
    out = []
    if "tpuaf" not in data.strategies():
        return out
    for col, name in (("idleness_max_s", "I_max"), ("uncertainty_mean", "X")):
        cases = [(m, n) for m in data.maps() for n in data.robots(m) if n > 1
                 and data.stat(m, "tpuaf", n, col).n]
        lost, winners = [], defaultdict(int)
        for m, n in cases:
            t = data.stat(m, "tpuaf", n, col).mean
            others = [(data.stat(m, s, n, col).mean, s) for s in data.strategies(m)
                      if s != "tpuaf" and data.stat(m, s, n, col).n]
            low = [(v, s) for v, s in others if v < t]
            if low:
                v, s = min(low)
                lost.append(f"{m} N={n} ({label(s)} {fmt(v)} vs {fmt(t)}, {v / t:.2f}×)")
                for _, s2 in low:
                    winners[s2] += 1
        if not cases:
            continue
        top = ", ".join(f"{label(s)} ({k})" for s, k in
                        sorted(winners.items(), key=lambda x: (-x[1], x[0])))
        out.append(f"- {name}: TPUAF is beaten in {len(lost)} of {len(cases)} (map, N ≥ 2) cases"
                   + (f"; the best there: {'; '.join(lost)}. Strategies below TPUAF (number of "
                      f"cases): {top}." if lost else "."))
    return out


def plus_targets(data: Data, faults: dict[str, Data]) -> list[str]:
    """The issue-13 targets of tpuaf_plus, met or missed, with the margins."""
    if PLUS not in data.strategies():
        return [f"- {label(PLUS)} did not run in this comparison: its targets are not tested."]
    out = []
    cases = [(m, n) for m in data.maps() for n in (4, 8, 12) if n in data.robots(m)
             and data.stat(m, PLUS, n, "idleness_max_s").n]
    rs = [(m, n, ratio_of(data, m, PLUS, n)) for m, n in cases]
    rs = [(m, n, r) for m, n, r in rs if np.isfinite(r)]
    if rs:
        miss = [f"{m} N={n} {r:.2f}×" for m, n, r in rs if r > TARGET_RATIO]
        worst = max(rs, key=lambda x: x[2])
        out.append(f"- I_max within {TARGET_RATIO}× of the best-known tour at N = 4, 8, 12 "
                   f"(maps in the bounds): **{'met' if not miss else 'missed'}** in "
                   f"{len(rs) - len(miss)} of {len(rs)} cases; worst {worst[0]} N={worst[1]} "
                   f"{worst[2]:.2f}×" + (f"; missed: {', '.join(miss)}." if miss else "."))
    x_cases, x_miss, x_tie = 0, [], []
    for m, n in cases:
        p = data.stat(m, PLUS, n, "uncertainty_mean")
        others = [(data.stat(m, s, n, "uncertainty_mean").mean, s) for s in data.strategies(m)
                  if s != PLUS and data.stat(m, s, n, "uncertainty_mean").n]
        if not p.n or not others:
            continue
        x_cases += 1
        v, s = min(others)
        if p.mean < v:
            continue
        if p.mean <= v * 1.005:  # equal within 0.5 % (e.g. both 0: every target covered)
            x_tie.append(f"{m} N={n} ({label(s)} {fmt(v)})")
            continue
        more = f", +{100 * (p.mean / v - 1):.0f} %" if v > 0 else ""
        x_miss.append(f"{m} N={n} ({label(s)} {fmt(v)} vs {fmt(p.mean)}{more})")
    if x_cases:
        met = x_cases - len(x_miss) - len(x_tie)
        out.append(f"- mean X lower than every other strategy's (N = 4, 8, 12): "
                   f"**{'met' if not x_miss and not x_tie else 'missed'}**: lower in {met} of "
                   f"{x_cases} cases"
                   + (f"; tied (within 0.5 %) in {len(x_tie)}: {'; '.join(x_tie)}" if x_tie else "")
                   + (f"; higher in {len(x_miss)}: {'; '.join(x_miss)}" if x_miss else "") + ".")
    for name, fd in faults.items():
        if PLUS not in fd.strategies():
            continue
        total, miss, tie = 0, [], []
        for m in fd.maps():
            for n in fd.robots(m):
                for col, cname in FAULT_METRICS:
                    p = fd.stat(m, PLUS, n, col)
                    others = [(fd.stat(m, s, n, col).mean, s) for s in fd.strategies(m)
                              if s != PLUS and fd.stat(m, s, n, col).n]
                    if not p.n or not others:
                        continue
                    total += 1
                    v, s = min(others)
                    if p.mean < v:
                        continue
                    text = f"{m} N={n} {cname} ({label(s)} {fmt(v)} vs {fmt(p.mean)})"
                    (tie if p.mean <= v * 1.005 else miss).append(text)
        if total:
            out.append(f"- under {FAULT_TITLES.get(name, name)}: lower I_max, worst idleness and X "
                       f"than every other strategy: **{'met' if not miss and not tie else 'missed'}"
                       f"**: lower in {total - len(miss) - len(tie)} of {total} (map, N, metric) "
                       "cases"
                       + (f"; tied (within 0.5 %) in {len(tie)}: {'; '.join(tie)}" if tie else "")
                       + (f"; higher in {len(miss)}: {'; '.join(miss)}" if miss else "") + ".")
    return out


def losses_section(data: Data) -> list[str]:
    """## Where TPUAF loses, and to what: every strategy that ran."""
    md = ["## Where TPUAF loses, and to what", "",
          "Every strategy that ran, fault-free (the verdicts above compare TPUAF with the "
          "paper's rivals only).", ""]
    md += loss_summary(data) + [""]
    table = losses_table(data)
    if table:
        md += ["Per (map, N): TPUAF's mean, then every strategy with a lower mean and its "
               "ratio to TPUAF (~ = the 95 % CIs overlap).", "", table, ""]
    return md


def ratio_section(data: Data) -> list[str]:
    """## Ratio to the best-known tour (mean I_max over its worst idleness)."""
    ratio, notes = ratio_table(data)
    md = ["## Ratio to the best-known tour", "",
          "Mean I_max (the largest interval between two visits of a vertex) divided by the "
          "best-known tour's worst idleness (`best_known_worst_idleness_s` of "
          f"{'`' + data.bounds_path.name + '`' if data.bounds_path else 'the bounds table'}"
          f"); **bold** = within {TARGET_RATIO}× (issue 13's target). The last rows are our "
          "reference tours (tours.py, analytic), on the same scale, under the visit rule: a "
          "part of one vertex is driven out and back, as standing on a vertex makes no visit. "
          "patrol_bounds.csv's best-known tours park robots on vertices where that pays (1r5 "
          "and ctcv at N ≥ 8), which no strategy obeying the rule can match there.", ""]
    md += ([ratio, ""] if ratio else ["No map of this comparison is in the bounds table.", ""])
    md += [f"- {n}" for n in notes] + ([""] if notes else [])
    return md


def plus_section(data: Data, faults: dict[str, Data]) -> list[str]:
    """## Targets of TPUAF_PLUS (issue 13), met or missed."""
    return [f"## Targets of {label(PLUS)} (issue 13)", "", *plus_targets(data, faults), ""]
