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

from tpuaf.files import atomic_file, atomic_path

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


# ------------------------------------------------------------------------------- trajectories


class Trajectories:
    """Robot positions [m] of a run at any time: positions.csv when the folder has one (time_s,
    robot, x, y; linear in between), else rebuilt from visits.csv for the graph runtime: between
    two visits a robot drives the shortest path at the nominal speed and arrives at the second
    visit's time (it waited at the first vertex before that). Exact for the graph runtime
    except after a mid-edge redirect (DTAG's change_goal), where the robot is shown on the
    shortest path instead of the detour. After its last visit a robot stays there."""

    def __init__(self, folder: Path, pm, n_robots: int, speed_mps: float):
        self.pm = pm
        self.n = int(n_robots)
        folder = Path(folder)
        self.source = "positions.csv" if (folder / "positions.csv").is_file() else "visits.csv"
        self.tracks: list[tuple[np.ndarray, np.ndarray]] = []  # per robot: times, (k, 2) points
        if self.source == "positions.csv":
            per: dict[int, list] = {}
            for r in _read_csv(folder / "positions.csv"):
                if r.get("x") in (None, "") or r.get("y") in (None, ""):
                    continue
                per.setdefault(int(r["robot"]), []).append(
                    (float(r["time_s"]), float(r["x"]), float(r["y"])))
            for i in range(self.n):
                a = np.array(sorted(per.get(i, [])), dtype=float).reshape(-1, 3)
                self.tracks.append((a[:, 0], a[:, 1:]))
            return
        visits: dict[int, list[tuple[float, int]]] = {}
        for r in _read_csv(folder / "visits.csv"):
            visits.setdefault(int(r["robot"]), []).append((float(r["time_s"]),
                                                           int(r["vertex_index"])))
        graph, xy = pm.graph, np.asarray(pm.positions, dtype=float)
        for i in range(self.n):
            vs = sorted(visits.get(i, []))
            times, points = [], []
            for (ta, va), (tb, vb) in zip(vs, vs[1:], strict=False):
                if not times:
                    times.append(ta)
                    points.append(xy[va])
                if va == vb:
                    times.append(tb)
                    points.append(xy[vb])
                    continue
                path = [int(v) for v in graph.path(va, vb)]
                seg = np.array([graph.edge_length(a, b) for a, b in zip(path, path[1:],
                                                                         strict=False)])
                travel = float(seg.sum()) / speed_mps
                depart = max(ta, tb - travel)
                scale = (tb - depart) / travel if travel > 0 else 0.0
                times.append(depart)
                points.append(xy[va])
                elapsed = depart
                for (_a, b), d in zip(zip(path, path[1:], strict=False), seg, strict=True):
                    elapsed += d / speed_mps * scale
                    times.append(elapsed)
                    points.append(xy[b])
                times[-1] = tb
            if not times and vs:
                times, points = [vs[0][0]], [xy[vs[0][1]]]
            self.tracks.append((np.array(times, dtype=float),
                                np.array(points, dtype=float).reshape(-1, 2)))

    def at(self, t: float) -> np.ndarray:
        """(n_robots, 2) positions at time t [s]; NaN for a robot never seen."""
        out = np.full((self.n, 2), np.nan)
        for i, (times, points) in enumerate(self.tracks):
            if not len(times):
                continue
            out[i, 0] = np.interp(t, times, points[:, 0])
            out[i, 1] = np.interp(t, times, points[:, 1])
        return out


# ------------------------------------------------------------------------------- animation


def _run_facts(folder: Path) -> dict:
    """n_robots, start and end time [s], speed, strategy, deaths of a results folder."""
    folder = Path(folder)
    config = yaml.safe_load((folder / "config.yaml").read_text()) or {}
    summary = {}
    if (folder / "summary.json").is_file():
        import json

        summary = json.loads((folder / "summary.json").read_text())
    rows = _read_csv(folder / "timeseries.csv")
    # Run-time files (summary `time_base`) start at 0; older ones hold ROS time from start_time_s.
    start = 0.0 if summary.get("time_base") else float(summary.get("start_time_s") or 0.0)
    if summary.get("duration_s") is not None:
        end = start + float(summary["duration_s"])
    elif rows:
        end = float(rows[-1]["time_s"])
    else:
        end = start
    n = summary.get("n_robots") or config.get("robots") or config.get("n_robots")
    settings = config.get("map_settings") or {}
    return {"config": config, "summary": summary, "rows": rows, "start": start, "end": end,
            "n_robots": int(n) if n else None, "speed": settings.get("nominal_speed"),
            "deaths": [(float(f.get("time_s", 0.0)), int(f["robot"]))
                       for f in (summary.get("faults") or [])
                       if isinstance(f, dict) and "robot" in f and f.get("kind", "death")
                       in ("death", "fail")]}


