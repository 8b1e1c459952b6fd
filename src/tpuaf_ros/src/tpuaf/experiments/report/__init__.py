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

One module per part: `common` (error, metric lists, formatting, statistics), `data` (loading),
`tables`, `claims` (the verdicts), `comparison` (where TPUAF loses, ratio to the best-known
tour, tpuaf_plus targets), `faults`, `degradation`, `physics`, `figures`, `writer`
(write_report: report.md, one function per section).
"""

from tpuaf.experiments.report.claims import Verdict, verdicts
from tpuaf.experiments.report.common import ReportError, Stat, fmt, label, stat
from tpuaf.experiments.report.data import Data, load
from tpuaf.experiments.report.writer import write_report

__all__ = ["Data", "ReportError", "Stat", "Verdict", "fmt", "label", "load", "stat", "verdicts",
           "write_report"]
