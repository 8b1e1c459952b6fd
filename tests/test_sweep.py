"""Sweeps (`tpuaf compare`) and reports (`tpuaf report`): issue 4, items 3-5.

A tiny sweep (grid, GBS and TPUAF, N = 1 and 2, 120 s) runs on a local Dask cluster and on a
Dask scheduler + worker started here on loopback; resumption is checked after an interruption
and after deleting a run folder; verdicts are checked on hand-made result tables."""

from __future__ import annotations

import csv
import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from tpuaf.cli import main
from tpuaf.experiments.report import load, verdicts, write_report
from tpuaf.experiments.results_folder import lock_folder, unlock_folder
from tpuaf.experiments.sweep.execute import run_sweep
from tpuaf.experiments.sweep.grid import RunKey, make_spec
from tpuaf.experiments.sweep.tables import RESULT_COLUMNS

TINY = ["--maps", "grid", "--strategies", "gbs", "TPUAF", "--robots", "1", "2",
        "--duration", "120", "--seeds", "1", "--quiet"]


def read_results(root: Path) -> dict[tuple, dict]:
    with open(root / "results.csv", newline="") as f:
        return {(r["map"], r["strategy"], int(r["robots"]), int(r["seed"])): r
                for r in csv.DictReader(f)}


def summary_mtimes(root: Path) -> dict[str, int]:
    return {str(p.parent.relative_to(root)): p.stat().st_mtime_ns
            for p in sorted(root.glob("runs/*/*/N*/seed*/summary.json"))}


@pytest.fixture(scope="module")
def tiny(tmp_path_factory) -> Path:
    """The tiny sweep, run once on a local cluster with one worker."""
    root = tmp_path_factory.mktemp("sweep") / "tiny"
    assert main(["compare", *TINY, "--workers", "1", "--out", str(root)]) == 0
    return root


# ---------------------------------------------------------------------------- validation


