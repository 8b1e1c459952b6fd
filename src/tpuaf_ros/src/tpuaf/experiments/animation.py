"""Animations of a results folder (`tpuaf render`): robot trajectories from positions.csv or
rebuilt from visits.csv (`Trajectories`), drawn over the map with the vertices coloured by
idleness or by the ground-truth X; GIF through Pillow or MP4 through ffmpeg."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml

from tpuaf.experiments.plots import (
    _draw_map,
    _map_of,
    _read_csv,
    _title,
    map_background,
    new_figure,
)
from tpuaf.files import atomic_file, atomic_path

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


class _VertexColours:
    """Each frame's vertex values: idleness [s] (time since the last visit, from visits.csv) or
    X (the ground-truth field of tpuaf_core, Eq. 1-2, advanced along the frames' positions)."""

    def __init__(self, folder: Path, pm, facts: dict, n: int, color: str, times: np.ndarray):
        if color not in ("idleness", "uncertainty"):
            raise ValueError(f"colour '{color}': expected idleness or uncertainty")
        self.start = facts["start"]
        self.nv = len(pm.positions)
        visits = sorted((float(r["time_s"]), int(r["vertex_index"]))
                        for r in _read_csv(folder / "visits.csv"))
        self.vt = np.array([t for t, _ in visits])
        self.vv = np.array([v for _, v in visits], dtype=int)
        self.field = None
        if color == "uncertainty":
            import tpuaf_core

            s = pm.settings
            self.field = tpuaf_core.UncertaintyField(
                np.asarray(pm.positions, dtype=float), np.asarray(pm.importance, dtype=float),
                np.asarray(pm.initial_uncertainty, dtype=float), pm.uncertainty_model())
            self.peaks = np.full(n, float(s.sensing_peak))
            self.radii = np.full(n, float(s.sensing_radius))
            self.label, self.vmax = "X (ground truth)", None
        else:
            vmax = max(float(self.idleness(times[-1]).max()), 1.0)
            for t in times[:: max(1, len(times) // 20)]:
                vmax = max(vmax, float(self.idleness(t).max()))
            self.label, self.vmax = "idleness [s]", vmax

    def idleness(self, t: float) -> np.ndarray:
        last = np.full(self.nv, self.start)
        k = int(np.searchsorted(self.vt, t, side="right"))
        if k:
            np.maximum.at(last, self.vv[:k], self.vt[:k])
        return t - last

    def at(self, t: float, prev_t: float, prev_p: np.ndarray | None, p: np.ndarray):
        """Values at t; X advances from the previous frame's positions prev_p to p (NaN: dead)."""
        if self.field is None:
            return self.idleness(t)
        if prev_p is not None and t > prev_t:
            live = ~(np.isnan(prev_p[:, 0]) | np.isnan(p[:, 0]))
            k_live = int(live.sum())
            # Eq. 1-2 along the straight chord between frames (0.25 s substeps)
            self.field.advance_linear(t - prev_t, prev_p[live], p[live], self.peaks[:k_live],
                                      self.radii[:k_live], 0.25)
        return np.asarray(self.field.values, dtype=float)


class _AnimationFigure:
    """The figure of one animation: the map, vertices coloured by value, robots as numbered
    squares (grey when dead), a title with the time and the mean value."""

    def __init__(self, folder: Path, pm, n: int, colours: _VertexColours, times: np.ndarray,
                 start: float):
        xy = np.asarray(pm.positions, dtype=float)
        nv = len(xy)
        rows, cols = map_background(pm).occupied.shape
        self.fig = new_figure(figsize=(6.0, max(2.5, 4.8 * rows / max(cols, 1)) + 0.4))
        ax = self.fig.subplots()
        _draw_map(ax, pm)
        size = max(12.0, min(70.0, 3000.0 / max(nv, 1)))
        self.verts = ax.scatter(xy[:, 0], xy[:, 1], c=np.zeros(nv), cmap="inferno_r", vmin=0,
                                vmax=colours.vmax or 1.0, s=size, zorder=3, edgecolors="k",
                                linewidths=0.4)
        self.fig.colorbar(self.verts, ax=ax, label=colours.label, shrink=0.8)
        # robots: blue squares with their index (the vertex colours run yellow -> black)
        self.robots = ax.scatter(np.zeros(n), np.zeros(n), s=size * 2.2, marker="s",
                                 c="deepskyblue", edgecolors="black", linewidths=1.0, zorder=5)
        self.labels = [ax.text(0, 0, str(i), fontsize=6, ha="center", va="center", zorder=6)
                       for i in range(n)]
        self.title = ax.set_title("", fontsize=9)
        self.name = _title(folder)
        self.what = "idleness" if colours.field is None else "X"
        self.rescale = colours.field is not None
        self.start = start
        self.fig.tight_layout()
        step = float(times[1] - times[0]) if len(times) > 1 else 1.0
        self.decimals = 0 if step >= 1 else 1 if step >= 0.1 else 2  # consecutive frames differ

    def draw(self, t: float, p: np.ndarray, alive: np.ndarray, values: np.ndarray) -> np.ndarray:
        """Draws one frame; returns its RGB pixels."""
        if self.rescale:
            self.verts.set_clim(0, max(float(values.max()), 1e-9))
        self.verts.set_array(values)
        self.robots.set_offsets(np.nan_to_num(p, nan=-1e9))
        self.robots.set_facecolors(["deepskyblue" if a else "0.5" for a in alive])
        for i, text in enumerate(self.labels):
            text.set_position((p[i, 0], p[i, 1]) if np.isfinite(p[i]).all() else (-1e9, -1e9))
        self.title.set_text(f"{self.name}   t = {t - self.start:.{self.decimals}f} s   "
                            f"mean {self.what} {values.mean():.3g}")
        self.fig.canvas.draw()
        return np.asarray(self.fig.canvas.buffer_rgba())[:, :, :3].copy()


def _frames(figure: _AnimationFigure, colours: _VertexColours, traj: Trajectories,
            times: np.ndarray, deaths: list):
    """Yields each frame's RGB pixels in time order."""
    n = traj.n
    prev_t, prev_p = float(times[0]), None
    for t in (float(t) for t in times):
        p = traj.at(t)
        alive = np.array([not any(r == i and td <= t for td, r in deaths) for i in range(n)])
        q = p.copy()
        q[~alive] = np.nan
        values = colours.at(t, prev_t, prev_p, q)
        yield figure.draw(t, p, alive, values)
        prev_p, prev_t = _without_dead(p, deaths, t), t


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
    traj = Trajectories(folder, pm, n, float(facts["speed"] or pm.settings.nominal_speed))
    times = frame_times(facts["start"], facts["end"], frames, step_s)
    out = Path(out) if out is not None else folder / "animation.gif"
    if out.suffix.lower() not in (".gif", ".mp4"):
        raise ValueError(f"{out}: the animation is a .gif or an .mp4 file")
    colours = _VertexColours(folder, pm, facts, n, color, times)
    figure = _AnimationFigure(folder, pm, n, colours, times, facts["start"])
    figure.fig.set_dpi(dpi)
    pictures = _frames(figure, colours, traj, times, facts["deaths"])
    if out.suffix.lower() == ".mp4":
        return out, _write_mp4(out, figure.fig, pictures, fps, dpi)
    return out, _write_gif(out, pictures, fps)


def _write_mp4(out: Path, fig, pictures, fps: float, dpi: int) -> int:
    import shutil

    from matplotlib import animation

    if not shutil.which("ffmpeg"):
        raise ValueError("an .mp4 needs ffmpeg on the PATH; write a .gif instead")
    writer = animation.FFMpegWriter(fps=fps)
    count = 0
    with atomic_path(out, out.suffix) as tmp:  # ffmpeg picks the format by the name
        with writer.saving(fig, str(tmp), dpi):
            for _ in pictures:
                writer.grab_frame()
                count += 1
    return count


def _write_gif(out: Path, pictures, fps: float) -> int:
    from PIL import Image

    images = [Image.fromarray(rgb).quantize(colors=128, method=Image.Quantize.MEDIANCUT)
              for rgb in pictures]
    with atomic_file(out) as f:
        images[0].save(f, format="GIF", save_all=True, append_images=images[1:],
                       duration=max(20, int(round(1000.0 / fps))), loop=0, optimize=False,
                       disposal=1)
    return len(images)