def frame_times(start: float, end: float, frames: int | None = None,
                step_s: float | None = None) -> np.ndarray:
    """The frame times [s]: `frames` evenly from start to end, or every `step_s` from start."""
    if step_s is not None:
        k = int(math.floor((end - start) / step_s + 1e-9)) + 1
        return start + step_s * np.arange(k)
    frames = int(frames or 200)
    return np.linspace(start, end, frames) if frames > 1 else np.array([end])


def _without_dead(p: np.ndarray, deaths, t: float) -> np.ndarray:
    q = p.copy()
    for td, r in deaths:
        if td <= t and 0 <= r < len(q):
            q[r] = np.nan
    return q


def render(folder: Path, out: Path | None = None, *, frames: int | None = None,
           step_s: float | None = None, fps: float = 10.0, color: str = "idleness",
           dpi: int = 80, patrol_map=None) -> tuple[Path, int]:
    """An animation of the robots over the map, vertices coloured by idleness [s] (time since
    the last visit, from visits.csv) or by X (the ground-truth field of tpuaf_core, advanced
    along the frames' positions). GIF through Pillow, or MP4 when `out` ends in .mp4
    (matplotlib's ffmpeg writer). Returns (path, frame count)."""
    folder = Path(folder)
    facts = _run_facts(folder)
    pm = _map_of(folder, patrol_map)
    n = facts["n_robots"]
    if not n:
        raise ValueError(f"{folder}: the team size is in neither summary.json nor config.yaml")
    speed = float(facts["speed"] or pm.settings.nominal_speed)
    traj = Trajectories(folder, pm, n, speed)
    times = frame_times(facts["start"], facts["end"], frames, step_s)
    out = Path(out) if out is not None else folder / "animation.gif"
    if out.suffix.lower() not in (".gif", ".mp4"):
        raise ValueError(f"{out}: the animation is a .gif or an .mp4 file")

    nv = len(pm.positions)
    xy = np.asarray(pm.positions, dtype=float)
    visits = sorted((float(r["time_s"]), int(r["vertex_index"]))
                    for r in _read_csv(folder / "visits.csv"))
    vt = np.array([t for t, _ in visits])
    vv = np.array([v for _, v in visits], dtype=int)

    def idleness(t: float) -> np.ndarray:
        last = np.full(nv, facts["start"])
        k = int(np.searchsorted(vt, t, side="right"))
        if k:
            np.maximum.at(last, vv[:k], vt[:k])
        return t - last

    field = None
    if color == "uncertainty":
        import tpuaf_core

        s = pm.settings
        field = tpuaf_core.UncertaintyField(
            xy, np.asarray(pm.importance, dtype=float),
            np.asarray(pm.initial_uncertainty, dtype=float), pm.uncertainty_model())
        peaks = np.full(n, float(s.sensing_peak))
        radii = np.full(n, float(s.sensing_radius))
    elif color != "idleness":
        raise ValueError(f"colour '{color}': expected idleness or uncertainty")

    if color == "idleness":
        vmax = max(float(idleness(times[-1]).max()), 1.0)
        for t in times[:: max(1, len(times) // 20)]:
            vmax = max(vmax, float(idleness(t).max()))
        clabel = "idleness [s]"
    else:
        clabel = "X (ground truth)"
        vmax = None

    rows, cols = map_background(pm).occupied.shape
    aspect = rows / max(cols, 1)
    fig = new_figure(figsize=(6.0, max(2.5, 4.8 * aspect) + 0.4))
    ax = fig.subplots()
    _draw_map(ax, pm)
    size = max(12.0, min(70.0, 3000.0 / max(nv, 1)))
    verts = ax.scatter(xy[:, 0], xy[:, 1], c=np.zeros(nv), cmap="inferno_r", vmin=0,
                       vmax=vmax or 1.0, s=size, zorder=3, edgecolors="k", linewidths=0.4)
    fig.colorbar(verts, ax=ax, label=clabel, shrink=0.8)
    # robots: blue squares with their index (the vertex colours run yellow -> black)
    robots = ax.scatter(np.zeros(n), np.zeros(n), s=size * 2.2, marker="s", c="deepskyblue",
                        edgecolors="black", linewidths=1.0, zorder=5)
    labels = [ax.text(0, 0, str(i), fontsize=6, ha="center", va="center", zorder=6)
              for i in range(n)]
    title = ax.set_title("", fontsize=9)
    name = _title(folder)
    fig.tight_layout()
    deaths = facts["deaths"]
    step = float(times[1] - times[0]) if len(times) > 1 else 1.0
    decimals = 0 if step >= 1 else 1 if step >= 0.1 else 2  # consecutive frames differ

    def frame_rgb(k: int, t: float, prev_t: float, prev_p: np.ndarray | None):
        p = traj.at(t)
        alive = np.array([not any(r == i and td <= t for td, r in deaths) for i in range(n)])
        if field is not None:
            q = p.copy()
            q[~alive] = np.nan
            if prev_p is not None and t > prev_t:
                live = ~(np.isnan(prev_p[:, 0]) | np.isnan(q[:, 0]))
                k_live = int(live.sum())
                # Eq. 1-2 along the straight chord between frames (0.25 s substeps)
                field.advance_linear(t - prev_t, prev_p[live], q[live], peaks[:k_live],
                                     radii[:k_live], 0.25)
            values = np.asarray(field.values, dtype=float)
            verts.set_clim(0, max(float(values.max()), 1e-9))
        else:
            values = idleness(t)
        verts.set_array(values)
        robots.set_offsets(np.nan_to_num(p, nan=-1e9))
        robots.set_facecolors(["deepskyblue" if a else "0.5" for a in alive])  # grey = dead
        for i, text in enumerate(labels):
            text.set_position((p[i, 0], p[i, 1]) if np.isfinite(p[i]).all() else (-1e9, -1e9))
        title.set_text(f"{name}   t = {t - facts['start']:.{decimals}f} s   "
                       f"mean {'idleness' if field is None else 'X'} {values.mean():.3g}")
        fig.canvas.draw()
        rgba = np.asarray(fig.canvas.buffer_rgba())
        return rgba[:, :, :3].copy(), p

    fig.set_dpi(dpi)
    images = []
    prev_t, prev_p = times[0], None
    writer = None
    if out.suffix.lower() == ".mp4":
        import shutil

        from matplotlib import animation

        if not shutil.which("ffmpeg"):
            raise ValueError("an .mp4 needs ffmpeg on the PATH; write a .gif instead")
        writer = animation.FFMpegWriter(fps=fps)
        with atomic_path(out, out.suffix) as tmp:  # ffmpeg picks the format by the name
            with writer.saving(fig, str(tmp), dpi):
                for k, t in enumerate(times):
                    _, p = frame_rgb(k, float(t), prev_t, prev_p)
                    prev_p = _without_dead(p, deaths, float(t))
                    prev_t = float(t)
                    writer.grab_frame()
        return out, len(times)
    from PIL import Image

    for k, t in enumerate(times):
        rgb, p = frame_rgb(k, float(t), prev_t, prev_p)
        prev_p = _without_dead(p, deaths, float(t))
        prev_t = float(t)
        images.append(Image.fromarray(rgb).quantize(colors=128, method=Image.Quantize.MEDIANCUT))
    with atomic_file(out) as f:
        images[0].save(f, format="GIF", save_all=True, append_images=images[1:],
                       duration=max(20, int(round(1000.0 / fps))), loop=0, optimize=False,
                       disposal=1)
    return out, len(images)


if __name__ == "__main__":
    import sys

    for p in run_figures(Path(sys.argv[1])):
        print(p)
