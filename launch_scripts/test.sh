#!/usr/bin/env bash
# The whole test suite: performs any missing setup, then runs pytest. Extra args go to pytest.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/launch_scripts/setup.sh"
cd "$ROOT"
set +u  # catkin's setup and env hooks read unset variables
source devel/setup.bash
set -u
export ROS_HOME="${ROS_HOME:-$ROOT/build/ros_home}" ROS_IP=127.0.0.1
.venv/bin/python -m ruff check src tests benchmarks
# C++ unit tests of the core (gtest through ctest).
ctest --test-dir build --output-on-failure
# pytest on parallel workers (pytest-xdist): on 2 cores about half of the time is ROS tests waiting
# on the wall clock, so more workers than cores. --dist loadfile: a test file runs on one worker
# (module fixtures computed once, a file's fleets one after another), files in collection order
# (tests/ros first: the long wall-clock tests start at once). Not loadgroup: with pytest 9.2,
# xdist 3.8 ignores xdist_group marks (pytest-dev/pytest-xdist#1386).
# TPUAF_TEST_WORKERS=N sets the number; extra args come after ours (`-n 0`: no workers). The 25
# slowest tests are listed at the end (suite time budget: 20 min on 2 cores).
# A background job inherits SIGINT ignored, which bash cannot undo: pytest and its workers get
# SIGINT back at its default (KeyboardInterrupt), as in a terminal, before pytest starts.
exec .venv/bin/python -c 'import os, signal, sys
signal.signal(signal.SIGINT, signal.SIG_DFL)
os.execv(sys.executable, [sys.executable, "-m", "pytest", *sys.argv[1:]])' \
  -n "${TPUAF_TEST_WORKERS:-4}" --dist loadfile --no-loadscope-reorder --durations=25 "$@"
