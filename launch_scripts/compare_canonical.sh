#!/usr/bin/env bash
# The canonical comparison (docs/COMPARISON.md): performs any missing setup, then runs the sweep
# grid + cumberland x GBS, SEBS, DTAG, DTAP, TPUAF x N = 1, 4, 8, 12 x 5 seeds x 1 h on a local
# Dask cluster and writes the report into reports/canonical/ (or $OUT).
# Resumable: re-running skips finished runs. Extra args go to `tpuaf compare`
# (e.g. --workers 4, --scheduler tcp://127.0.0.1:8786).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OUT="${OUT:-$ROOT/reports/canonical}"
bash "$ROOT/launch_scripts/setup.sh"
cd "$ROOT"
start=$(date +%s)
"$ROOT/.venv/bin/tpuaf" compare \
  --maps grid ../shared/maps/patrolling_sim/cumberland \
  --strategies gbs sebs dtag dtap tpuaf \
  --robots 1 4 8 12 --duration 3600 --seeds 5 \
  --out "$OUT" "$@"
"$ROOT/.venv/bin/tpuaf" report "$OUT" \
  --title "Canonical comparison: grid and cumberland, N = 1, 4, 8, 12, 5 seeds, 1 h"
echo "compare_canonical: wall time $(( $(date +%s) - start )) s"
