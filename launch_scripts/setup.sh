#!/usr/bin/env bash
# Idempotent setup of the tpuaf workspace on Debian 12:
#   1. Debian's ROS 1 and build packages (apt), only those missing;
#   2. .venv from /usr/bin/python3 --system-site-packages with the pinned PyPI dependencies;
#   3. the catkin workspace (build/, devel/), rebuilt incrementally.
# Quick when nothing is missing. Prints what it does on stderr.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
export PATH="/usr/bin:/bin:/usr/sbin:/sbin:$PATH"
log() { echo "[setup] $*" >&2; }

APT_PACKAGES=(
  build-essential cmake ros-core-dev catkin rosbash python3-rospy python3-rosbag python3-roslaunch
  python3-geometry-msgs python3-nav-msgs python3-sensor-msgs python3-tf2-ros python3-tf2-msgs
  python3-std-srvs python3-rosgraph-msgs python3-visualization-msgs python3-actionlib
  python3-move-base-msgs libeigen3-dev libfcl-dev libgtest-dev pybind11-dev python3-networkx python3-numpy
  python3-yaml python3-dev python3-venv python3-catkin-pkg
  python3-scipy python3-tqdm python3-matplotlib  # tours; `tpuaf run`/`fleet` of a catkin workspace
  libroscpp-dev libgeometry-msgs-dev libnav-msgs-dev libsensor-msgs-dev libros-rosgraph-msgs-dev
  libstd-msgs-dev libstd-srvs-dev libtf2-msgs-dev libtopic-tools-dev libyaml-cpp-dev
  rviz xvfb python3-pil  # RViz, its headless test (Xvfb) and screenshot (Pillow ImageGrab)
)

missing=()
for pkg in "${APT_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
if ((${#missing[@]})); then
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  log "installing Debian packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  if ! $SUDO apt-get install -y -q "${missing[@]}" >&2; then
    log "apt-get install failed; updating package lists and retrying"
    $SUDO apt-get update -q >&2
    $SUDO apt-get install -y -q "${missing[@]}" >&2
  fi
fi

STAMPS="$ROOT/.setup-stamps"
mkdir -p "$STAMPS"
req_hash="$(sha256sum requirements.txt | cut -d' ' -f1)"
if [ ! -x .venv/bin/python ] || [ "$(cat "$STAMPS/requirements" 2>/dev/null)" != "$req_hash" ]; then
  log "creating .venv and installing requirements.txt"
  [ -x .venv/bin/python ] || /usr/bin/python3 -m venv --system-site-packages .venv
  .venv/bin/python -m pip install -q --disable-pip-version-check -r requirements.txt >&2
  echo "$req_hash" > "$STAMPS/requirements"
fi

if [ ! -f build/CMakeCache.txt ]; then
  log "configuring the catkin workspace"
  mkdir -p build
  cmake -S . -B build -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCATKIN_DEVEL_PREFIX="$ROOT/devel" \
    -DCMAKE_INSTALL_PREFIX="$ROOT/install" -DCMAKE_BUILD_TYPE=Release >"$STAMPS/cmake.log" 2>&1 || {
    tail -40 "$STAMPS/cmake.log" >&2
    log "cmake configure failed (full log: $STAMPS/cmake.log)"
    exit 1
  }
fi
# Keep catkin from searching the virtualenv and build trees for packages.
touch build/CATKIN_IGNORE .venv/CATKIN_IGNORE
[ -d devel ] && touch devel/CATKIN_IGNORE
if ! cmake --build build -j"$(nproc)" >"$STAMPS/build.log" 2>&1; then
  grep -E -A8 "error|Error" "$STAMPS/build.log" | head -60 >&2
  log "build failed (full log: $STAMPS/build.log)"
  exit 1
fi
touch devel/CATKIN_IGNORE

# Make the devel space importable from .venv and provide the `tpuaf` command.
site="$(.venv/bin/python -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
echo "$ROOT/devel/lib/python3/dist-packages" > "$site/tpuaf_devel.pth"
# The `tpuaf` program handles SIGINT, SIGTERM and SIGHUP from its first instruction: site runs
# this line (the first .pth, builtin modules only) before any other import, in the tpuaf
# program only (tpuaf.cli then takes over; a signal inherited as ignored stays ignored).
cat > "$site/00-tpuaf-signals.pth" <<'PTH'
import os, sys, _signal as _s; exec("def _tpuaf_stop(n, _f):\n    os.write(2, b'tpuaf: interrupted (' + {1: b'SIGHUP', 2: b'SIGINT', 15: b'SIGTERM'}[n] + b')\\n')\n    os._exit(128 + n)\nfor _n in (1, 2, 15):\n    if _s.getsignal(_n) != _s.SIG_IGN:\n        _s.signal(_n, _tpuaf_stop)") if os.path.basename(sys.argv[0] if sys.argv else "") == "tpuaf" else None
PTH
cat > .venv/bin/tpuaf <<WRAP
#!$ROOT/.venv/bin/python
# tpuaf command-line entry point (written by launch_scripts/setup.sh).
import sys

from tpuaf.cli import main

if __name__ == "__main__":  # Dask worker processes re-import the main module
    sys.exit(main())
WRAP
chmod +x .venv/bin/tpuaf
