"""Cost of RunRecorder.record_positions (12 robots on cumberland), written to
benchmarks/results/metrics.json. Run: .venv/bin/python benchmarks/bench_metrics.py"""

from __future__ import annotations

import json
import platform
import time
from pathlib import Path

import numpy as np
from tpuaf.maps import load_map
from tpuaf.measure.metrics import RunRecorder

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "maps" / "patrolling_sim"


def run(pm, n_robots: int, dt: float, calls: int, ground_truth: bool, seed: int = 0) -> float:
    """Best of 5 repetitions of the mean CPU time [us] per call; robots bounce around the map
    (12 robots in the vertices' bounding box: some pair is usually within reach of d_if)."""
    rng = np.random.default_rng(seed)
    lo, hi = pm.positions.min(axis=0), pm.positions.max(axis=0)
    best = float("inf")
    for _ in range(5):
        rec = RunRecorder(pm, n_robots, ground_truth=ground_truth)
        pos = pm.positions[rng.choice(pm.num_vertices, n_robots, replace=False)].copy()
        vel = rng.normal(size=(n_robots, 2))
        vel /= np.linalg.norm(vel, axis=1)[:, None]
        trajectory = []
        for _k in range(calls):
            pos = pos + vel * dt * pm.settings.nominal_speed
            out = (pos < lo) | (pos > hi)
            vel[out] *= -1
            trajectory.append(pos.copy())
        t = 0.0
        start = time.process_time()
        for p in trajectory:
            t += dt
            rec.record_positions(t, p)
        best = min(best, (time.process_time() - start) / calls * 1e6)
    return best


def main() -> None:
    pm = load_map(SHARED / "cumberland") if SHARED.is_dir() else load_map("grid")
    results = {"map": pm.name, "n_robots": 12, "machine": platform.machine(),
               "python": platform.python_version(), "us_per_call": {}}
    for dt in (0.1, 0.36, 1.0):
        for gt in (True, False):
            key = f"dt={dt}s ground_truth={gt}"
            results["us_per_call"][key] = round(run(pm, 12, dt, 5000, gt), 2)
            print(f"{key}: {results['us_per_call'][key]:.1f} us/call")
    out = Path(__file__).resolve().parent / "results" / "metrics.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps(results, indent=2) + "\n")
    print(f"written {out}")


if __name__ == "__main__":
    main()
