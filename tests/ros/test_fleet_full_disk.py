"""Complete means complete (issue 33 item 5): `tpuaf fleet` on a 500 kB filesystem fails with a
one-line error and never leaves a summary.json saying "complete": true (beside an empty bag or
simulator.json); `tpuaf render` says the folder is incomplete. Needs root for the tmpfs (skipped
with the reason otherwise). About 1 minute of wall time."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest

from ..conftest import run_cli

REPO = Path(__file__).resolve().parents[2]
TPUAF = str(REPO / ".venv" / "bin" / "tpuaf")

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def test_a_full_disk_is_not_a_complete_fleet_run(small_disk):
    out = small_disk / "run"
    env = {k: v for k, v in os.environ.items() if not k.startswith("ROS_")}
    run = run_cli([TPUAF, "fleet", "--map", "grid", "--robots", "2", "--duration", "60",
                   "--rtf", "10", "--quiet", "--out", str(out)], timeout=600, env=env, cwd=REPO)
    summary_path = out / "summary.json"
    summary = json.loads(summary_path.read_text()) if summary_path.is_file() else None
    render = (subprocess.run([TPUAF, "render", str(out)], capture_output=True, text=True,
                             timeout=300) if summary is not None else None)
    assert run.returncode == 2, run.stdout + run.stderr
    assert "Traceback" not in run.stderr, run.stderr
    last = run.stderr.strip().splitlines()[-1]
    assert last.startswith("tpuaf fleet: error:"), run.stderr
    if summary is not None:
        assert summary["complete"] is False, summary
        assert "incomplete" in render.stderr, render.stderr
