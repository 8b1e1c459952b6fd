"""The verdicts: one line per claim of SPEC section 8, computed from the means of the tables
(fault-free graph runs)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tpuaf.experiments.report.common import (
    METRICS,
    PAPER_STRATEGIES,
    _overlap,
    fmt,
    label,
)
from tpuaf.experiments.report.data import Data


@dataclass
class Verdict:
    claim: str
    status: str  # "reproduced", "not reproduced", "not tested"
    numbers: str

    def line(self) -> str:
        mark = {"reproduced": "**reproduced**", "not reproduced": "**not reproduced**"}.get(
            self.status, f"*{self.status}*")
        return f"- {self.claim}: {mark}. {self.numbers}"


def _lowest(data: Data, m: str, n: int, col: str, among: list[str]):
    """(is TPUAF lowest, TPUAF stat, best other strategy, its stat) by means."""
    t = data.stat(m, "tpuaf", n, col)
    others = [(s, data.stat(m, s, n, col)) for s in among if s != "tpuaf"]
    others = [(s, st) for s, st in others if st.n]
    if not t.n or not others:
        return None
    s_best, st_best = min(others, key=lambda x: x[1].mean)
    return t.mean < st_best.mean, t, s_best, st_best


def _cmp_text(m, n, col_label, res) -> str:
    ok, t, s_best, st_best = res
    rel = "<" if ok else "≥"
    note = " (95 % CIs overlap)" if _overlap(t, st_best) else ""
    return (f"{m} N={n} {col_label}: TPUAF {fmt(t.mean)} {rel} {label(s_best)} "
            f"{fmt(st_best.mean)}{note}")


@dataclass(frozen=True)
class _Scope:
    """What the claims 2 to 4 compare: the paper's maps present, the paper's strategies present
    (`among`) and the others (`extra`), the (map, N) cases at N = 8 and 12."""

    maps: list[str]
    among: list[str]
    extra: list[str]
    cases: list[tuple[str, int]]
    have_t: bool  # TPUAF ran
    vs: str  # "among ... (the paper's comparison)"

    @classmethod
    def of(cls, data: Data) -> _Scope:
        maps = [m for m in ("grid", "cumberland") if m in data.maps()]
        among = [s for s in PAPER_STRATEGIES if s in data.strategies()]
        return cls(maps, among, [s for s in data.strategies() if s not in PAPER_STRATEGIES],
                   [(m, n) for m in maps for n in (8, 12) if n in data.robots(m)],
                   "tpuaf" in data.strategies(),
                   f"among {', '.join(label(s) for s in among)} (the paper's comparison)")


def verdicts(data: Data) -> list[Verdict]:
    """One verdict per claim of SPEC section 8, in its order."""
    scope = _Scope.of(data)
    return [_falling_verdict(data), _lowest_max_verdict(data, scope),
            _lowest_ins_x_verdict(data, scope), _dtag_exception_verdict(data, scope),
            _not_best_at_4_verdict(data, scope)]


def _falling_verdict(data: Data) -> Verdict:
    """1. idleness and uncertainty fall as N grows (over the paper's team sizes when present)."""
    paper_ns = [n for n in (4, 8, 12) if n in data.robots()]
    scope = paper_ns if len(paper_ns) >= 2 else data.robots()
    claim = ("Idleness (I_avg, I_ins) and uncertainty (X) fall as N grows, for every map and "
             f"strategy ({', '.join(label(s) for s in data.strategies())}), "
             f"N = {', '.join(map(str, scope))}")
    checked, broken = _falling(data, scope)
    if not checked:
        return Verdict(claim, "not tested", "Needs at least two team sizes.")
    bad = len({b.split(" (N")[0].rsplit(" ", 1)[0] for b in broken})
    nums = f"Strictly falling in {checked - bad} of {checked} series (map, strategy, metric)"
    nums += "." if not broken else "; exceptions: " + "; ".join(broken) + "."
    if scope != data.robots():
        _, more = _falling(data, data.robots())
        more = [b for b in more if b not in broken]
        nums += (f" Including N = {', '.join(str(n) for n in data.robots() if n not in scope)}"
                 ": " + ("also " + "; ".join(more) if more else "no further exception") + ".")
    return Verdict(claim, "reproduced" if not broken else "not reproduced", nums)


def _lowest_max_verdict(data: Data, scope: _Scope) -> Verdict:
    """2. TPUAF lowest I_max at N = 8 and 12 on both maps."""
    claim = f"TPUAF has the lowest I_max at N = 8 and 12 on grid and cumberland, {scope.vs}"
    results = [(m, n, _lowest(data, m, n, "idleness_max_s", scope.among))
               for m, n in scope.cases]
    results = [r for r in results if r[2] is not None]
    if not scope.have_t or len(results) < 4:
        return Verdict(claim, "not tested",
                       "Needs TPUAF and another strategy on grid and cumberland at N = 8, 12.")
    wins = sum(r[2][0] for r in results)
    nums = f"Lowest in {wins} of 4 cases: " + "; ".join(
        _cmp_text(m, n, "I_max", r) for m, n, r in results) + "."
    nums += _extra_note(data, scope.cases, "idleness_max_s", scope.extra)
    return Verdict(claim, "reproduced" if wins == 4 else "not reproduced", nums)


def _lowest_ins_x_verdict(data: Data, scope: _Scope) -> Verdict:
    """3. TPUAF lowest I_ins and X in three of those four cases."""
    claim = f"TPUAF has the lowest I_ins and X in at least three of those four cases, {scope.vs}"
    cases = scope.cases
    res_ins = {(m, n): _lowest(data, m, n, "idleness_ins_mean_s", scope.among) for m, n in cases}
    res_x = {(m, n): _lowest(data, m, n, "uncertainty_mean", scope.among) for m, n in cases}
    if not scope.have_t or len(cases) < 4 or \
            any(v is None for v in [*res_ins.values(), *res_x.values()]):
        return Verdict(claim, "not tested",
                       "Needs TPUAF and another strategy on grid and cumberland at N = 8, 12.")
    both = [c for c in cases if res_ins[c][0] and res_x[c][0]]
    parts = [_cmp_text(m, n, "I_ins", res_ins[(m, n)]) + ", " +
             _cmp_text(m, n, "X", res_x[(m, n)]).split(": ", 1)[1] for m, n in cases]
    nums = f"Lowest in both in {len(both)} of 4 cases: " + "; ".join(parts) + "."
    nums += _extra_note(data, cases, "idleness_ins_mean_s", scope.extra)
    return Verdict(claim, "reproduced" if len(both) >= 3 else "not reproduced", nums)


def _dtag_exception_verdict(data: Data, scope: _Scope) -> Verdict:
    """3b. The exception: DTAG lower on grid at N = 8."""
    claim = "DTAG is lower than TPUAF in I_ins and X on grid at N = 8 (the paper's exception)"
    if ("grid", 8) not in scope.cases or "dtag" not in data.strategies("grid") or \
            not scope.have_t:
        return Verdict(claim, "not tested", "Needs DTAG and TPUAF on grid at N = 8.")
    parts, ok = [], True
    for col, name in (("idleness_ins_mean_s", "I_ins"), ("uncertainty_mean", "X")):
        d, t = data.stat("grid", "dtag", 8, col), data.stat("grid", "tpuaf", 8, col)
        ok &= d.mean < t.mean
        note = " (95 % CIs overlap)" if _overlap(d, t) else ""
        parts.append(f"{name}: DTAG {fmt(d.mean)} {'<' if d.mean < t.mean else '≥'} TPUAF "
                     f"{fmt(t.mean)}{note}")
    return Verdict(claim, "reproduced" if ok else "not reproduced", "; ".join(parts) + ".")


def _not_best_at_4_verdict(data: Data, scope: _Scope) -> Verdict:
    """4. TPUAF not best at N = 4."""
    claim = ("TPUAF is not best at N = 4: on each map some table metric (I_ins, I_max, I_std, X) "
             f"is lower for another strategy {scope.vs}")
    cols = [("idleness_ins_mean_s", "I_ins"), ("idleness_max_s", "I_max"),
            ("idleness_std_s", "I_std"), ("uncertainty_mean", "X")]
    per_map, ok, tested = [], True, False
    for m in scope.maps:
        if 4 not in data.robots(m) or not scope.have_t:
            continue
        res = [(name, _lowest(data, m, 4, col, scope.among)) for col, name in cols]
        res = [(name, r) for name, r in res if r is not None]
        if not res:
            continue
        tested = True
        best = [name for name, r in res if r[0]]
        not_best = [f"{name} (TPUAF {fmt(r[1].mean)}, {label(r[2])} {fmt(r[3].mean)})"
                    for name, r in res if not r[0]]
        ok &= bool(not_best)
        per_map.append(f"{m}: TPUAF lowest in {', '.join(best) or 'none of them'}"
                       + (f"; not lowest in {', '.join(not_best)}" if not_best else ""))
    if not tested:
        return Verdict(claim, "not tested", "Needs TPUAF and another strategy at N = 4.")
    return Verdict(claim, "reproduced" if ok else "not reproduced", "; ".join(per_map) + ".")


def _falling(data: Data, ns_all: list[int]) -> tuple[int, list[str]]:
    """(series checked, exceptions) of strictly falling means of I_avg, I_ins, X over N."""
    checked, broken = 0, []
    for m in data.maps():
        ns = [n for n in ns_all if n in data.robots(m)]
        if len(ns) < 2:
            continue
        for s in data.strategies(m):
            for col, name in (("idleness_avg_s", "I_avg"), ("idleness_ins_mean_s", "I_ins"),
                              ("uncertainty_mean", "X")):
                means = [data.stat(m, s, n, col).mean for n in ns]
                if not all(np.isfinite(means)):
                    continue
                checked += 1
                for k in range(len(ns) - 1):
                    # already zero (e.g. X of a fully covered map) cannot fall any further
                    if not (means[k + 1] < means[k] or means[k + 1] == means[k] == 0):
                        broken.append(f"{m} {label(s)} {name} {fmt(means[k])} (N={ns[k]}) → "
                                      f"{fmt(means[k + 1])} (N={ns[k + 1]})")
    return checked, broken


def _extra_note(data: Data, cases, col: str, extra: list[str]) -> str:
    """How the strategies outside the paper's comparison (e.g. SEBS) compare with TPUAF."""
    name = next(m[1].split(" ")[0] for m in METRICS if m[0] == col)
    notes = []
    for s in extra:
        beats = [f"{m} N={n} ({data.stat(m, s, n, col).mean:.5g} vs "
                 f"{data.stat(m, 'tpuaf', n, col).mean:.5g})"
                 for m, n in cases if data.stat(m, s, n, col).n
                 and data.stat(m, s, n, col).mean < data.stat(m, "tpuaf", n, col).mean]
        if beats:
            notes.append(f"{label(s)} (not in the paper's comparison) has a lower {name} than "
                         "TPUAF in " + ", ".join(beats))
    return (" " + "; ".join(notes) + ".") if notes else ""


def verdicts_section(data: Data) -> list[str]:
    """## Verdicts (claims of SPEC section 8)."""
    provisional = data.progress is not None and not data.progress.complete
    return ["## Verdicts (claims of SPEC section 8)" + (" - PROVISIONAL" if provisional else ""),
            "",
            *([f"Provisional: {data.progress.line().strip('*')}", ""] if provisional else []),
            "Fault-free graph runs. Computed from the means in the tables below (orderings of "
            "means over seeds; where the 95 % confidence intervals overlap, it is noted).", "",
            *[v.line() + (" (provisional)" if provisional else "") for v in verdicts(data)], ""]
