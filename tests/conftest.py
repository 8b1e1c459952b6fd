"""Shared test fixtures: paths to the repository and to ../shared; the Hypothesis profile."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest
from hypothesis import settings

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
PATROLLING_SIM_MAPS = SHARED / "maps" / "patrolling_sim"

# Fuzzers are deterministic: the same examples on every run and on every xdist worker (seeded
# from each test's name), no example database in the tree (shared by parallel workers, and it
# would replay old failures on one machine only). Loaded here, before the test modules build
# their settings(...) objects, so these inherit it. HYPOTHESIS_PROFILE=default explores anew.
settings.register_profile("ci", derandomize=True, database=None, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

# A TurtleBot3 shell sets TURTLEBOT3_MODEL, which `--robot auto` reads: the suite runs (and its
# subprocesses inherit) without it, so its figures do not depend on the developer's shell.
os.environ.pop("TURTLEBOT3_MODEL", None)


@pytest.fixture(scope="session")
def shared_maps() -> Path:
    if not PATROLLING_SIM_MAPS.is_dir():
        pytest.skip(f"reference maps not found at {PATROLLING_SIM_MAPS}")
    return PATROLLING_SIM_MAPS


# ---------------------------------------------------------------------------------------------
# Subprocesses that clean up after themselves (issue 12): the suite may run with SIGINT ignored
# (a background job), which children inherit; and a failed or timed-out test must not leave its
# child (and the child's ROS processes) running.


def default_sigint() -> None:
    """preexec_fn: the stop signals (SIGINT, SIGTERM, SIGHUP) back to their defaults in the
    child, whatever the suite inherited (a background job ignores SIGINT, nohup SIGHUP)."""
    import signal

    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, signal.SIG_DFL)


def stop_tree(proc, grace_s: float = 60.0) -> None:
    """Stop a `tpuaf` child started with start_new_session: SIGTERM (tpuaf cleans up what it
    started, e.g. roscore), then SIGKILL of its process group."""
    import contextlib
    import os
    import signal

    if proc.poll() is not None:
        return
    proc.terminate()
    try:
        proc.wait(grace_s)
    except subprocess.TimeoutExpired:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(10)


def run_cli(cmd: list[str], timeout: float, **kwargs):
    """subprocess.run(cmd, capture_output=True, text=True) that, on a timeout or any failure
    (e.g. Ctrl-C of the test), stops the child and what it started (stop_tree)."""

    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True, preexec_fn=default_sigint, **kwargs)
    try:
        stdout, stderr = proc.communicate(timeout=timeout)
    except BaseException:
        stop_tree(proc)
        raise
    return subprocess.CompletedProcess(cmd, proc.returncode, stdout, stderr)


@pytest.fixture
def small_disk(tmp_path):
    """A 500 kB tmpfs (root only; skipped with the reason otherwise), unmounted after."""
    mnt = tmp_path / "small"
    mnt.mkdir()
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=500k", "tmpfs", str(mnt)],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        pytest.skip(f"cannot mount a 500 kB tmpfs: {proc.stderr.strip() or proc.returncode}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], check=False)