@pytest.mark.parametrize("args, message", [
    (["--maps", "nowhere"], "built-in maps are"),
    (["--strategies", "gbs", "best"], "unknown strategy 'best' (valid:"),
])
def test_invalid_names_fail_before_any_run(tmp_path, capsys, args, message):
    out = tmp_path / "out"
    assert main(["compare", *TINY, *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err
    assert "Traceback" not in err
    assert not out.exists()  # nothing started, nothing written


def test_invalid_team_size_is_an_argument_error(tmp_path):
    with pytest.raises(SystemExit) as exit_info:
        main(["compare", *TINY, "--robots", "0", "--out", str(tmp_path / "o")])
    assert exit_info.value.code == 2


# ---------------------------------------------------------------------------- local cluster


@pytest.mark.slow
def test_tiny_sweep_writes_every_run_and_the_table(tiny):
    rows = read_results(tiny)
    assert set(rows) == {("grid", s, n, 0) for s in ("gbs", "tpuaf") for n in (1, 2)}
    assert all(r["status"] == "ok" for r in rows.values())
    with open(tiny / "results.csv", newline="") as f:
        assert next(csv.reader(f)) == RESULT_COLUMNS
    for key, row in rows.items():
        folder = RunKey(*key).folder(tiny)
        summary = json.loads((folder / "summary.json").read_text())
        assert summary["run"]["duration_s"] == 120
        assert summary["n_robots"] == key[2]
        assert float(row["idleness_avg_s"]) == pytest.approx(summary["idleness_avg_s"])
        assert (folder / "idleness.txt.gz").is_file() and (folder / "config.json").is_file()
    # reference tours for every (map, N)
    with open(tiny / "reference.csv", newline="") as f:
        ref = {(r["map"], int(r["robots"])) for r in csv.DictReader(f)}
    assert ref == {("grid", 1), ("grid", 2)}


@pytest.mark.slow
def test_resume_recomputes_only_the_missing_run(tiny, tmp_path):
    import shutil

    root = tmp_path / "copy"
    shutil.copytree(tiny, root)
    before = read_results(root)
    gone = RunKey("grid", "tpuaf", 2, 0)
    shutil.rmtree(gone.folder(root))
    # a run interrupted while writing (no summary.json) is not finished either
    half = RunKey("grid", "gbs", 1, 0).folder(root)
    (half / "summary.json").unlink()
    mtimes = summary_mtimes(root)
    assert main(["compare", *TINY, "--workers", "1", "--out", str(root)]) == 0
    record = json.loads((root / "sweep.json").read_text())
    assert (record["ran"], record["skipped"], record["failed"]) == (2, 2, 0)
    after_mtimes = summary_mtimes(root)
    changed = {k for k in after_mtimes if mtimes.get(k) != after_mtimes[k]}
    assert changed == {str(gone.folder(root).relative_to(root)), str(half.relative_to(root))}
    after = read_results(root)
    assert set(after) == set(before)
    for key in before:  # runs are deterministic: the recomputed ones give the same metrics
        for column in ("idleness_avg_s", "idleness_max_s", "uncertainty_mean", "visits"):
            assert after[key][column] == before[key][column], (key, column)


@pytest.mark.slow
def test_interrupted_sweep_keeps_finished_runs_and_resumes(tmp_path):
    spec = make_spec(["grid"], ["gbs", "tpuaf"], [1, 2], seeds=1, duration_s=60.0)
    root = tmp_path / "interrupted"
    seen = []

    def stop_after_first(key, result):
        seen.append(key)
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep(spec, root, workers=1, progress=False, on_result=stop_after_first)
    assert len(seen) == 1
    assert (seen[0].folder(root) / "summary.json").is_file()
    rows = read_results(root)  # the table was rebuilt on the way out
    assert list(rows) == [(seen[0].map, seen[0].strategy, seen[0].robots, seen[0].seed)]
    first_mtime = (seen[0].folder(root) / "summary.json").stat().st_mtime_ns
    # the report says the sweep is incomplete and its verdicts provisional (issue 33 item 8)
    text = write_report(root, out=tmp_path / "report1").read_text()
    assert ("**Sweep incomplete: 1 of 4 planned runs finished, 0 failed, 3 missing; the sweep "
            "was interrupted") in text
    assert "## Verdicts (claims of SPEC section 8) - PROVISIONAL" in text
    assert "(provisional)" in text
    lock_folder(root)  # a sweep writing there now: running
    try:
        text = write_report(root, out=tmp_path / "report2").read_text()
    finally:
        unlock_folder(root)
    assert f"the sweep is still running (pid {os.getpid()})" in text

    outcome = run_sweep(spec, root, workers=1, progress=False)
    assert (outcome.skipped, outcome.ran, outcome.failed) == (1, 3, 0)
    assert seen[0] not in outcome.computed
    assert (seen[0].folder(root) / "summary.json").stat().st_mtime_ns == first_mtime
    assert len(read_results(root)) == 4
    text = write_report(root, out=tmp_path / "report3").read_text()
    assert "Sweep complete: 4 of 4 planned runs finished, 0 failed, 0 missing." in text
    assert "PROVISIONAL" not in text and "(provisional)" not in text


@pytest.mark.slow
def test_changed_duration_is_refused(tiny, capsys):
    args = [a if a != "120" else "60" for a in TINY]
    assert main(["compare", *args, "--out", str(tiny)]) == 2
    assert "duration 120" in capsys.readouterr().err


# ---------------------------------------------------------------------------- external scheduler


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_for_port(port: int, proc: subprocess.Popen, timeout_s: float = 60.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"dask scheduler exited with {proc.returncode}")
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.2)
    raise RuntimeError(f"dask scheduler not listening on port {port}")


@pytest.mark.slow
def test_compare_against_a_dask_scheduler_on_loopback(tmp_path):
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = dict(os.environ)
    logs = tmp_path / "logs"
    logs.mkdir()
    procs = []
    try:
        procs.append(subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
             "--port", str(port), "--no-dashboard"],
            cwd=tmp_path, env=env, stdout=open(logs / "scheduler.log", "w"),
            stderr=subprocess.STDOUT))
        _wait_for_port(port, procs[0])
        procs.append(subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_worker", address, "--host", "127.0.0.1",
             "--nthreads", "1", "--no-dashboard", "--no-nanny"],
            cwd=tmp_path, env=env, stdout=open(logs / "worker.log", "w"),
            stderr=subprocess.STDOUT))
        root = tmp_path / "out"
        args = ["compare", *TINY, "--robots", "2", "--scheduler", address, "--out", str(root)]
        assert main(args) == 0, (logs / "worker.log").read_text()[-3000:]
        rows = read_results(root)
        assert set(rows) == {("grid", "gbs", 2, 0), ("grid", "tpuaf", 2, 0)}
        assert all(r["status"] == "ok" for r in rows.values())
        # every run was computed by the external worker, not in this process
        pids = {json.loads((RunKey(*k).folder(root) / "config.json").read_text())["pid"]
                for k in rows}
        assert pids == {procs[1].pid}
    finally:
        for proc in reversed(procs):
            proc.terminate()
        for proc in reversed(procs):
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


@pytest.mark.slow
def test_unreachable_scheduler_is_a_clear_error(tmp_path, capsys):
    port = _free_port()
    args = ["compare", *TINY, "--scheduler", f"tcp://127.0.0.1:{port}",
            "--out", str(tmp_path / "o")]
    assert main(args) == 2
    assert "cannot connect to the Dask scheduler" in capsys.readouterr().err


