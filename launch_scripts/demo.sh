#!/usr/bin/env bash
# The main job: performs any missing setup, then runs a headless simulated ROS fleet (4 TPUAF
# robots on the built-in grid map, 600 simulated seconds, lock-step, bag recorded), analyses
# its bag (`tpuaf analyze`), prints the metrics and writes the plots (idleness over time, each
# vertex's idleness on the map) into the results folder. About 1-2 minutes of wall time once
# setup is done. Extra args go to `tpuaf fleet` (e.g. --robots 8, --strategy gbs).
#   Results: results/demo_fleet_<UTC time>/ (and the link results/demo_fleet_latest).
# The batch demo (no ROS): .venv/bin/tpuaf run --map grid --robots 4 --duration 3600 --out DIR
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/launch_scripts/setup.sh"
TPUAF="$ROOT/.venv/bin/tpuaf"
OUT="$ROOT/results/demo_fleet_$(date -u +%Y%m%d_%H%M%S)"
mkdir -p "$ROOT/results"
start=$(date +%s)
"$TPUAF" fleet --map grid --strategy tpuaf --robots 4 --duration 600 --seed 1 --out "$OUT" \
  --quiet "$@"
echo
echo "== tpuaf analyze $OUT/run.bag"
# (exit code 1 when a bag metric differs from the monitor's: reported, the demo goes on)
"$TPUAF" analyze "$OUT/run.bag" || echo "demo: tpuaf analyze exited with code $?"
echo
echo "== plots"
"$ROOT/.venv/bin/python" -m tpuaf.experiments.plots "$OUT"
ln -sfn "$(basename "$OUT")" "$ROOT/results/demo_fleet_latest"
echo
echo "demo: fleet, analysis and plots in $OUT ($(($(date +%s) - start)) s wall)"
