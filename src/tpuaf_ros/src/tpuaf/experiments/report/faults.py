"""The fault scenarios of the canonical comparison (deaths, message loss, delay): per scenario
and metric a table against the fault-free means, and the recovery after robot deaths."""

from __future__ import annotations

import math

import numpy as np

from tpuaf.experiments.report.common import FAULT_TITLES, fmt, label, stat
from tpuaf.experiments.report.data import Data


def fault_table(fd: Data, nominal: Data, col: str) -> str:
    """One fault scenario, one metric: a row per strategy, a column per (map, N); in brackets the
    ratio to the same strategy's fault-free mean."""
    cols = [(m, n) for m in fd.maps() for n in fd.robots(m)]
    head = ["strategy"] + [f"{m} N={n}" for m, n in cols]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    best = {}
    for m, n in cols:
        means = [fd.stat(m, s, n, col).mean for s in fd.strategies(m) if fd.stat(m, s, n, col).n]
        best[(m, n)] = min(means) if len(means) > 1 else None
    for s in fd.strategies():
        cells = []
        for m, n in cols:
            st = fd.stat(m, s, n, col)
            if not st.n:
                cells.append("")
                continue
            text = fmt(st.mean)
            if best[(m, n)] is not None and st.mean == best[(m, n)]:
                text = f"**{text}**"
            base = nominal.stat(m, s, n, col)
            if base.n and base.mean > 0:
                text += f" ({st.mean / base.mean:.2f}×)"
            cells.append(text)
        lines.append("| " + " | ".join([label(s)] + cells) + " |")
    return "\n".join(lines)


def recovery_table(fd: Data) -> str | None:
    if not any(np.isfinite(r.get("recovery_time_s", math.nan))
               or np.isfinite(r.get("worst_idleness_after_s", math.nan)) for r in fd.rows):
        return None
    cols = [(m, n) for m in fd.maps() for n in fd.robots(m)]
    head = ["strategy"] + [f"{m} N={n}" for m, n in cols]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for s in fd.strategies():
        cells = []
        for m, n in cols:
            rec = fd.stat(m, s, n, "recovery_time_s")
            after = fd.stat(m, s, n, "worst_idleness_after_s")
            ideal = fd.stat(m, s, n, "ideal_worst_idleness_survivors_s")
            floor = stat(r.get("floor_worst_idleness_after_s", math.nan) for r in fd.rows
                         if r["map"] == m and r["strategy"] == s and r["robots"] == n)
            unrec = sum(r.get("unrecovered", 0) or 0 for r in fd.rows
                        if r["map"] == m and r["strategy"] == s and r["robots"] == n
                        and np.isfinite(r.get("unrecovered", math.nan)))
            if not (rec.n or after.n):
                cells.append("")
                continue
            cells.append(f"{fmt(rec.mean)} / {fmt(after.mean)} / {fmt(ideal.mean)}"
                         + (f" / {fmt(floor.mean)}" if floor.n else "")
                         + (f" ({unrec:.0f} never)" if unrec else ""))
        lines.append("| " + " | ".join([label(s)] + cells) + " |")
    return "\n".join(lines)


def faults_section(faults: dict[str, Data], nominal: Data) -> list[str]:
    """## Fault scenarios: I_max, worst idleness, X and recovery per scenario ([] if none ran)."""
    if not faults:
        return []
    md = ["## Fault scenarios", "",
          "Each table: the mean over seeds, **bold** = lowest of the column; in brackets "
          "the ratio to the same strategy's fault-free mean. Deaths: robots "
          "floor(i N / K), i = 0..K-1, die at half the run (K = N/4, rounded down). "
          "Nobody tells the survivors: each notices a death from the heartbeats (one a "
          "second) and team messages it stops hearing, once silent for the teammate timeout "
          "(10 s by default, the agent node's); loss can make that sooner, delay later.", ""]
    for sc, fd in faults.items():
        md += [f"### {FAULT_TITLES.get(sc, sc)} (`{sc}`)", "", "**I_max [s]**", "",
               fault_table(fd, nominal, "idleness_max_s"), "",
               "**worst idleness [s]** (max over vertices and time of t - last visit: a "
               "vertex never visited again counts, unlike in I_max)", "",
               fault_table(fd, nominal, "worst_idleness_s"), "", "**X (time mean)**", "",
               fault_table(fd, nominal, "uncertainty_mean"), ""]
        rec = recovery_table(fd)
        if rec:
            md += ["**Recovery** (per cell: slowest time until every vertex was visited "
                   "again after a death [s] / worst idleness after the deaths [s] / ideal "
                   "worst idleness of the N - K survivors, reference tours [s] / the floor "
                   "no strategy could avoid after the death: each vertex's idleness at the "
                   "death plus the shortest drive to it from a survivor [s]; where the ideal "
                   "is under the floor, the floor is what to compare with)", "", rec, ""]
        elif sc.startswith("deaths"):
            md += ["(No recovery figures in these runs' summaries.)", ""]
    return md
