"""The report of a `tpuaf compare` folder: Markdown tables, PNG figures, verdicts (SPEC sec. 8).

Inputs (written by tpuaf.experiments.sweep): DIR/results.csv, DIR/samples.csv.gz, DIR/reference.csv; when
DIR/runs/ exists the tables are rebuilt from the run folders first. Output: DIR/report.md and
DIR/figures/*.png (or another --out folder).

- Tables in the layout of the paper's Tables 2 (cumberland) and 3 (grid): per N and metric, one
  column per strategy (mean +- 95 % CI half-width over seeds, Student t), the paper's figure in
  brackets, then the reference tours (analytic steady state, tours.py).
- Figures: interval idleness box plots per strategy and N (paper Fig. 4), metrics against N,
  acceleration ratio a(N) = I_avg(1) / (N I_avg(N)) against N (paper Fig. 8, needs N = 1 runs).
- Verdicts: one line per claim of SPEC section 8, computed from the means of the table.
"""

from __future__ import annotations

import csv
import gzip
import math
import time
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

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
PAPER_STRATEGIES = ["gbs", "dtag", "dtap", "tpuaf"]  # the paper's comparison set
ORDER = ["gbs", "sebs", "cbls", "dtag", "dtap", "tpuaf", "tpuaf_plus", "tpuaf_any", "cgg", "msp",
         "cr", "hcr", "hpcc", "rand"]
PAPER_TABLE = {"cumberland": 2, "grid": 3, "lab": 4}
NOMINAL = "nominal"  # tpuaf.experiments.sweep.NOMINAL: the fault-free graph runs
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


# ------------------------------------------------------------------------------- inputs


def _float(text: str | None) -> float:
    try:
        return float(text) if text not in (None, "") else math.nan
    except ValueError:
        return math.nan


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


@dataclass
class Data:
    rows: list[dict[str, Any]]  # finished runs
    failed: list[dict[str, Any]]
    reference: dict[tuple[str, int], dict[str, float]]
    samples: dict[tuple[str, str, int], np.ndarray]
    paper: dict[tuple[str, int, str, str], float]
    paper_path: Path | None
    sweep: dict[str, Any]
    bounds: dict[tuple[str, int], dict[str, float]] = field(default_factory=dict)
    bounds_path: Path | None = None

    def subset(self, scenario: str) -> Data:
        """The runs of one scenario (samples are kept for the nominal one only)."""
        return Data([r for r in self.rows if r["scenario"] == scenario],
                    [r for r in self.failed if r["scenario"] == scenario], self.reference,
                    self.samples if scenario == NOMINAL else {}, self.paper, self.paper_path,
                    self.sweep, self.bounds, self.bounds_path)

    def scenarios(self) -> list[str]:
        names = {r["scenario"] for r in self.rows}
        return sorted(names, key=lambda s: (s != NOMINAL, s))

    def maps(self) -> list[str]:
        return _map_order(r["map"] for r in self.rows)

    def strategies(self, map_name: str | None = None) -> list[str]:
        return _strategy_order(r["strategy"] for r in self.rows
                               if map_name is None or r["map"] == map_name)

    def robots(self, map_name: str | None = None) -> list[int]:
        return sorted({r["robots"] for r in self.rows if map_name is None or r["map"] == map_name})

    def stat(self, map_name: str, strategy: str, n: int, column: str) -> Stat:
        return stat(r[column] for r in self.rows
                    if r["map"] == map_name and r["strategy"] == strategy and r["robots"] == n)

    def per_seed(self, map_name: str, strategy: str, n: int, column: str) -> dict[int, float]:
        return {r["seed"]: r[column] for r in self.rows
                if r["map"] == map_name and r["strategy"] == strategy and r["robots"] == n}


def default_paper_path(name: str = "paper_tables.csv") -> Path | None:
    """../shared/reference/<name> beside the repository holding this package."""
    here = Path(__file__).resolve()
    for parent in here.parents:
        if (parent / ".git").exists() or (parent / "launch_scripts").is_dir():
            candidate = parent.parent / "shared" / "reference" / name
            return candidate if candidate.is_file() else None
    return None


