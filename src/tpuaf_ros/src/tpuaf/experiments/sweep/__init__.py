"""Experiment sweeps: the grid (map x strategy x N x scenario x seed) of runs, on Dask (ROS-free).

A scenario is the fault setting of a run (message loss, delay, robot deaths) and its runtime
(graph or physics): `nominal` is the fault-free graph run. One task = one run, executed on a
worker (`run_task`): it loads the map from its name or path (workers share the filesystem), runs
the runtime's engine and returns the summary plus the interval idleness samples. The client
writes each result as it arrives into

    DIR/runs/<map>/<strategy>/N<k>/seed<s>/              the nominal scenario
    DIR/runs/<map>/<strategy>/N<k>/<scenario>/seed<s>/   any other scenario, e.g. loss0.3
        config.json            the run's key and effective configuration
        idleness.txt.gz        interval idleness samples [s], one per line
        error.txt              only for a failed run (its traceback)
        summary.json           every metric; written last (temp file + rename)

so a finished run is one whose summary.json exists; a re-run skips those (resumption), and a
failed run (error.txt, no summary.json) is retried. The tidy tables are rebuilt from the run
folders after every sweep:

    DIR/results.csv            one row per run folder (finished or failed)
    DIR/samples.csv.gz         map, strategy, robots, seed, scenario, idleness_s: every interval
                               sample of the fault-free runs (nominal and other runtimes)
    DIR/reference.csv          reference tours (cyclic, partition) per (map, N), tours.py
    DIR/sweep.json             the last sweep's grid and wall time, plus `history`: every sweep
                               into this folder (its wall time, runs computed, git commit)
    DIR/plan.json              the runs the last sweep planned (their folders under runs/),
                               written before the first run and marked `ended` after the last:
                               `tpuaf report` tells a finished sweep from a running or an
                               interrupted one (finished, failed, missing runs)

One module per job: `grid` (the sweep's spec: maps, strategies, team sizes, scenarios, seeds,
run keys, content hashes), `worker` (one run on a worker: its RunConfig and engine), `folders`
(a run's folder: write_run, the samples, reading folders back), `tables` (results.csv,
samples.csv.gz, reference.csv), `execute` (run_sweep on Dask: resumption checks, plan.json,
sweep.json).
"""

from tpuaf.experiments.sweep.execute import run_sweep
from tpuaf.experiments.sweep.folders import write_run
from tpuaf.experiments.sweep.grid import SweepError, make_scenarios, make_spec
from tpuaf.experiments.sweep.tables import write_tables
from tpuaf.experiments.sweep.worker import run_task

__all__ = ["SweepError", "make_scenarios", "make_spec", "run_sweep", "run_task", "write_run",
           "write_tables"]
