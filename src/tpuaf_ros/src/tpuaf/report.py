"""The report of a `tpuaf compare` folder: Markdown tables, PNG figures, verdicts (SPEC sec. 8).

Inputs (written by tpuaf.sweep): DIR/results.csv, DIR/samples.csv.gz, DIR/reference.csv; when
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

from .errors import TpuafError


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
ORDER = ["gbs", "sebs", "dtag", "dtap", "tpuaf"]
PAPER_TABLE = {"cumberland": 2, "grid": 3}


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


def default_paper_path() -> Path | None:
    """../shared/reference/paper_tables.csv beside the repository holding this package."""
    here = Path(__file__).resolve()
    for parent in here.parents:
        if (parent / ".git").exists() or (parent / "launch_scripts").is_dir():
            candidate = parent.parent / "shared" / "reference" / "paper_tables.csv"
            return candidate if candidate.is_file() else None
    return None


def load_paper(path: Path | None) -> dict[tuple[str, int, str, str], float]:
    out: dict[tuple[str, int, str, str], float] = {}
    if path is None or not Path(path).is_file():
        return out
    with open(path, newline="") as f:
        for line, row in enumerate(csv.DictReader(f), start=2):
            if row.get("table") not in ("2", "3") or not row.get("N"):
                continue
            try:
                out[(row["map"], int(row["N"]), row["strategy"].lower(), row["metric"])] = float(
                    row["value"])
            except (KeyError, ValueError) as err:
                raise ReportError(f"{path}:{line}: malformed row ({err})") from None
    return out


def load(root: Path, paper: Path | None = None) -> Data:
    from .sweep import write_tables

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
                    row[key] = value if key in ("status", "error", "map_source", "finished_at") \
                        else _float(value)
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
            for m, s, n, _seed, v in reader:
                samples[(m, s, int(n))].append(float(v))
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
    return Data(rows, failed, reference,
                {k: np.asarray(v) for k, v in samples.items()},
                load_paper(paper_path), paper_path if paper_path and Path(paper_path).is_file()
                else None, sweep)


# ------------------------------------------------------------------------------- tables


def metric_table(data: Data, map_name: str) -> str:
    strategies = data.strategies(map_name)
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
    from .metrics import acceleration_ratio

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
                cells = [fmt(base / (n * r[f"{kind}_avg_idleness_visit_s"]))
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
                    if not means[k + 1] < means[k]:
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

    cmap = matplotlib.colormaps["tab10"]
    return {s: cmap(i % 10) for i, s in enumerate(strategies)}


def box_figure(data: Data, m: str, path: Path) -> Path | None:
    plt = _pyplot()

    ns = data.robots(m)
    strategies = data.strategies(m)
    if not any((m, s, n) in data.samples for s in strategies for n in ns):
        return None
    fig, axes = plt.subplots(1, len(ns), figsize=(3.2 * len(ns) + 1, 4.2), squeeze=False)
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
        ax.set_xticks(range(1, len(present) + 1), [label(s) for s, _ in present], rotation=45)
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
            ax.plot(ns, [base / (n * r["partition_avg_idleness_visit_s"])
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
                 title: str | None = None) -> Path:
    root = Path(root)
    data = load(root, paper)
    out = Path(out) if out is not None else root
    figures = out / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    rel = Path("figures")  # relative to report.md

    md: list[str] = [f"# {title or 'Comparison report'}", ""]
    durations = sorted({r["duration_s"] for r in data.rows if np.isfinite(r["duration_s"])})
    seeds = sorted({r["seed"] for r in data.rows})
    wall_runs = sum(r["wall_time_s"] for r in data.rows if np.isfinite(r["wall_time_s"]))
    md += [f"Generated by `tpuaf report` on {time.strftime('%Y-%m-%d %H:%M')} from "
           f"`{root.name}/results.csv`: {len(data.rows)} finished runs, {len(data.failed)} failed.",
           "",
           f"- maps: {', '.join(data.maps())}",
           f"- strategies: {', '.join(label(s) for s in data.strategies())}",
           f"- team sizes N: {', '.join(map(str, data.robots()))}",
           f"- seeds: {', '.join(map(str, seeds))} ({len(seeds)} per configuration)",
           f"- simulated duration per run: {', '.join(f'{d:g}' for d in durations)} s",
           f"- batch runtime (no ROS); run wall times sum to {wall_runs:.0f} s"
           + (f"; the last `tpuaf compare` took {data.sweep['wall_time_s']:.0f} s wall "
              f"({data.sweep.get('ran', 0)} runs computed, {data.sweep.get('skipped', 0)} skipped)"
              if data.sweep.get("wall_time_s") else ""),
           ""]

    md += ["## Verdicts (claims of SPEC section 8)", "",
           "Computed from the means in the tables below (orderings of means over seeds; where the "
           "95 % confidence intervals overlap, it is noted).", ""]
    md += [v.line() for v in verdicts(data)] + [""]

    md += ["## Tables", "",
           "Mean ± 95 % CI half-width over seeds (Student t; ± 0 = the same value for every "
           "seed: the strategy does not depend on the seed there); **bold** = lowest mean of "
           "the row. "
           + ("In brackets: the paper's figure (Tables 2 and 3; a different simulator and "
              "navigation stack, so only orderings are comparable; the paper's X uses another "
              "scale). " if data.paper else "")
           + "The reference tours are analytic steady-state figures (tours.py): I_ins ↔ mean "
             "over vertices of the time-average idleness, I_max ↔ worst idleness (I_avg, a mean "
             "over visits, has no tour counterpart). I_std is the population std of interval idleness, the "
             "column the paper labels I_G^avg.", ""]
    for m in data.maps():
        table = PAPER_TABLE.get(m)
        md += [f"### {m}" + (f" (layout of the paper's Table {table})" if table else ""), "",
               metric_table(data, m), ""]

    md += ["## Figures", ""]
    for m in data.maps():
        p = box_figure(data, m, figures / f"box_{m}.png")
        if p:
            md += [f"### Interval idleness on {m} (paper Fig. 4)", "",
                   f"![interval idleness box plots, {m}]({rel / p.name})", "",
                   "Dashed: the best reference tour's worst idleness; dotted: the cyclic tour's "
                   "mean interval between visits.", ""]
    for m in data.maps():
        p = metrics_figure(data, m, figures / f"metrics_{m}.png")
        md += [f"### Metrics against N on {m}", "", f"![metrics against N, {m}]({rel / p.name})",
               ""]
    md += ["### Acceleration ratio (paper Fig. 8)", ""]
    p = acceleration_figure(data, figures / "acceleration.png")
    if p:
        md += [f"![acceleration ratio]({rel / p.name})", "",
               "a(N) = I_avg(1) / (N I_avg(N)) per seed (same map, strategy and seed), > 1 is "
               "super-linear.", acceleration_table(data) or "", ""]
    else:
        md += ["Not available: the acceleration ratio needs N = 1 runs "
               "(`tpuaf compare --robots 1 4 8 12 ...`).", ""]

    if data.failed:
        md += ["## Failed runs", "", "| map | strategy | N | seed | error |", "|---|---|---|---|---|"]
        md += [f"| {r['map']} | {label(r['strategy'])} | {r['robots']} | {r['seed']} | "
               f"{str(r.get('error', '')).replace('|', '/')} |" for r in data.failed]
        md += [""]
    if not data.paper:
        md += ["(The paper's figures were not found, so they are not shown.)", ""]
    path = out / "report.md"
    tmp = path.with_suffix(".md.tmp")
    tmp.write_text("\n".join(md))
    tmp.replace(path)
    return path