def load_bounds(path: Path | None) -> dict[tuple[str, int], dict[str, float]]:
    """patrol_bounds.csv: per (map, N) the best-known tour's worst idleness and the bounds [s]."""
    out: dict[tuple[str, int], dict[str, float]] = {}
    if path is None or not Path(path).is_file():
        return out
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        if "best_known_worst_idleness_s" not in (reader.fieldnames or []):
            raise ReportError(f"{path}: not a bounds table (needs best_known_worst_idleness_s)")
        for line, row in enumerate(reader, start=2):
            try:
                out[(row["map"], int(row["N"]))] = {
                    k: float(v) for k, v in row.items() if k not in ("map", "N") and v}
            except (KeyError, ValueError) as err:
                raise ReportError(f"{path}:{line}: malformed row ({err})") from None
    return out


def load_paper(path: Path | None) -> dict[tuple[str, int, str, str], float]:
    out: dict[tuple[str, int, str, str], float] = {}
    if path is None or not Path(path).is_file():
        return out
    with open(path, newline="") as f:
        for line, row in enumerate(csv.DictReader(f), start=2):
            if row.get("table") not in ("2", "3", "4") or not row.get("N"):
                continue
            try:
                out[(row["map"], int(row["N"]), row["strategy"].lower(), row["metric"])] = float(
                    row["value"])
            except (KeyError, ValueError) as err:
                raise ReportError(f"{path}:{line}: malformed row ({err})") from None
    return out


def load(root: Path, paper: Path | None = None, bounds: Path | None = None) -> Data:
    from tpuaf.experiments.sweep import write_tables

    root = Path(root)
    if not root.is_dir():
        raise ReportError(f"{root}: no such folder (run `tpuaf compare --out {root}` first)")
    if (root / "runs").is_dir():
        write_tables(root)
    results = root / "results.csv"
    if not results.is_file():
        raise ReportError(f"{results}: missing (run `tpuaf compare --out {root}` first)")
    rows, failed = [], []
    with open(results, newline="") as f:
        reader = csv.DictReader(f)
        need = {"map", "strategy", "robots", "seed", "status"}
        if not need <= set(reader.fieldnames or []):
            raise ReportError(f"{results}: not a results table (needs columns {sorted(need)})")
        for line, raw in enumerate(reader, start=2):
            try:
                row: dict[str, Any] = {"map": raw["map"], "strategy": raw["strategy"],
                                       "robots": int(raw["robots"]), "seed": int(raw["seed"])}
            except ValueError as err:
                raise ReportError(f"{results}:{line}: {err}") from None
            for key, value in raw.items():
                if key not in row:
                    row[key] = value if key in ("status", "error", "map_source", "finished_at",
                                                "scenario", "runtime") else _float(value)
            row["scenario"] = row.get("scenario") or NOMINAL  # tables of older sweeps
            row["runtime"] = row.get("runtime") or "graph"
            for key in ("loss", "delay_s", "deaths"):
                if not np.isfinite(row.get(key, math.nan)):
                    row[key] = 0.0
            (rows if raw["status"] == "ok" else failed).append(row)
    if not rows:
        raise ReportError(f"{results}: no finished runs")

    reference: dict[tuple[str, int], dict[str, float]] = {}
    ref_path = root / "reference.csv"
    if ref_path.is_file():
        with open(ref_path, newline="") as f:
            for raw in csv.DictReader(f):
                reference[(raw["map"], int(raw["robots"]))] = {
                    k: _float(v) for k, v in raw.items() if k not in ("map", "robots", "better")}

    samples: dict[tuple[str, str, int], list[float]] = defaultdict(list)
    sample_path = root / "samples.csv.gz"
    if sample_path.is_file():
        with gzip.open(sample_path, "rt", newline="") as f:
            reader = csv.reader(f)
            next(reader, None)
            for fields in reader:  # map, strategy, robots, seed[, scenario], idleness_s
                if len(fields) == 6 and fields[4] != NOMINAL:
                    continue
                samples[(fields[0], fields[1], int(fields[2]))].append(float(fields[-1]))
    sweep = {}
    if (root / "sweep.json").is_file():
        import json

        try:
            sweep = json.loads((root / "sweep.json").read_text())
        except ValueError:
            sweep = {}
    paper_path = paper if paper is not None else default_paper_path()
    if paper is not None and not Path(paper).is_file():
        raise ReportError(f"{paper}: no such file (the paper's figures)")
    bounds_path = bounds if bounds is not None else default_paper_path("patrol_bounds.csv")
    if bounds is not None and not Path(bounds).is_file():
        raise ReportError(f"{bounds}: no such file (the best-known tours)")
    return Data(rows, failed, reference,
                {k: np.asarray(v) for k, v in samples.items()},
                load_paper(paper_path), paper_path if paper_path and Path(paper_path).is_file()
                else None, sweep, load_bounds(bounds_path),
                bounds_path if bounds_path and Path(bounds_path).is_file() else None)


