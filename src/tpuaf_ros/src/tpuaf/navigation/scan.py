"""Planar laser scans and their obstacle points: the one scan-to-points step of every runtime."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Scan:
    """A planar scan in the robot frame: beam k at angle_min + k * angle_increment [rad]."""

    ranges: np.ndarray  # [m]; 0, NaN, inf or > range_max = no return
    angle_min: float
    angle_increment: float
    range_min: float = 0.0
    range_max: float = math.inf


_TRIG_CACHE: dict[tuple[int, float, float], tuple[np.ndarray, np.ndarray]] = {}


def scan_points(scan: Scan) -> np.ndarray:
    """(k, 2) obstacle points [m] in the robot frame from the valid returns of `scan`."""
    r = np.asarray(scan.ranges, dtype=float)
    key = (len(r), float(scan.angle_min), float(scan.angle_increment))
    trig = _TRIG_CACHE.get(key)
    if trig is None:
        a = scan.angle_min + scan.angle_increment * np.arange(len(r))
        trig = (np.cos(a), np.sin(a))
        if len(_TRIG_CACHE) > 16:
            _TRIG_CACHE.clear()
        _TRIG_CACHE[key] = trig
    ok = (r > 0) & (r >= scan.range_min) & (r <= scan.range_max)  # NaN compares False
    return np.column_stack((r[ok] * trig[0][ok], r[ok] * trig[1][ok]))
