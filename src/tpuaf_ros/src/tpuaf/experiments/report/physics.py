"""The physics runs (the paper's physical experiment, Table 4): a table per map and, per
strategy, whether I_ins and X fall as N grows."""

from __future__ import annotations

from tpuaf.experiments.report.claims import Verdict
from tpuaf.experiments.report.common import ALL_METRICS, fmt, label
from tpuaf.experiments.report.data import Data
from tpuaf.experiments.report.tables import _cell


def physics_table(data: Data, m: str) -> str:
    """The physics runs of one map: a row per (strategy, N), the paper's Table 4 in brackets."""
    head = ["strategy", "N"] + [name for _, name, _, _ in ALL_METRICS]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for s in data.strategies(m):
        for n in data.robots(m):
            stats = [data.stat(m, s, n, col) for col, *_ in ALL_METRICS]
            if not any(st.n for st in stats):
                continue
            cells = [_cell(st, None, data.paper.get((m, n, s, key)) if key else None)
                     for st, (_, _, key, _) in zip(stats, ALL_METRICS, strict=True)]
            lines.append("| " + " | ".join([label(s), str(n)] + cells) + " |")
    return "\n".join(lines)


def physics_verdicts(pd: Data, m: str) -> list[Verdict]:
    """Per strategy: do I_ins and X strictly fall as N grows on map `m` ([] with one N)?"""
    out = []
    ns = pd.robots(m)
    for strat in pd.strategies(m):
        if len(ns) < 2:
            break
        means = [pd.stat(m, strat, n, "idleness_ins_mean_s").mean for n in ns]
        xs = [pd.stat(m, strat, n, "uncertainty_mean").mean for n in ns]
        falls = all(b < a for a, b in zip(means, means[1:], strict=False)) and \
            all(b < a for a, b in zip(xs, xs[1:], strict=False))
        out.append(Verdict(f"{label(strat)}'s I_ins and X fall as N grows in the physics runs "
                           "(as TPUAF's in the paper's Table 4)",
                           "reproduced" if falls else "not reproduced",
                           "I_ins " + " → ".join(fmt(v) for v in means) + "; X "
                           + " → ".join(fmt(v) for v in xs) + f" (N = {', '.join(map(str, ns))})."))
    return out


def physics_section(everything: Data) -> list[str]:
    """## Physics runtime, one per scenario with physics runs ([] if none)."""
    md: list[str] = []
    physics = [sc for sc in everything.scenarios()
               if any(r["runtime"] == "physics" for r in everything.subset(sc).rows)]
    for sc in physics:
        pd = everything.subset(sc)
        md += [f"## Physics runtime (`{sc}`; the paper's physical experiment, Table 4)", "",
               "Mean ± 95 % CI over seeds; in brackets the paper's figure (TurtleBot3 Burgers in "
               "the lab; a different robot stack, so only orderings and trends compare).", ""]
        for m in pd.maps():
            md += [f"### {m}", "", physics_table(pd, m), ""]
            if not any(k[0] == m for k in everything.bounds):
                md += [f"{m}: not in "
                       f"{everything.bounds_path.name if everything.bounds_path else 'the bounds'}"
                       ", so no ratio to a best-known tour.", ""]
            md += [v.line() for v in physics_verdicts(pd, m)]
            md += [""]
    return md
