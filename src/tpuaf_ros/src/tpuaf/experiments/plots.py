"""Per-run figures of a results folder (batch or fleet): idleness over time, and each vertex's
idleness drawn on the map image. Headless: matplotlib's object-oriented API on its own Agg
canvas (no pyplot state). Inputs: the folder's timeseries.csv, visits.csv and config.yaml (the
map); outputs PNG files in the folder (or `out`).

    tpuaf.experiments.plots.run_figures(folder)  ->  [idleness_over_time.png, vertex_idleness_map.png]

The map under the vertices (occupancy image and graph edges) is one image and one line
collection, prepared once per map content (`map_background`) and reused by every figure.
"""

from __future__ import annotations

import csv
import hashlib
import io
import math
import warnings
from collections import OrderedDict
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from tpuaf.files import atomic_file

_YAML_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # config.yaml: libyaml if present


@contextmanager
def _quiet_matplotlib_imports():
    """Debian's mpl_toolkits beside the venv's matplotlib makes it warn about 3-D axes; no
    figure here uses them."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Unable to import Axes3D")
        warnings.filterwarnings("ignore", message="Importing matplotlib.tri.triangulation")
        yield


def headless_pyplot():
    """matplotlib.pyplot on the headless Agg backend (for the report's figures)."""
    import matplotlib

    matplotlib.use("Agg")
    with _quiet_matplotlib_imports():
        import matplotlib.pyplot as plt
    return plt


def new_figure(**kwargs: Any):
    """A matplotlib Figure on its own Agg canvas: no pyplot, no global figure list (nothing to
    close; the figure goes with its last reference)."""
    with _quiet_matplotlib_imports():
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    fig = Figure(**kwargs)
    FigureCanvasAgg(fig)
    return fig


def _read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def _columns(path: Path, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The named columns of a CSV file of numbers (ours: no quotes), as arrays of strings
    ("" = empty cell; a missing column: an empty array)."""
    with open(path, newline="") as f:
        head = next(csv.reader(f), [])
    out = {name: np.array([], dtype=str) for name in names}
    present = [name for name in names if name in head]
    if not present:
        return out
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # loadtxt warns about a file without rows
            table = np.loadtxt(path, delimiter=",", skiprows=1, dtype=str, comments=None,
                               usecols=[head.index(name) for name in present], ndmin=2,
                               encoding="utf-8")
    except ValueError:  # rows of other lengths: the csv module, short rows padded
        with open(path, newline="") as f:
            rows = list(csv.reader(f))[1:]
        width = len(head)
        table = np.array([(row + [""] * width)[:width] for row in rows], dtype=str)
        table = table.reshape(-1, width)[:, [head.index(name) for name in present]]
    for k, name in enumerate(present):
        out[name] = table[:, k]
    return out


def _number_columns(path: Path, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The named columns of a CSV file of numbers as floats (NaN for an empty cell; a missing
    column: an empty array), read by numpy's C parser straight into numbers: `_columns` then
    `_floats` costs ~3 us a cell in string conversions (0.2 s for 60,000 visits)."""
    with open(path, "rb") as f:
        head = next(csv.reader([f.readline().decode("utf-8")]), [])
        body = f.read()
    out = {name: np.zeros(0) for name in names}
    present = [name for name in names if name in head]
    if not present or not body.strip():
        return out
    body = body.replace(b"\r\n", b"\n")
    while b",," in body:  # empty cells -> nan
        body = body.replace(b",,", b",nan,")
    body = body.replace(b",\n", b",nan\n").replace(b"\n,", b"\nnan,")
    body = (b"nan" if body.startswith(b",") else b"") + body + \
        (b"nan" if body.endswith(b",") else b"")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            table = np.loadtxt(io.BytesIO(body), delimiter=",", dtype=float, comments=None,
                               usecols=[head.index(name) for name in present], ndmin=2)
    except ValueError:  # rows of other lengths, or a cell that is no number: as _columns does
        return {name: _floats(v) if len(v) else np.zeros(0)
                for name, v in _columns(path, names).items()}
    for k, name in enumerate(present):
        out[name] = table[:, k]
    return out


def _floats(values: np.ndarray) -> np.ndarray:
    """Numbers of a CSV column; NaN for empty cells."""
    out = np.full(len(values), np.nan)
    filled = values != ""
    out[filled] = values[filled].astype(float)
    return out


def _config(folder: Path) -> Any:
    return yaml.load((Path(folder) / "config.yaml").read_text(), Loader=_YAML_LOADER)


def _mean_interval_idleness(folder: Path, n: int) -> np.ndarray:
    """Each vertex's mean interval idleness [s] (visits.csv); NaN for a vertex without one."""
    path = Path(folder) / "visits.csv"
    cols = _number_columns(path, ("vertex_index", "interval_idleness_s"))
    vertex, idleness = cols["vertex_index"], cols["interval_idleness_s"]
    if len(vertex) != len(idleness):  # a column missing: no intervals
        vertex = idleness = np.zeros(0)
    filled = ~np.isnan(idleness)
    if np.isnan(vertex[filled]).any() or (vertex[filled] != np.round(vertex[filled])).any():
        raise ValueError(f"{path}: vertex_index is not an integer")
    vertex = vertex[filled].astype(np.int64)
    idleness = idleness[filled]
    if len(vertex) and not (0 <= vertex.min() and vertex.max() < n):
        raise ValueError(f"{path}: vertex_index outside the map's 0..{n - 1}")
    sums = np.bincount(vertex, weights=idleness, minlength=n)
    counts = np.bincount(vertex, minlength=n)
    return np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)


# ------------------------------------------------------------------------------- map background
# The occupancy image of a large map has millions of cells (grid1000: 4,500 x 2,800 at 5 cm);
# drawn at a few hundred pixels, imshow's 'nearest' keeps one cell per pixel. The background
# keeps every k-th cell (the same nearest sampling, at least 2x finer than any figure here
# draws it), so a figure resamples an image of ~1,500 cells a side instead of the whole grid.

BACKGROUND_CELLS = 1500  # cells on the long side of a map background, at most
_BACKGROUNDS: OrderedDict[bytes, MapBackground] = OrderedDict()
_MAX_BACKGROUNDS = 8  # maps kept (a sweep worker draws a few maps over and over)


@dataclass(frozen=True)
class MapBackground:
    """What every map figure draws under the vertices: the occupancy image (True =
    occupied, subsampled), its extent [m] (x0, x1, y0, y1) and the edges' end points [m]."""

    occupied: np.ndarray  # (rows, cols) bool, row 0 at y0
    extent: tuple[float, float, float, float]
    segments: np.ndarray  # (edges, 2, 2): [[xa, ya], [xb, yb]]


def _map_key(positions: np.ndarray, edges: np.ndarray, occupied: np.ndarray,
             extent: tuple[float, ...]) -> bytes:
    h = hashlib.blake2b(digest_size=16)
    for part in (positions, edges, np.packbits(occupied), np.asarray(extent, dtype=float),
                 np.asarray(occupied.shape)):
        h.update(np.ascontiguousarray(part).tobytes())
    return h.digest()


def _corridor_cells(pm) -> tuple[np.ndarray, tuple[float, float, float, float]]:
    """The corridors `corridors_from_graph` would generate for a map without an image (same
    width and extent), rasterised straight at the background's cell size: cells within half a
    corridor width of an edge's centre line (points every half cell along it) or of a vertex
    are free. A picture of that grid at a twentieth of its cost (per edge, ~1 ms there)."""
    from tpuaf.maps.occupancy import default_corridor_width

    width = float(pm.corridor_width or default_corridor_width(pm))  # [m]
    pos = np.asarray(pm.positions, dtype=float).reshape(-1, 2)
    if pm.bounds is not None:
        lo = np.array(pm.bounds[:2], dtype=float)
        hi = np.array(pm.bounds[2:], dtype=float)
    else:
        lo, hi = pos.min(axis=0) - width, pos.max(axis=0) + width
    cell = max(float((hi - lo).max()) / BACKGROUND_CELLS, min(0.05, width / 8.0))  # [m]
    cols, rows = (max(1, int(round(float(s) / cell))) for s in hi - lo)
    pairs = np.array([(a, b) for a, b, *_ in pm.edges], dtype=np.int64).reshape(-1, 2)
    start, delta = pos[pairs[:, 0]], pos[pairs[:, 1]] - pos[pairs[:, 0]]
    count = np.ceil(np.hypot(delta[:, 0], delta[:, 1]) / (0.5 * cell)).astype(np.int64) + 1
    edge = np.repeat(np.arange(len(pairs)), count)
    first = np.cumsum(count) - count
    fraction = (np.arange(int(count.sum())) - first[edge]) / np.maximum(count[edge] - 1, 1)
    points = np.vstack((start[edge] + fraction[:, None] * delta[edge], pos))
    col = np.floor((points[:, 0] - lo[0]) / cell).astype(np.int64)
    row = np.floor((points[:, 1] - lo[1]) / cell).astype(np.int64)
    inside = (col >= 0) & (col < cols) & (row >= 0) & (row < rows)
    centre = np.zeros((rows, cols), dtype=bool)
    centre[row[inside], col[inside]] = True
    reach = 0.5 * width / cell  # [cells] the disc every centre cell frees (~1 % of the cells
    # differ from the generated grid's, along the corridor sides)
    k = int(math.floor(reach))
    free = centre.copy()
    for dr in range(-k, k + 1):
        for dc in range(-k, k + 1):
            if (dr or dc) and dr * dr + dc * dc <= reach * reach:
                free[max(dr, 0):rows + min(dr, 0), max(dc, 0):cols + min(dc, 0)] |= \
                    centre[max(-dr, 0):rows + min(-dr, 0), max(-dc, 0):cols + min(-dc, 0)]
    extent = (float(lo[0]), float(lo[0] + cols * cell), float(lo[1]), float(lo[1] + rows * cell))
    return ~free, extent


def map_background(pm) -> MapBackground:
    """The background of map `pm`, shared by maps of equal content (positions, edges and the
    image, or what generates its corridors)."""
    xy = np.asarray(pm.positions, dtype=float)
    edges = np.array([(a, b) for a, b, *_ in pm.edges], dtype=np.int64).reshape(-1, 2)
    grid = pm.occupancy
    if grid is None:  # corridors to generate: keyed by what they are made of
        from tpuaf.maps.occupancy import default_corridor_width

        made_of = np.array([float(pm.corridor_width or default_corridor_width(pm)),
                            *(pm.bounds or (np.nan,) * 4)], dtype=float)
        key = _map_key(xy, edges, np.zeros(0, dtype=bool), tuple(made_of))
    else:
        x0, y0 = grid.origin
        extent = (float(x0), float(x0 + grid.width * grid.resolution), float(y0),
                  float(y0 + grid.height * grid.resolution))
        step = max(1, math.ceil(max(grid.occupied.shape) / BACKGROUND_CELLS))
        occupied = np.ascontiguousarray(grid.occupied[::step, ::step], dtype=bool)
        key = _map_key(xy, edges, occupied, extent)
    cached = _BACKGROUNDS.get(key)
    if cached is not None:
        _BACKGROUNDS.move_to_end(key)
        return cached
    if grid is None:
        occupied, extent = _corridor_cells(pm)
    background = MapBackground(occupied, extent, xy[edges] if len(edges) else
                               np.zeros((0, 2, 2)))
    _BACKGROUNDS[key] = background
    while len(_BACKGROUNDS) > _MAX_BACKGROUNDS:
        _BACKGROUNDS.popitem(last=False)
    return background


def _draw_map(ax, pm, *, occupied_gray: float = 0.3, edge_color: str = "0.75",
              ticks: bool = False) -> None:
    """The occupancy image (free = white, occupied = `occupied_gray`) and the graph's edges, in
    map metres: one image and one line collection."""
    from matplotlib.collections import LineCollection

    bg = map_background(pm)
    ax.imshow(np.where(bg.occupied, occupied_gray, 1.0), cmap="gray", vmin=0, vmax=1,
              origin="lower", extent=bg.extent, interpolation="nearest")
    ax.add_collection(LineCollection(bg.segments, colors=edge_color, linewidths=0.8, zorder=1))
    ax.autoscale_view()  # as ax.plot did: the edges count in the limits
    ax.set_aspect("equal")
    if not ticks:
        ax.set_xticks([])
        ax.set_yticks([])


# ------------------------------------------------------------------------------- run figures


def idleness_over_time(folder: Path, out: Path | None = None) -> Path:
    """Instantaneous (mean over vertices) and worst idleness [s] against run time [s]."""
    folder = Path(folder)
    cols = _columns(folder / "timeseries.csv", ("time_s", "idleness_ins_s", "worst_idleness_s"))
    if not len(cols["time_s"]):
        raise ValueError(f"{folder / 'timeseries.csv'}: no rows")
    t = _floats(cols["time_s"])
    t = t - t[0]
    fig = new_figure(figsize=(8, 4))
    ax = fig.subplots()
    ax.plot(t, _floats(cols["idleness_ins_s"]),
            label="instantaneous idleness (mean over vertices)")
    ax.plot(t, _floats(cols["worst_idleness_s"]), label="worst idleness", alpha=0.8)
    ax.set_xlabel("run time [s]")
    ax.set_ylabel("idleness [s]")
    ax.set_title(_title(folder))
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left")
    path = Path(out or folder) / "idleness_over_time.png"
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return path


def vertex_idleness_on_map(folder: Path, out: Path | None = None) -> Path:
    """Each vertex's mean interval idleness [s] (visits.csv) as a coloured disc on the map."""
    from tpuaf.maps import load_map

    folder = Path(folder)
    config = _config(folder)
    pm = load_map(config["map"], params=config.get("map_params") or None)
    mean = _mean_interval_idleness(folder, len(pm.positions))
    rows, cols = map_background(pm).occupied.shape
    fig = new_figure(figsize=(8, 8 * rows / max(cols, 1) + 0.5))
    ax = fig.subplots()
    _draw_map(ax, pm, occupied_gray=0.25, edge_color="0.7", ticks=True)
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
    path = Path(out or folder) / "vertex_idleness_map.png"
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return path


def _title(folder: Path) -> str:
    try:
        c = _config(folder)
        return f"{c.get('strategy', '?')} on {c.get('map_name', c.get('map', '?'))}, N = {c.get('robots', '?')}"
    except (OSError, yaml.YAMLError, AttributeError):
        return Path(folder).name


def run_figures(folder: Path, out: Path | None = None) -> list[Path]:
    """Both figures of a results folder."""
    return [idleness_over_time(folder, out), vertex_idleness_on_map(folder, out)]


# ------------------------------------------------------------------------------- summary.png
# One small PNG per results folder, written by ResultsWriter.finish (before summary.json):
# idleness over time (and X) beside each vertex's mean interval idleness on the map image.


def _map_of(folder: Path, patrol_map=None):
    if patrol_map is not None:
        return patrol_map
    from tpuaf.maps import load_map

    config = _config(folder) or {}
    source = config.get("map_source")
    return load_map(source if source and source != "built-in" else config["map"],
                    params=config.get("map_params") or None)


def summary_png(folder: Path, patrol_map=None, summary: dict | None = None,
                path: Path | None = None) -> Path:
    """summary.png of a results folder (timeseries.csv, visits.csv, config.yaml); atomic."""
    folder = Path(folder)
    pm = _map_of(folder, patrol_map)
    cols = _number_columns(folder / "timeseries.csv",
                           ("time_s", "idleness_ins_s", "worst_idleness_s", "uncertainty_mean"))
    fig = new_figure(figsize=(9.5, 3.8))
    ax_t, ax_m = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.3, 1.0]})
    if len(cols["time_s"]):
        t = cols["time_s"]
        t = t - t[0] + (t[1] - t[0] if len(t) > 1 else 0.0)
        ax_t.plot(t, cols["idleness_ins_s"], lw=1, label="I_ins (mean)")
        ax_t.plot(t, cols["worst_idleness_s"], lw=1, label="worst")
        x = cols["uncertainty_mean"] if len(cols["uncertainty_mean"]) else \
            np.full(len(t), np.nan)
        if np.isfinite(x).any():
            ax_x = ax_t.twinx()
            ax_x.plot(t, x, lw=0.8, color="tab:green", alpha=0.7, label="X (mean)")
            ax_x.set_ylabel("X", color="tab:green")
            ax_x.tick_params(axis="y", labelcolor="tab:green")
        ax_t.legend(loc="upper left", fontsize=7)
    else:
        ax_t.text(0.5, 0.5, "no 1 Hz rows", ha="center", transform=ax_t.transAxes)
    ax_t.set_xlabel("run time [s]")
    ax_t.set_ylabel("idleness [s]")
    ax_t.grid(alpha=0.3)
    _draw_map(ax_m, pm)
    mean = _mean_interval_idleness(folder, len(pm.positions))
    xy = np.asarray(pm.positions)
    seen = np.isfinite(mean)
    size = max(12.0, min(60.0, 2500.0 / max(len(xy), 1)))
    if seen.any():
        sc = ax_m.scatter(xy[seen, 0], xy[seen, 1], c=mean[seen], cmap="viridis", s=size,
                          zorder=3, edgecolors="k", linewidths=0.4)
        fig.colorbar(sc, ax=ax_m, label="mean interval idleness [s]", shrink=0.85)
    if (~seen).any():
        ax_m.scatter(xy[~seen, 0], xy[~seen, 1], marker="x", color="red", s=size, zorder=3)
    s = summary or {}
    facts = [f"I_max {s['idleness_max_s']:.1f} s" if isinstance(s.get("idleness_max_s"), float)
             else "", f"X {s['uncertainty_mean']:.3g}"
             if isinstance(s.get("uncertainty_mean"), float) else ""]
    fig.suptitle(_title(folder) + ("  (" + ", ".join(f for f in facts if f) + ")"
                                   if any(facts) else ""), fontsize=10)
    ax_m.set_title("per vertex" + ("; x = fewer than 2 visits" if (~seen).any() else ""),
                   fontsize=8)
    # Fixed margins [figure fraction] instead of tight_layout (which draws the figure once more
    # to measure it: a third of the drawing time).
    fig.subplots_adjust(left=0.075, right=0.95, bottom=0.13, top=0.86, wspace=0.3)
    path = Path(path or folder / "summary.png")
    with atomic_file(path) as f:
        fig.savefig(f, dpi=80, format="png")
    return path


def write_summary_png(folder: Path, patrol_map=None, summary: dict | None = None) -> Path | None:
    """summary_png that never raises: a figure must not cost a run its results (a note instead)."""
    import sys

    try:
        return summary_png(folder, patrol_map, summary)
    except Exception as err:  # noqa: BLE001 - any plotting failure (missing matplotlib, odd map)
        print(f"note: no summary.png in {folder} ({type(err).__name__}: {err})", file=sys.stderr)
        return None



if __name__ == "__main__":
    import sys

    for p in run_figures(Path(sys.argv[1])):
        print(p)
