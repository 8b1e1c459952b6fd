#!/usr/bin/env bash
# The main job: performs any missing setup, then runs a 1 h TPUAF patrol with 4 robots on the
# built-in grid map and prints its metrics. Extra args go to `tpuaf run`.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/launch_scripts/setup.sh"
exec "$ROOT/.venv/bin/tpuaf" run --map grid --strategy tpuaf --robots 4 --duration 3600 --seed 1 \
  --out "$ROOT/results/demo" "$@"
