"""A lock-step fleet is faithful under load: 12 TPUAF robots on cumberland through `tpuaf fleet`
(roscpp simulator, Python agents, monitor, bag) while two busy-loop processes keep both cores
busy. The run finishes, no robot is declared dead or unresponsive, and its visits are within 5 %
of the physics runtime's for the same map, N and seed (health >= 0.95).

The busy loops and the fleet are stopped by PID (process groups we created), also on failure.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
TPUAF = [str(REPO / ".venv" / "bin" / "tpuaf")]
CUMBERLAND = Path("/work/shared/maps/patrolling_sim/cumberland")
N, DURATION, SEED = 12, 120.0, 0

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def physics_runtime() -> bool:
    text = subprocess.run([*TPUAF, "run", "--help"], capture_output=True, text=True).stdout
    return "--runtime" in text and "physics" in text


def clean_env() -> dict:
    return {k: v for k, v in os.environ.items() if not k.startswith("ROS_")}


def run_in_group(cmd: list[str], timeout: float) -> subprocess.CompletedProcess:
    """Run cmd in its own process group; on timeout or failure stop the whole group."""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=clean_env(), cwd=REPO, start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        out, _ = proc.communicate(timeout=timeout)
    finally:
        if proc.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGINT)
            try:
                proc.wait(60)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait(10)
    return subprocess.CompletedProcess(cmd, proc.returncode, out, "")


@pytest.fixture
def cpu_hog():
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"], start_new_session=True,
                             stdin=subprocess.DEVNULL) for _ in range(2)]
    try:
        yield hogs
    finally:
        for p in hogs:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(p.pid, signal.SIGKILL)
            p.wait(10)


def test_twelve_robots_on_cumberland_in_lockstep_under_a_cpu_hog(tmp_path, cpu_hog):
    if not CUMBERLAND.is_dir():
        pytest.skip("shared patrolling_sim maps not present")
    if not physics_runtime():
        pytest.skip("the physics runtime (tpuaf run --runtime physics) is not available: "
                    "health needs it as the reference")
    ref = run_in_group([*TPUAF, "run", "--map", str(CUMBERLAND), "--robots", str(N),
                        "--duration", str(DURATION), "--seed", str(SEED), "--runtime", "physics",
                        "--out", str(tmp_path / "physics")], timeout=900)
    assert ref.returncode == 0, ref.stdout[-3000:]
    ref_visits = json.loads((tmp_path / "physics" / "summary.json").read_text())["visits"]

    assert all(h.poll() is None for h in cpu_hog)  # the hog runs for the whole fleet run
    out = tmp_path / "fleet"
    proc = run_in_group([*TPUAF, "fleet", "--map", str(CUMBERLAND), "--robots", str(N),
                         "--duration", str(DURATION), "--seed", str(SEED), "--out", str(out),
                         "--quiet"], timeout=DURATION + 900)
    assert proc.returncode == 0, proc.stdout[-3000:]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["complete"] is True and "(finished)" in proc.stdout
    assert summary["stepping"] == "lock-step"
    assert summary["deaths"] == 0
    assert summary["unresponsive_events"] == 0, summary["simulator_events"]
    health = summary["visits"] / ref_visits
    print(f"fleet visits {summary['visits']}, physics {ref_visits}, health {health:.3f}, "
          f"RTF {summary['real_time_factor']}")
    assert health >= 0.95, (summary["visits"], ref_visits)
    assert (out / "run.bag").is_file() and not (out / "run.bag.active").exists()
