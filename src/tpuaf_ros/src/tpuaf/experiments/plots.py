"""Per-run figures of a results folder (batch or fleet): idleness over time, and each vertex's
idleness drawn on the map image. Headless (Agg). Inputs: the folder's timeseries.csv,
visits.csv and config.yaml (the map); outputs PNG files in the folder (or `out`).

    tpuaf.experiments.plots.run_figures(folder)  ->  [idleness_over_time.png, vertex_idleness_map.png]
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import yaml

from tpuaf.files import atomic_file, atomic_path


def headless_pyplot():
    """matplotlib.pyplot on the headless Agg backend. Debian's mpl_toolkits beside the venv's
    matplotlib makes it warn about 3-D axes; no figure here uses them."""
    import warnings

    import matplotlib

    matplotlib.use("Agg")
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Unable to import Axes3D")
        warnings.filterwarnings("ignore", message="Importing matplotlib.tri.triangulation")
        import matplotlib.pyplot as plt
    return plt


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
    plt = headless_pyplot()
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
    from tpuaf.maps import load_map

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
    plt = headless_pyplot()
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


# ------------------------------------------------------------------------------- summary.png
# One small PNG per results folder, written by ResultsWriter.finish (before summary.json):
# idleness over time (and X) beside each vertex's mean interval idleness on the map image.


def _map_of(folder: Path, patrol_map=None):
    if patrol_map is not None:
        return patrol_map
    from tpuaf.maps import load_map

    config = yaml.safe_load((Path(folder) / "config.yaml").read_text()) or {}
    source = config.get("map_source")
    return load_map(source if source and source != "built-in" else config["map"])


def _draw_map(ax, pm) -> None:
    """The occupancy image (free = white) and the graph's edges, in map metres."""
    grid = pm.occupancy_grid()
    x0, y0 = grid.origin
    extent = (x0, x0 + grid.width * grid.resolution, y0, y0 + grid.height * grid.resolution)
    ax.imshow(np.where(grid.occupied, 0.3, 1.0), cmap="gray", vmin=0, vmax=1, origin="lower",
              extent=extent, interpolation="nearest")
    for a, b, *_ in pm.edges:
        pa, pb = pm.positions[a], pm.positions[b]
        ax.plot([pa[0], pb[0]], [pa[1], pb[1]], color="0.75", lw=0.8, zorder=1)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])


def _mean_interval_idleness(folder: Path, n: int) -> np.ndarray:
    sums, counts = np.zeros(n), np.zeros(n)
    for r in _read_csv(Path(folder) / "visits.csv"):
        if r.get("interval_idleness_s"):
            v = int(r["vertex_index"])
            sums[v] += float(r["interval_idleness_s"])
            counts[v] += 1
    return np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)


def summary_png(folder: Path, patrol_map=None, summary: dict | None = None,
                path: Path | None = None) -> Path:
    """summary.png of a results folder (timeseries.csv, visits.csv, config.yaml); atomic."""
    folder = Path(folder)
    pm = _map_of(folder, patrol_map)
    rows = _read_csv(folder / "timeseries.csv")
    plt = headless_pyplot()
    fig, (ax_t, ax_m) = plt.subplots(1, 2, figsize=(9.5, 3.8),
                                     gridspec_kw={"width_ratios": [1.3, 1.0]})
    if rows:
        t = np.array([float(r["time_s"]) for r in rows])
        t = t - t[0] + (t[1] - t[0] if len(t) > 1 else 0.0)
        ax_t.plot(t, [float(r["idleness_ins_s"]) for r in rows], lw=1, label="I_ins (mean)")
        ax_t.plot(t, [float(r["worst_idleness_s"]) for r in rows], lw=1, label="worst")
        x = np.array([float(r["uncertainty_mean"]) if r.get("uncertainty_mean") else np.nan
                      for r in rows])
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
    fig.tight_layout()
    path = Path(path or folder / "summary.png")
    with atomic_file(path) as f:
        fig.savefig(f, dpi=80, format="png")
    plt.close(fig)
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
    start = float(summary.get("start_time_s") or 0.0)
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

    plt = headless_pyplot()
    grid = pm.occupancy_grid()
    aspect = grid.height / max(grid.width, 1)
    fig, ax = plt.subplots(figsize=(6.0, max(2.5, 4.8 * aspect) + 0.4))
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
            plt.close(fig)
            raise ValueError("an .mp4 needs ffmpeg on the PATH; write a .gif instead")
        writer = animation.FFMpegWriter(fps=fps)
        with atomic_path(out, out.suffix) as tmp:  # ffmpeg picks the format by the name
            with writer.saving(fig, str(tmp), dpi):
                for k, t in enumerate(times):
                    _, p = frame_rgb(k, float(t), prev_t, prev_p)
                    prev_p = _without_dead(p, deaths, float(t))
                    prev_t = float(t)
                    writer.grab_frame()
            plt.close(fig)
        return out, len(times)
    from PIL import Image

    for k, t in enumerate(times):
        rgb, p = frame_rgb(k, float(t), prev_t, prev_p)
        prev_p = _without_dead(p, deaths, float(t))
        prev_t = float(t)
        images.append(Image.fromarray(rgb).quantize(colors=128, method=Image.Quantize.MEDIANCUT))
    plt.close(fig)
    with atomic_file(out) as f:
        images[0].save(f, format="GIF", save_all=True, append_images=images[1:],
                       duration=max(20, int(round(1000.0 / fps))), loop=0, optimize=False,
                       disposal=1)
    return out, len(images)


if __name__ == "__main__":
    import sys

    for p in run_figures(Path(sys.argv[1])):
        print(p)
