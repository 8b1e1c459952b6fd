"""The results tables: the paper's layout (Tables 2 and 3: per N and metric one row, one
column per strategy), one table per (map, N) with every strategy, and the acceleration ratio
a(N) = I_avg(1) / (N I_avg(N)) (paper Fig. 8)."""

from __future__ import annotations

import numpy as np

from tpuaf.experiments.report.common import (
    ALL_METRICS,
    METRICS,
    PAPER_STRATEGIES,
    PAPER_TABLE,
    PLUS,
    Stat,
    _ratio,
    fmt,
    label,
    stat,
)
from tpuaf.experiments.report.data import Data


def metric_table(data: Data, map_name: str, strategies: list[str] | None = None) -> str:
    """The paper's layout: per N and metric one row, one column per strategy, then the tours."""
    present = data.strategies(map_name)
    strategies = [s for s in (strategies or present) if s in present]
    has_paper = any(k[0] == map_name for k in data.paper)
    has_ref = any(k[0] == map_name for k in data.reference)
    head = ["N", "metric"] + [label(s) for s in strategies]
    if has_ref:
        head += ["cyclic tour", "partition tour"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for n in data.robots(map_name):
        for col, name, paper_key, ref_key in METRICS:
            stats = {s: data.stat(map_name, s, n, col) for s in strategies}
            means = {s: st.mean for s, st in stats.items() if np.isfinite(st.mean)}
            best = min(means.values()) if means else None
            cells = []
            for s in strategies:
                st = stats[s]
                if st.n == 0:
                    cells.append("")
                    continue
                text = fmt(st.mean) + (f" ± {fmt(st.ci)}" if np.isfinite(st.ci) else "")
                if best is not None and len(means) > 1 and st.mean == best:
                    text = f"**{text}**"
                if has_paper and paper_key:
                    p = data.paper.get((map_name, n, s, paper_key))
                    if p is not None:
                        text += f" [{fmt(p)}]"
                cells.append(text)
            row = [str(n), name] + cells
            if has_ref:
                ref = data.reference.get((map_name, n), {})
                row += [fmt(ref.get(f"cyclic_{ref_key}")) if ref_key and ref else "–",
                        fmt(ref.get(f"partition_{ref_key}")) if ref_key and ref else "–"]
            lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines)


def acceleration(data: Data, map_name: str, strategy: str, n: int) -> Stat:
    """a(N) per seed (seeds run at both N = 1 and N), mean and CI over seeds."""
    one = data.per_seed(map_name, strategy, 1, "idleness_avg_s")
    many = data.per_seed(map_name, strategy, n, "idleness_avg_s")
    from tpuaf.measure.metrics import acceleration_ratio

    return stat(acceleration_ratio(one[s], many[s], n) for s in sorted(set(one) & set(many)))


def acceleration_table(data: Data) -> str | None:
    maps = [m for m in data.maps() if 1 in data.robots(m)]
    if not maps:
        return None
    lines = []
    for m in maps:
        ns = [n for n in data.robots(m) if n > 1]
        strategies = data.strategies(m)
        lines.append(f"\n**{m}**\n")
        head = ["strategy"] + [f"N = {n}" for n in ns]
        lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for s in strategies:
            cells = []
            for n in ns:
                st = acceleration(data, m, s, n)
                cells.append(fmt(st.mean) + (f" ± {fmt(st.ci)}" if np.isfinite(st.ci) else ""))
            lines.append("| " + " | ".join([label(s)] + cells) + " |")
        ref = [data.reference.get((m, 1)), *[data.reference.get((m, n)) for n in ns]]
        if all(ref):
            for kind in ("cyclic", "partition"):
                base = ref[0][f"{kind}_avg_idleness_visit_s"]
                cells = [fmt(_ratio(base, n * r[f"{kind}_avg_idleness_visit_s"]))
                         for n, r in zip(ns, ref[1:], strict=True)]
                lines.append("| " + " | ".join([f"{kind} tour"] + cells) + " |")
    return "\n".join(lines)


def _cell(st: Stat, best: float | None, paper: float | None = None) -> str:
    if st.n == 0:
        return ""
    text = fmt(st.mean) + (f" ± {fmt(st.ci)}" if np.isfinite(st.ci) else "")
    if best is not None and st.mean == best:
        text = f"**{text}**"
    if paper is not None:
        text += f" [{fmt(paper)}]"
    return text


def strategy_table(data: Data, m: str, n: int) -> str:
    """One (map, N): a row per strategy (every one that ran), a column per metric, then the
    reference tours' analytic figures."""
    strategies = data.strategies(m)
    head = ["strategy"] + [name for _, name, _, _ in ALL_METRICS]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    stats = {(s, col): data.stat(m, s, n, col) for s in strategies for col, *_ in ALL_METRICS}
    best = {}
    for col, *_ in ALL_METRICS:
        means = [stats[(s, col)].mean for s in strategies if stats[(s, col)].n]
        best[col] = min(means) if len(means) > 1 else None
    for s in strategies:
        if not any(stats[(s, col)].n for col, *_ in ALL_METRICS):
            continue
        cells = [_cell(stats[(s, col)], best[col],
                       data.paper.get((m, n, s, key)) if key else None)
                 for col, _, key, _ in ALL_METRICS]
        lines.append("| " + " | ".join([label(s)] + cells) + " |")
    ref = data.reference.get((m, n))
    if ref:
        for kind in ("cyclic", "partition"):
            cells = [fmt(ref.get(f"{kind}_{rk}")) if rk else "–" for _, _, _, rk in ALL_METRICS]
            lines.append("| " + " | ".join([f"{kind} tour (analytic)"] + cells) + " |")
    return "\n".join(lines)


def tables_section(data: Data) -> list[str]:
    """## Tables: the paper's layout per map, then every strategy per (map, N)."""
    md = ["## Tables", "",
          "Mean ± 95 % CI half-width over seeds (Student t; ± 0 = the same value for every "
          "seed: the strategy does not depend on the seed there); **bold** = lowest mean. "
          + ("In brackets: the paper's figure (Tables 2 and 3; a different simulator and "
             "navigation stack, so only orderings are comparable; the paper's X uses another "
             "scale). " if data.paper else "")
          + "The reference tours are analytic steady-state figures (tours.py): I_ins ↔ mean "
            "over vertices of the time-average idleness, I_max ↔ worst idleness (I_avg, a "
            "mean over visits, has no tour counterpart). I_std is the population std of "
            "interval idleness, the column the paper labels I_G^avg.", ""]
    paper_set = PAPER_STRATEGIES + [PLUS]
    for m in data.maps():
        table = PAPER_TABLE.get(m)
        if table and table != 4:
            md += [f"### {m}: the paper's strategies (layout of the paper's Table {table})",
                   "", metric_table(data, m, paper_set), ""]
        for n in data.robots(m):
            md += [f"### {m}, N = {n}: every strategy", "", strategy_table(data, m, n), ""]
    return md