# ------------------------------------------------------------------------------- tables


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


def _ratio(a: float, b: float) -> float:
    """a / b, NaN when b is 0 (e.g. a tour with one robot per vertex: no interval at all)."""
    return a / b if b else math.nan


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


# ------------------------------------------------------------------------------- verdicts


@dataclass
class Verdict:
    claim: str
    status: str  # "reproduced", "not reproduced", "not tested"
    numbers: str

    def line(self) -> str:
        mark = {"reproduced": "**reproduced**", "not reproduced": "**not reproduced**"}.get(
            self.status, f"*{self.status}*")
        return f"- {self.claim}: {mark}. {self.numbers}"


def _overlap(a: Stat, b: Stat) -> bool:
    lo_a, hi_a = a.interval()
    lo_b, hi_b = b.interval()
    return lo_a <= hi_b and lo_b <= hi_a


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


def verdicts(data: Data) -> list[Verdict]:
    out: list[Verdict] = []
    maps = [m for m in ("grid", "cumberland") if m in data.maps()]
    among = [s for s in PAPER_STRATEGIES if s in data.strategies()]
    extra = [s for s in data.strategies() if s not in PAPER_STRATEGIES]

    # 1. idleness and uncertainty fall as N grows (over the paper's team sizes when present).
    paper_ns = [n for n in (4, 8, 12) if n in data.robots()]
    scope = paper_ns if len(paper_ns) >= 2 else data.robots()
    claim = ("Idleness (I_avg, I_ins) and uncertainty (X) fall as N grows, for every map and "
             f"strategy ({', '.join(label(s) for s in data.strategies())}), "
             f"N = {', '.join(map(str, scope))}")
    checked, broken = _falling(data, scope)
    if not checked:
        out.append(Verdict(claim, "not tested", "Needs at least two team sizes."))
    else:
        bad = len({b.split(" (N")[0].rsplit(" ", 1)[0] for b in broken})
        nums = f"Strictly falling in {checked - bad} of {checked} series (map, strategy, metric)"
        nums += "." if not broken else "; exceptions: " + "; ".join(broken) + "."
        if scope != data.robots():
            _, more = _falling(data, data.robots())
            more = [b for b in more if b not in broken]
            nums += (f" Including N = {', '.join(str(n) for n in data.robots() if n not in scope)}"
                     ": " + ("also " + "; ".join(more) if more else "no further exception") + ".")
        out.append(Verdict(claim, "reproduced" if not broken else "not reproduced", nums))

    cases = [(m, n) for m in maps for n in (8, 12) if n in data.robots(m)]
    have_t = "tpuaf" in data.strategies()
    vs = f"among {', '.join(label(s) for s in among)} (the paper's comparison)"

    # 2. TPUAF lowest I_max at N = 8 and 12 on both maps.
    claim = f"TPUAF has the lowest I_max at N = 8 and 12 on grid and cumberland, {vs}"
    results = [(m, n, _lowest(data, m, n, "idleness_max_s", among)) for m, n in cases]
    results = [r for r in results if r[2] is not None]
    if not have_t or len(results) < 4:
        out.append(Verdict(claim, "not tested",
                           "Needs TPUAF and another strategy on grid and cumberland at N = 8, 12."))
    else:
        wins = sum(r[2][0] for r in results)
        nums = f"Lowest in {wins} of 4 cases: " + "; ".join(
            _cmp_text(m, n, "I_max", r) for m, n, r in results) + "."
        nums += _extra_note(data, cases, "idleness_max_s", extra)
        out.append(Verdict(claim, "reproduced" if wins == 4 else "not reproduced", nums))

    # 3. TPUAF lowest I_ins and X in three of those four cases.
    claim = f"TPUAF has the lowest I_ins and X in at least three of those four cases, {vs}"
    res_ins = {(m, n): _lowest(data, m, n, "idleness_ins_mean_s", among) for m, n in cases}
    res_x = {(m, n): _lowest(data, m, n, "uncertainty_mean", among) for m, n in cases}
    if not have_t or len(cases) < 4 or any(v is None for v in [*res_ins.values(), *res_x.values()]):
        out.append(Verdict(claim, "not tested",
                           "Needs TPUAF and another strategy on grid and cumberland at N = 8, 12."))
    else:
        both = [c for c in cases if res_ins[c][0] and res_x[c][0]]
        parts = [_cmp_text(m, n, "I_ins", res_ins[(m, n)]) + ", " +
                 _cmp_text(m, n, "X", res_x[(m, n)]).split(": ", 1)[1] for m, n in cases]
        nums = f"Lowest in both in {len(both)} of 4 cases: " + "; ".join(parts) + "."
        nums += _extra_note(data, cases, "idleness_ins_mean_s", extra)
        out.append(Verdict(claim, "reproduced" if len(both) >= 3 else "not reproduced", nums))

    # 3b. The exception: DTAG lower on grid at N = 8.
    claim = "DTAG is lower than TPUAF in I_ins and X on grid at N = 8 (the paper's exception)"
    if ("grid", 8) not in cases or "dtag" not in data.strategies("grid") or not have_t:
        out.append(Verdict(claim, "not tested", "Needs DTAG and TPUAF on grid at N = 8."))
    else:
        parts, ok = [], True
        for col, name in (("idleness_ins_mean_s", "I_ins"), ("uncertainty_mean", "X")):
            d, t = data.stat("grid", "dtag", 8, col), data.stat("grid", "tpuaf", 8, col)
            ok &= d.mean < t.mean
            note = " (95 % CIs overlap)" if _overlap(d, t) else ""
            parts.append(f"{name}: DTAG {fmt(d.mean)} {'<' if d.mean < t.mean else '≥'} TPUAF "
                         f"{fmt(t.mean)}{note}")
        out.append(Verdict(claim, "reproduced" if ok else "not reproduced", "; ".join(parts) + "."))

    # 4. TPUAF not best at N = 4.
    claim = ("TPUAF is not best at N = 4: on each map some table metric (I_ins, I_max, I_std, X) "
             f"is lower for another strategy {vs}")
    cols = [("idleness_ins_mean_s", "I_ins"), ("idleness_max_s", "I_max"),
            ("idleness_std_s", "I_std"), ("uncertainty_mean", "X")]
    per_map, ok, tested = [], True, False
    for m in maps:
        if 4 not in data.robots(m) or not have_t:
            continue
        res = [(name, _lowest(data, m, 4, col, among)) for col, name in cols]
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
        out.append(Verdict(claim, "not tested", "Needs TPUAF and another strategy at N = 4."))
    else:
        out.append(Verdict(claim, "reproduced" if ok else "not reproduced",
                           "; ".join(per_map) + "."))
    return out


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
    name = next(m[1].split(" ")[0] for m in METRICS if m[0] == col)
    """How the strategies outside the paper's comparison (e.g. SEBS) compare with TPUAF."""
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


