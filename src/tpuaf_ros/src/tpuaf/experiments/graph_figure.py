"""The picture of a patrol graph over its map (`tpuaf graph`, benchmarks/bench_graphgen.py):
the occupancy image, the cells seen by some vertex within the sensing radius (green) and the
reachable free cells none sees (red), edges and vertices by kind."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tpuaf.experiments.plots import _draw_map, new_figure

KIND_COLOURS = {"fixed": "tab:purple", "dead end": "tab:orange", "cover": "tab:blue"}
MAX_INCHES = 7.0  # long side of the figure [in], at 80 dpi: < 200 kB as PNG


def graph_png(pm, path: Path, *, covered: np.ndarray | None = None, region: np.ndarray | None
              = None, extent: tuple[float, float, float, float] | None = None,
              kinds: list[str] | None = None, title: str = "", lanes: list | None = None,
              arrows: list[tuple[int, int]] | None = None) -> Path:
    """Write the picture of map `pm` to `path` (PNG). `covered` / `region`: work-grid masks
    (row 0 at the bottom) spanning `extent` (x0, x1, y0, y1) [m]. `lanes`: per lane (its
    edges' planned paths (k, 2) [m] or None, its waiting spots' vertex indices), drawn over
    the graph, one colour each, the waiting spots as squares (docs/LANES.md). `arrows`: one-way
    arcs (u, v) by vertex index, an arrow each at the middle of its edge."""
    x0, y0, x1, y1 = pm.occupancy_grid().extent
    scale = MAX_INCHES / max(x1 - x0, y1 - y0)
    fig = new_figure(figsize=(max(2.5, (x1 - x0) * scale), max(2.5, (y1 - y0) * scale + 0.4)))
    ax = fig.add_axes((0.01, 0.01, 0.98, 0.9))
    _draw_map(ax, pm, edge_color="0.35")
    if covered is not None and region is not None and extent is not None:
        tint = np.zeros((*covered.shape, 4))
        tint[covered] = (0.2, 0.7, 0.2, 0.25)
        tint[region & ~covered] = (0.9, 0.1, 0.1, 0.45)
        ax.imshow(tint, origin="lower", extent=extent, interpolation="nearest", zorder=0.5)
    pos = np.asarray(pm.positions, dtype=float)
    for k, (paths, spots) in enumerate(lanes or []):
        colour = f"C{k % 10}"
        for p in paths:
            if p is not None:
                ax.plot(p[:, 0], p[:, 1], color=colour, linewidth=3.0, alpha=0.6, zorder=2)
        ax.scatter(pos[spots, 0], pos[spots, 1], s=40, marker="s", facecolors="none",
                   edgecolors=colour, linewidths=1.2, zorder=4)
    for u, v in arrows or []:
        a, b = pos[u], pos[v]
        mid, step = (a + b) / 2.0, (b - a) * 0.15
        ax.annotate("", xy=mid + step, xytext=mid - step, zorder=5,
                    arrowprops={"arrowstyle": "-|>", "color": "black", "linewidth": 1.2})
    kinds = kinds or ["cover"] * len(pos)
    for kind, colour in KIND_COLOURS.items():
        mask = np.array([k == kind for k in kinds], dtype=bool)
        if mask.any():
            ax.scatter(pos[mask, 0], pos[mask, 1], s=14, c=colour, zorder=3, label=kind,
                       edgecolors="black", linewidths=0.3)
    if len(set(kinds)) > 1:
        ax.legend(loc="upper right", fontsize=6, framealpha=0.8)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    if title:
        ax.set_title(title, fontsize=7)
    path = Path(path)
    fig.savefig(path, dpi=80, format="png")
    return path
