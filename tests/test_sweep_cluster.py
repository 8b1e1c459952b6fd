"""A sweep on a local Dask cluster of 2 worker processes with 1 thread each (issue 14).

The runs are spread over both workers and give the same summaries as the same runs done in
this process: a sweep's results do not depend on where its runs execute.
"""

from __future__ import annotations

import json

from tpuaf.experiments.sweep.execute import run_sweep
from tpuaf.experiments.sweep.grid import make_spec
from tpuaf.experiments.sweep.worker import run_task


def test_two_worker_local_cluster_runs_every_run_once_with_equal_results(tmp_path):
    spec = make_spec(["grid"], ["tpuaf", "gbs"], [3], 3, 300.0)
    results: dict = {}
    outcome = run_sweep(spec, tmp_path, workers=2, progress=False,
                        on_result=lambda key, result: results.setdefault(key, result))
    keys = spec.keys()
    assert outcome.ran == len(keys) == 6 and outcome.failed == 0
    assert set(results) == set(keys)
    pids = {r["pid"] for r in results.values()}
    assert len(pids) == 2  # both worker processes took runs
    for key in keys:
        summary = json.loads((key.folder(tmp_path) / "summary.json").read_text())
        local = run_task(spec.task(key))
        assert local["error"] is None
        summary.pop("run")
        summary.pop("real_duration_s", None)
        local["summary"].pop("real_duration_s", None)
        assert summary == json.loads(json.dumps(local["summary"]))