# ------------------------------------------------------------------------------- all strategies

ALL_METRICS = [m for m in METRICS]  # every table metric, one column each


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
            unrec = sum(r.get("unrecovered", 0) or 0 for r in fd.rows
                        if r["map"] == m and r["strategy"] == s and r["robots"] == n
                        and np.isfinite(r.get("unrecovered", math.nan)))
            if not (rec.n or after.n):
                cells.append("")
                continue
            cells.append(f"{fmt(rec.mean)} / {fmt(after.mean)} / {fmt(ideal.mean)}"
                         + (f" ({unrec:.0f} never)" if unrec else ""))
        lines.append("| " + " | ".join([label(s)] + cells) + " |")
    return "\n".join(lines)


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
    plt = _pyplot()

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


def wall_time_lines(data: Data) -> list[str]:
    """The sweeps' wall times (sweep.json history) and the runs' summed wall times."""
    out = []
    history = data.sweep.get("history") or []
    if history:
        total = sum(float(h.get("wall_time_s") or 0) for h in history)
        ran = sum(int(h.get("ran") or 0) for h in history)
        commits = sorted({str(h.get("commit")) for h in history if h.get("commit")})
        out.append(f"- wall time of the sweeps into this folder: **{total:.0f} s** "
                   f"({total / 60:.1f} min) for {ran} runs, in {len(history)} `tpuaf compare` "
                   f"invocations (2-core machine shared with other jobs; commits: "
                   f"{', '.join(commits) or 'unknown'})")
    by_sc: dict[str, list[float]] = defaultdict(list)
    for r in data.rows:
        if np.isfinite(r.get("wall_time_s", math.nan)):
            by_sc[r["scenario"]].append(r["wall_time_s"])
    if by_sc:
        parts = [f"{sc} {sum(v):.0f} s ({len(v)} runs)" for sc, v in
                 sorted(by_sc.items(), key=lambda x: (x[0] != NOMINAL, x[0]))]
        out.append("- run wall times summed (CPU-seconds of the workers, by scenario): "
                   + ", ".join(parts))
    return out


