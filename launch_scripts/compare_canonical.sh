#!/usr/bin/env bash
# The canonical comparison (docs/COMPARISON.md): performs any missing setup, then, into
# reports/canonical/ (or $OUT), on a local Dask cluster (resumable: finished runs are skipped):
#  1. fault-free: every registered strategy (`tpuaf run --list`) x grid, cumberland, DIAG_labs,
#     1r5 (read from ../shared/maps/patrolling_sim, never copied) x N = 1, 4, 8, 12 x $SEEDS
#     seeds x 1 h;
#  2. degradation curves on grid, N = 8: loss 0.1-0.9, delay 1-30 s, 1-7 deaths, $CURVE_SEEDS;
#  3. the paper's physical experiment: lab, N = 1-4, 15 min, TurtleBot3 Burger presets in the
#     physics runtime, $PHYSICS_SEEDS seeds;
#  4. faults (a quarter of the team dies at 1800 s; 30 % message loss; 5 s delay): the paper's
#     strategies, tpuaf_plus, SEBS, CGG, MSP x the same maps x N = $FAULT_ROBOTS x $FAULT_SEEDS;
# then `tpuaf report`. Extra args go to every `tpuaf compare` (e.g. --workers 1).
# Smaller runs for a busy machine: SEEDS=2 FAULT_ROBOTS=8 FAULT_SEEDS=2 CURVE_SEEDS=2 ...
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OUT="${OUT:-$ROOT/reports/canonical}"
SEEDS="${SEEDS:-5}"
FAULT_ROBOTS="${FAULT_ROBOTS:-4 8 12}"
FAULT_SEEDS="${FAULT_SEEDS:-$SEEDS}"
CURVE_SEEDS="${CURVE_SEEDS:-3}"
PHYSICS_SEEDS="${PHYSICS_SEEDS:-3}"
SHARED="${SHARED:-$ROOT/../shared/maps/patrolling_sim}"
[ "${SKIP_SETUP:-0}" = 1 ] || bash "$ROOT/launch_scripts/setup.sh"
cd "$ROOT"
TPUAF="$ROOT/.venv/bin/tpuaf"
MAPS=(grid "$SHARED/cumberland" "$SHARED/DIAG_labs" "$SHARED/1r5")
read -r -a ALL <<< "$("$TPUAF" run --list | sed -n 's/^strategies: //p' | tr -d ,)"
RIVALS=(tpuaf tpuaf_plus gbs dtag dtap sebs cgg msp)
CURVES=(tpuaf tpuaf_plus gbs dtag dtap cgg msp)
start=$(date +%s)
status=0
stage() { echo "== compare_canonical: $1"; shift; "$TPUAF" compare "$@" --out "$OUT" || status=$?; }
# read -a splits FAULT_ROBOTS into separate numbers
read -r -a FAULT_N <<< "$FAULT_ROBOTS"
stage "fault-free, every strategy" --maps "${MAPS[@]}" --strategies "${ALL[@]}" \
  --robots 1 4 8 12 --duration 3600 --seeds "$SEEDS" "$@"
stage "degradation curves" --maps grid --strategies "${CURVES[@]}" --robots 8 --duration 3600 \
  --seeds "$CURVE_SEEDS" --loss 0.1 0.3 0.5 0.7 0.9 --delay 1 2 5 10 20 30 \
  --deaths 1/8 2/8 3/8 5/8 7/8 "$@"
stage "physics (paper Table 4)" --maps lab --strategies tpuaf tpuaf_plus --robots 1 2 3 4 \
  --duration 900 --seeds "$PHYSICS_SEEDS" --runtime physics --robot burger "$@"
# the most expensive stage last
stage "faults" --maps "${MAPS[@]}" --strategies "${RIVALS[@]}" --robots "${FAULT_N[@]}" \
  --duration 3600 --seeds "$FAULT_SEEDS" --deaths 1/4 --loss 0.3 --delay 5 "$@"
"$TPUAF" report "$OUT" --title "Canonical comparison: every strategy, 4 maps, N = 1-12, faults, degradation, physics"
echo "compare_canonical: wall time $(( $(date +%s) - start )) s (failed runs: exit $status)"
exit "$status"