# ---------------------------------------------------------------------------- report


@pytest.mark.slow
def test_report_of_the_tiny_sweep(tiny, tmp_path):
    out = tmp_path / "report"
    assert main(["report", str(tiny), "--out", str(out)]) == 0
    text = (out / "report.md").read_text()
    for name in ("box_grid.png", "metrics_grid.png", "acceleration.png"):
        png = out / "figures" / name
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name
        assert f"(figures/{name})" in text
    verdict_lines = [line for line in text.splitlines() if line.startswith("- ") and (
        "reproduced**" in line or "*not tested*" in line)]
    assert len(verdict_lines) == 5
    assert "### grid: the paper's strategies (layout of the paper's Table 3)" in text
    assert "| 2 | I_max [s] |" in text


def _write_table(root: Path, values: dict) -> None:
    """results.csv from {(map, strategy, N): (I_avg, I_max, I_ins, X, I_std)} for seeds 0, 1."""
    root.mkdir(parents=True)
    with open(root / "results.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=RESULT_COLUMNS)
        w.writeheader()
        for (m, s, n), (avg, mx, ins, x, std) in values.items():
            for seed, jitter in ((0, 0.99), (1, 1.01)):
                w.writerow({"map": m, "strategy": s, "robots": n, "seed": seed,
                            "duration_s": 3600, "status": "ok",
                            "idleness_avg_s": avg * jitter, "idleness_max_s": mx * jitter,
                            "idleness_ins_mean_s": ins * jitter, "uncertainty_mean": x * jitter,
                            "idleness_std_s": std, "interference_rate_per_min": 1.0,
                            "wall_time_s": 1.0})


def _paper_like(tpuaf_grid8_x: float) -> dict:
    """TPUAF lowest at N = 8, 12 except grid N = 8 (DTAG lower); not best at N = 4."""
    values = {}
    for m in ("grid", "cumberland"):
        for n, scale in ((1, 8.0), (4, 4.0), (8, 2.0), (12, 1.0)):
            values[(m, "dtag", n)] = (10 * scale, 50 * scale, 12 * scale, 0.2 * scale, 5)
            t = 0.8 if n >= 8 else 1.1
            values[(m, "tpuaf", n)] = (10 * scale * t, 50 * scale * t, 12 * scale * t,
                                       0.2 * scale * t, 3 if n == 4 else 5)
    values[("grid", "tpuaf", 8)] = (20 * 0.8, 100 * 0.8, 24 * 1.1, tpuaf_grid8_x, 5)
    return values


def test_verdicts_are_computed_from_the_table(tmp_path):
    root = tmp_path / "paper_like"
    _write_table(root, _paper_like(tpuaf_grid8_x=0.4 * 1.1))
    v = verdicts(load(root, paper=None))
    status = [x.status for x in v]
    assert status == ["reproduced"] * 5, [x.line() for x in v]
    assert "Lowest in 4 of 4 cases" in v[1].numbers
    assert "Lowest in both in 3 of 4 cases" in v[2].numbers


def test_verdicts_report_failures_with_numbers(tmp_path):
    values = _paper_like(tpuaf_grid8_x=0.1)  # TPUAF X lower than DTAG on grid at N = 8
    values[("cumberland", "tpuaf", 12)] = (15.0, 80.0, 20.0, 0.5, 5)  # worse than N = 8
    root = tmp_path / "broken"
    _write_table(root, values)
    v = {x.claim.split(" ")[0] + str(i): x for i, x in enumerate(verdicts(load(root, paper=None)))}
    lines = [x.line() for x in v.values()]
    assert v["Idleness0"].status == "not reproduced"
    assert "cumberland TPUAF I_ins 19.20 (N=8) → 20.00 (N=12)" in v["Idleness0"].numbers
    assert v["TPUAF1"].status == "not reproduced"  # I_max 80 > DTAG's 50 at cumberland N = 12
    assert "cumberland N=12 I_max: TPUAF 80.00 ≥ DTAG 50.00" in v["TPUAF1"].numbers
    assert v["DTAG3"].status == "not reproduced", lines
    assert "X: DTAG 0.4 ≥ TPUAF 0.1" in v["DTAG3"].numbers


def test_report_from_the_table_alone(tmp_path):
    root = tmp_path / "table_only"
    values = {("grid", "gbs", 4): (10, 50, 12, 0.2, 5), ("grid", "tpuaf", 4): (9, 40, 11, 0.1, 4)}
    _write_table(root, values)
    path = write_report(root)
    text = path.read_text()
    assert "needs N = 1 runs" in text
    assert "*not tested*" in text
    assert (root / "figures" / "metrics_grid.png").is_file()