# ------------------------------------------------------------------------------- figures


def _pyplot():
    """matplotlib.pyplot on the headless Agg backend. Debian's mpl_toolkits beside the venv's
    matplotlib makes it warn about 3-D axes; no figure here uses them."""
    import warnings

    import matplotlib

    matplotlib.use("Agg")
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Unable to import Axes3D")
        warnings.filterwarnings("ignore", message="Importing matplotlib.tri.triangulation")
        import matplotlib.pyplot as plt
    return plt


def _colors(strategies: list[str]) -> dict[str, Any]:
    import matplotlib

    if len(strategies) <= 10:
        cmap = matplotlib.colormaps["tab10"]
        return {s: cmap(i % 10) for i, s in enumerate(strategies)}
    cmap = matplotlib.colormaps["tab20"]  # dark shades first, then the light ones
    return {s: cmap((2 * i) % 20 + (2 * i) // 20) for i, s in enumerate(strategies)}


def box_figure(data: Data, m: str, path: Path) -> Path | None:
    plt = _pyplot()

    ns = data.robots(m)
    strategies = data.strategies(m)
    if not any((m, s, n) in data.samples for s in strategies for n in ns):
        return None
    width = 3.2 if len(strategies) <= 6 else 0.3 * len(strategies) + 0.6  # [in] per panel
    fig, axes = plt.subplots(1, len(ns), figsize=(width * len(ns) + 1, 4.6), squeeze=False)
    colors = _colors(strategies)
    for ax, n in zip(axes[0], ns, strict=True):
        values = [data.samples.get((m, s, n), np.zeros(0)) for s in strategies]
        present = [(s, v) for s, v in zip(strategies, values, strict=True) if v.size]
        if not present:
            ax.set_visible(False)
            continue
        bp = ax.boxplot([v for _, v in present], showmeans=True, patch_artist=True,
                        meanprops={"marker": "x", "markeredgecolor": "black"},
                        medianprops={"color": "red"},
                        flierprops={"marker": "o", "markersize": 2, "alpha": 0.3})
        for patch, (s, _) in zip(bp["boxes"], present, strict=True):
            patch.set_facecolor(colors[s])
            patch.set_alpha(0.6)
        ax.set_xticks(range(1, len(present) + 1), [label(s) for s, _ in present],
                      rotation=90 if len(present) > 6 else 45, fontsize=7 if len(present) > 6 else 9)
        ref = data.reference.get((m, n))
        if ref:
            worst = min(ref["cyclic_worst_idleness_s"], ref["partition_worst_idleness_s"])
            ax.axhline(worst, color="black", ls="--", lw=1,
                       label="reference tour: worst idleness")
            ax.axhline(ref["cyclic_avg_idleness_visit_s"], color="black", ls=":", lw=1,
                       label="cyclic tour: mean interval")
        top = max(float(v.max()) for _, v in present)
        whisk = max(float(w.get_ydata().max()) for w in bp["whiskers"])
        if top > 10 * whisk:
            ax.set_yscale("log")
        ax.set_title(f"N = {n}")
        ax.grid(axis="y", alpha=0.3)
    axes[0][0].set_ylabel("interval idleness [s]")
    handles, labels = axes[0][0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=8, frameon=False)
    fig.suptitle(f"Interval idleness on {m} (all seeds pooled; x = mean, red = median)")
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def metrics_figure(data: Data, m: str, path: Path) -> Path:
    plt = _pyplot()

    panels = [("idleness_avg_s", "I_avg [s]", None),
              ("idleness_max_s", "I_max [s]", "worst_idleness_s"),
              ("idleness_ins_mean_s", "I_ins [s]", "avg_idleness_time_s"),
              ("uncertainty_mean", "X (time mean)", None)]
    ns = data.robots(m)
    strategies = data.strategies(m)
    colors = _colors(strategies)
    fig, axes = plt.subplots(2, 2, figsize=(10, 7.5))
    for ax, (col, name, ref_key) in zip(axes.flat, panels, strict=True):
        for k, s in enumerate(strategies):
            st = [data.stat(m, s, n, col) for n in ns]
            x = np.array(ns, dtype=float) * (1 + 0.012 * (k - len(strategies) / 2))
            ax.errorbar(x, [t.mean for t in st],
                        yerr=[t.ci if np.isfinite(t.ci) else 0 for t in st],
                        marker="o", ms=4, capsize=3, color=colors[s], label=label(s))
        if ref_key:
            refs = [data.reference.get((m, n)) for n in ns]
            if all(refs):
                best = [min(r[f"cyclic_{ref_key}"], r[f"partition_{ref_key}"]) for r in refs]
                ax.plot(ns, best, color="black", ls="--", lw=1.2,
                        label="reference tour (best of cyclic, partition)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks(ns, [str(n) for n in ns])
        ax.minorticks_off()
        ax.set_xlabel("N")
        ax.set_ylabel(name)
        ax.grid(alpha=0.3, which="both")
    axes[0][0].legend(fontsize=8)
    fig.suptitle(f"Metrics against team size on {m} (mean ± 95 % CI over seeds)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def acceleration_figure(data: Data, path: Path) -> Path | None:
    plt = _pyplot()

    maps = [m for m in data.maps() if 1 in data.robots(m) and len(data.robots(m)) > 1]
    if not maps:
        return None
    fig, axes = plt.subplots(1, len(maps), figsize=(5.5 * len(maps), 4.2), squeeze=False)
    for ax, m in zip(axes[0], maps, strict=True):
        ns = [n for n in data.robots(m) if n > 1]
        strategies = data.strategies(m)
        colors = _colors(strategies)
        for k, s in enumerate(strategies):
            st = [acceleration(data, m, s, n) for n in ns]
            x = np.array(ns, dtype=float) + 0.12 * (k - len(strategies) / 2)
            ax.errorbar(x, [t.mean for t in st], yerr=[t.ci if np.isfinite(t.ci) else 0 for t in st],
                        marker="o", ms=4, capsize=3, color=colors[s], label=label(s))
        refs = [data.reference.get((m, n)) for n in [1, *ns]]
        if all(refs):
            base = refs[0]["partition_avg_idleness_visit_s"]
            ax.plot(ns, [_ratio(base, n * r["partition_avg_idleness_visit_s"])
                         for n, r in zip(ns, refs[1:], strict=True)],
                    color="gray", ls=":", lw=1.2, label="partition tour")
        ax.axhline(1.0, color="black", ls="--", lw=1.2, label="linear (cyclic tour)")
        ax.set_xticks(ns)
        ax.set_xlabel("N")
        ax.set_ylabel("a(N) = I_avg(1) / (N I_avg(N))")
        ax.set_title(m)
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=8)
    fig.suptitle("Acceleration ratio (mean ± 95 % CI over seeds)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


# ------------------------------------------------------------------------------- the report


def write_report(root: Path, out: Path | None = None, paper: Path | None = None,
                 title: str | None = None, bounds: Path | None = None) -> Path:
    """report.md + figures/*.png of a compare folder; the nominal scenario carries the paper's
    claims, the other scenarios the fault tables, degradation curves and physics runs."""
    root = Path(root)
    everything = load(root, paper, bounds)
    data = everything.subset(NOMINAL)
    out = Path(out) if out is not None else root
    figures = out / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    rel = Path("figures")  # relative to report.md
    scenarios = everything.scenarios()
    physics = [sc for sc in scenarios
               if any(r["runtime"] == "physics" for r in everything.subset(sc).rows)]
    faults = {sc: everything.subset(sc) for sc in FAULT_SCENARIOS if sc in scenarios}

    md: list[str] = [f"# {title or 'Comparison report'}", ""]
    durations = sorted({r["duration_s"] for r in everything.rows if np.isfinite(r["duration_s"])})
    seeds = sorted({r["seed"] for r in everything.rows})
    md += [f"Generated by `tpuaf report` on {time.strftime('%Y-%m-%d %H:%M')} from "
           f"`{root.name}/results.csv`: {len(everything.rows)} finished runs, "
           f"{len(everything.failed)} failed.", ""]
    if data.rows:
        md += [f"- fault-free graph runs (nominal): maps {', '.join(data.maps())}; strategies "
               f"{', '.join(label(s) for s in data.strategies())}; N = "
               f"{', '.join(map(str, data.robots()))}; seeds "
               f"{', '.join(map(str, sorted({r['seed'] for r in data.rows})))}; "
               f"{len(data.rows)} runs"]
    for sc in scenarios:
        if sc == NOMINAL:
            continue
        d = everything.subset(sc)
        md.append(f"- scenario `{sc}`: maps {', '.join(d.maps())}; strategies "
                  f"{', '.join(label(s) for s in d.strategies())}; N = "
                  f"{', '.join(map(str, d.robots()))}; seeds "
                  f"{', '.join(map(str, sorted({r['seed'] for r in d.rows})))}; "
                  f"{len(d.rows)} runs")
    md += [f"- seeds: {', '.join(map(str, seeds))}",
           f"- simulated duration per run: {', '.join(f'{d:g}' for d in durations)} s"]
    md += wall_time_lines(everything) + [""]

    if data.rows:
        md += ["## Verdicts (claims of SPEC section 8)", "",
               "Fault-free graph runs. Computed from the means in the tables below (orderings of "
               "means over seeds; where the 95 % confidence intervals overlap, it is noted).", ""]
        md += [v.line() for v in verdicts(data)] + [""]

        md += ["## Where TPUAF loses, and to what", "",
               "Every strategy that ran, fault-free (the verdicts above compare TPUAF with the "
               "paper's rivals only).", ""]
        md += loss_summary(data) + [""]
        table = losses_table(data)
        if table:
            md += ["Per (map, N): TPUAF's mean, then every strategy with a lower mean and its "
                   "ratio to TPUAF (~ = the 95 % CIs overlap).", "", table, ""]

        ratio, notes = ratio_table(data)
        md += ["## Ratio to the best-known tour", "",
               "Mean I_max (the largest interval between two visits of a vertex) divided by the "
               "best-known tour's worst idleness (`best_known_worst_idleness_s` of "
               f"{'`' + everything.bounds_path.name + '`' if everything.bounds_path else 'the bounds table'}"
               f"); **bold** = within {TARGET_RATIO}× (issue 13's target). The last rows are our "
               "reference tours (tours.py, analytic), on the same scale.", ""]
        md += ([ratio, ""] if ratio else ["No map of this comparison is in the bounds table.", ""])
        md += [f"- {n}" for n in notes] + ([""] if notes else [])

        md += [f"## Targets of {label(PLUS)} (issue 13)", ""]
        md += plus_targets(data, faults) + [""]

    if faults:
        md += ["## Fault scenarios", "",
               "Each table: the mean over seeds, **bold** = lowest of the column; in brackets "
               "the ratio to the same strategy's fault-free mean. Deaths: robots "
               "floor(i N / K), i = 0..K-1, die at half the run (K = N/4, rounded down).", ""]
        for sc, fd in faults.items():
            md += [f"### {FAULT_TITLES.get(sc, sc)} (`{sc}`)", "", "**I_max [s]**", "",
                   fault_table(fd, data, "idleness_max_s"), "",
                   "**worst idleness [s]** (max over vertices and time of t - last visit: a "
                   "vertex never visited again counts, unlike in I_max)", "",
                   fault_table(fd, data, "worst_idleness_s"), "", "**X (time mean)**", "",
                   fault_table(fd, data, "uncertainty_mean"), ""]
            rec = recovery_table(fd)
            if rec:
                md += ["**Recovery** (per cell: slowest time until every vertex was visited "
                       "again after a death [s] / worst idleness after the deaths [s] / ideal "
                       "worst idleness of the N - K survivors, reference tours [s])", "", rec, ""]
            elif sc.startswith("deaths"):
                md += ["(No recovery figures in these runs' summaries.)", ""]

    cases = degradation_cases(everything)
    if cases:
        md += ["## Degradation curves", "",
               "One factor at a time (message loss, delay, robot deaths at half the run), the "
               "others at no fault; level 0 is the fault-free run.", ""]
        for m, n in cases:
            p = degradation_figure(everything, m, n, figures / f"degradation_{m}_N{n}.png")
            if p:
                md += [f"### {m}, N = {n}", "", f"![degradation, {m}, N = {n}]({rel / p.name})",
                       "", "I_max [s] (means over seeds):", "",
                       degradation_table(everything, m, n), "",
                       "Worst idleness [s] (means over seeds; counts a vertex never visited "
                       "again):", "", degradation_table(everything, m, n, "worst_idleness_s"), "",
                       "X (means over seeds):", "",
                       degradation_table(everything, m, n, "uncertainty_mean"), "",
                       monotone_note(everything, m, n), "",
                       monotone_note(everything, m, n, "worst_idleness_s", "worst idleness"), ""]

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
            ns = pd.robots(m)
            for strat in pd.strategies(m):
                if len(ns) < 2:
                    break
                means = [pd.stat(m, strat, n, "idleness_ins_mean_s").mean for n in ns]
                xs = [pd.stat(m, strat, n, "uncertainty_mean").mean for n in ns]
                falls = all(b < a for a, b in zip(means, means[1:], strict=False)) and \
                    all(b < a for a, b in zip(xs, xs[1:], strict=False))
                pv = Verdict(f"{label(strat)}'s I_ins and X fall as N grows in the physics runs "
                             "(as TPUAF's in the paper's Table 4)",
                             "reproduced" if falls else "not reproduced",
                             "I_ins " + " → ".join(fmt(v) for v in means) + "; X "
                             + " → ".join(fmt(v) for v in xs) + f" (N = {', '.join(map(str, ns))}).")
                md += [pv.line()]
            md += [""]

    if data.rows:
        md += ["## Tables", "",
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

        md += ["## Figures", ""]
        for m in data.maps():
            p = box_figure(data, m, figures / f"box_{m}.png")
            if p:
                md += [f"### Interval idleness on {m} (paper Fig. 4)", "",
                       f"![interval idleness box plots, {m}]({rel / p.name})", "",
                       "Dashed: the best reference tour's worst idleness; dotted: the cyclic "
                       "tour's mean interval between visits.", ""]
        for m in data.maps():
            p = metrics_figure(data, m, figures / f"metrics_{m}.png")
            md += [f"### Metrics against N on {m}", "",
                   f"![metrics against N, {m}]({rel / p.name})", ""]
        md += ["### Acceleration ratio (paper Fig. 8)", ""]
        p = acceleration_figure(data, figures / "acceleration.png")
        if p:
            md += [f"![acceleration ratio]({rel / p.name})", "",
                   "a(N) = I_avg(1) / (N I_avg(N)) per seed (same map, strategy and seed), > 1 is "
                   "super-linear.", acceleration_table(data) or "", ""]
        else:
            md += ["Not available: the acceleration ratio needs N = 1 runs "
                   "(`tpuaf compare --robots 1 4 8 12 ...`).", ""]

    if everything.failed:
        md += ["## Failed runs", "",
               "| map | strategy | N | scenario | seed | error |", "|---|---|---|---|---|---|"]
        md += [f"| {r['map']} | {label(r['strategy'])} | {r['robots']} | {r['scenario']} | "
               f"{r['seed']} | {str(r.get('error', '')).replace('|', '/')} |"
               for r in everything.failed]
        md += [""]
    if not data.paper:
        md += ["(The paper's figures were not found, so they are not shown.)", ""]
    path = out / "report.md"
    tmp = path.with_suffix(".md.tmp")
    tmp.write_text("\n".join(md))
    tmp.replace(path)
    return path
