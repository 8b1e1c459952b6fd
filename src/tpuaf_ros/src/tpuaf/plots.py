"""Per-run figures of a results folder (batch or fleet): idleness over time, and each vertex's
idleness drawn on the map image. Headless (Agg). Inputs: the folder's timeseries.csv,
visits.csv and config.yaml (the map); outputs PNG files in the folder (or `out`).

    tpuaf.plots.run_figures(folder)  ->  [idleness_over_time.png, vertex_idleness_map.png]
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import yaml


def _pyplot():
    from .report import _pyplot as headless

    return headless()


def _read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def idleness_over_time(folder: Path, out: Path | None = None) -> Path:
    """Instantaneous (mean over vertices) and worst idleness [s] against run time [s]."""
    folder = Path(folder)
    rows = _read_csv(folder / "timeseries.csv")
    if not rows:
        raise ValueError(f"{folder / 'timeseries.csv'}: no rows")
    t = np.array([float(r["time_s"]) for r in rows])
    t = t - t[0]
    ins = np.array([float(r["idleness_ins_s"]) for r in rows])
    worst = np.array([float(r["worst_idleness_s"]) for r in rows])
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(t, ins, label="instantaneous idleness (mean over vertices)")
    ax.plot(t, worst, label="worst idleness", alpha=0.8)
    ax.set_xlabel("run time [s]")
    ax.set_ylabel("idleness [s]")
    ax.set_title(_title(folder))
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left")
    path = Path(out or folder) / "idleness_over_time.png"
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def vertex_idleness_on_map(folder: Path, out: Path | None = None) -> Path:
    """Each vertex's mean interval idleness [s] (visits.csv) as a coloured disc on the map."""
    from .maps import load_map

    folder = Path(folder)
    config = yaml.safe_load((folder / "config.yaml").read_text())
    pm = load_map(config["map"])
    n = len(pm.positions)
    sums, counts = np.zeros(n), np.zeros(n)
    for r in _read_csv(folder / "visits.csv"):
        if r.get("interval_idleness_s"):
            v = int(r["vertex_index"])
            sums[v] += float(r["interval_idleness_s"])
            counts[v] += 1
    mean = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)
    plt = _pyplot()
    grid = pm.occupancy_grid()
    x0, y0 = grid.origin
    extent = (x0, x0 + grid.width * grid.resolution, y0, y0 + grid.height * grid.resolution)
    fig, ax = plt.subplots(figsize=(8, 8 * grid.height / max(grid.width, 1) + 0.5))
    ax.imshow(np.where(grid.occupied, 0.25, 1.0), cmap="gray", vmin=0, vmax=1, origin="lower",
              extent=extent, interpolation="nearest")
    for a, b, *_ in pm.edges:
        pa, pb = pm.positions[a], pm.positions[b]
        ax.plot([pa[0], pb[0]], [pa[1], pb[1]], color="0.7", lw=0.8, zorder=1)
    xy = np.asarray(pm.positions)
    seen = ~np.isnan(mean)
    sc = ax.scatter(xy[seen, 0], xy[seen, 1], c=mean[seen], cmap="viridis", s=70, zorder=3,
                    edgecolors="k", linewidths=0.5)
    if (~seen).any():
        ax.scatter(xy[~seen, 0], xy[~seen, 1], marker="x", color="red", s=60, zorder=3,
                   label="no interval (visited < 2 times)")
        ax.legend(loc="lower right")
    if seen.any():
        fig.colorbar(sc, ax=ax, label="mean interval idleness [s]", shrink=0.8)
    ax.set_title(_title(folder) + ": idleness per vertex")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")
    path = Path(out or folder) / "vertex_idleness_map.png"
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _title(folder: Path) -> str:
    try:
        c = yaml.safe_load((Path(folder) / "config.yaml").read_text())
        return f"{c.get('strategy', '?')} on {c.get('map_name', c.get('map', '?'))}, N = {c.get('robots', '?')}"
    except (OSError, yaml.YAMLError, AttributeError):
        return Path(folder).name


def run_figures(folder: Path, out: Path | None = None) -> list[Path]:
    """Both figures of a results folder."""
    return [idleness_over_time(folder, out), vertex_idleness_on_map(folder, out)]


if __name__ == "__main__":
    import sys

    for p in run_figures(Path(sys.argv[1])):
        print(p)
