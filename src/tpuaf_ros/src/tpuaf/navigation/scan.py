"""Planar laser scans and their obstacle points: the one scan-to-points step of every runtime.

The physics runtime (all robots at once) and the agent node (one scan message) both call
`scan_points_batch`: the scan is subsampled to at most `max_beams` beams, invalid returns are
dropped, and the points are given in the robot's base frame (the laser's mounting applied),
optionally only those within `within_m` of the base (what the controller can use).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tpuaf.params import CONTROLLER_DEFAULTS

DEFAULT_SCAN_BEAMS = CONTROLLER_DEFAULTS.scan_beams  # beams the controller uses at most


@dataclass(frozen=True)
class Scan:
    """A planar scan in the laser frame: beam k at angle_min + k * angle_increment [rad]."""

    ranges: np.ndarray  # [m]; 0, NaN, inf or > range_max = no return
    angle_min: float
    angle_increment: float
    range_min: float = 0.0
    range_max: float = math.inf


@dataclass(frozen=True)
class LaserMount:
    """Pose of the laser frame in the robot's base frame [m, m, rad]."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0


_TRIG_CACHE: dict[tuple[int, float, float, float], tuple[np.ndarray, np.ndarray]] = {}


def _trig(n: int, first: float, increment: float, yaw: float) -> tuple[np.ndarray, np.ndarray]:
    key = (n, float(first), float(increment), float(yaw))
    trig = _TRIG_CACHE.get(key)
    if trig is None:
        a = first + increment * np.arange(n) + yaw
        trig = (np.cos(a), np.sin(a))
        if len(_TRIG_CACHE) > 16:
            _TRIG_CACHE.clear()
        _TRIG_CACHE[key] = trig
    return trig


def beam_step(n_beams: int, max_beams: int) -> int:
    """Every how many beams one is kept so that at most `max_beams` remain (ceil)."""
    return max(1, -(-int(n_beams) // max(1, int(max_beams))))


def scan_points_batch(ranges: np.ndarray, angle_min: float, angle_increment: float,
                      range_min: float = 0.0, range_max: float = math.inf,
                      mount: LaserMount = LaserMount(), max_beams: int = DEFAULT_SCAN_BEAMS,
                      within_m: float = math.inf) -> list[np.ndarray]:
    """Per row of `ranges` (robots x beams, [m]): the (k, 2) obstacle points [m] in the base
    frame, in beam order, from the valid returns of the subsampled scan within `within_m`."""
    r = np.atleast_2d(np.asarray(ranges, dtype=float))
    step = beam_step(r.shape[1], max_beams)
    if step > 1:
        r = r[:, ::step]
    c, s = _trig(r.shape[1], angle_min, angle_increment * step, mount.yaw)
    # [m] of range beyond which no point can lie within within_m of the base
    near = within_m + math.hypot(mount.x, mount.y)
    ok = (r > 0) & (r >= range_min) & (r <= range_max) & (r < near)  # NaN compares False
    rows, cols = np.nonzero(ok)
    rr = r[rows, cols]
    xs = rr * c[cols] + mount.x
    ys = rr * s[cols] + mount.y
    if math.isfinite(within_m):
        keep = xs * xs + ys * ys < within_m * within_m
        rows, xs, ys = rows[keep], xs[keep], ys[keep]
    points = np.column_stack((xs, ys))
    counts = np.bincount(rows, minlength=len(r))
    return np.split(points, np.cumsum(counts)[:-1])


def scan_points(scan: Scan, mount: LaserMount = LaserMount(),
                max_beams: int = DEFAULT_SCAN_BEAMS, within_m: float = math.inf) -> np.ndarray:
    """(k, 2) obstacle points [m] in the base frame from one scan (see scan_points_batch)."""
    return scan_points_batch(scan.ranges, scan.angle_min, scan.angle_increment, scan.range_min,
                             scan.range_max, mount, max_beams, within_m)[0]


def moved_points(points: np.ndarray | None, scan_pose: tuple[float, float, float],
                 pose: tuple[float, float, float]) -> np.ndarray | None:
    """Points (k, 2) [m] measured in the base frame at `scan_pose`, in the base frame at `pose`
    (map-frame poses x, y [m], yaw [rad]): a scan older than the pose, motion-compensated."""
    if points is None or len(points) == 0 or tuple(scan_pose) == tuple(pose):
        return points
    xs, ys, ts = scan_pose
    x, y, th = pose
    d = ts - th
    c, s = math.cos(d), math.sin(d)
    # offset of the scan pose seen from the current pose, in the current base frame
    cth, sth = math.cos(th), math.sin(th)
    ox = cth * (xs - x) + sth * (ys - y)
    oy = -sth * (xs - x) + cth * (ys - y)
    px, py = points[:, 0], points[:, 1]
    return np.column_stack((ox + c * px - s * py, oy + s * px + c * py))
