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
exec .venv/bin/python -m pytest "$@"
