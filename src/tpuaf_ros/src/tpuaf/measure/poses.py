"""Robot positions from localisation streams (ROS-free), for the monitor node and bag analysis.

- `robot_chains` / `feed_chains`: every robot's tf chain map -> <robot>/base_footprint (the
  agents' own `tpuaf.navigation.frames.FrameChain`, one per robot).
- `PoseSampler`: per-robot pose streams at their own stamps (tf, odom, amcl_pose: robots are
  not stamped alike) -> pose groups at common tick times, as `FleetMonitor.on_pose` expects.
  A tick's position of a robot is its latest pose stamped at or before the tick (sample and
  hold); a tick is emitted once every robot has a pose and `lag_s` of newer data arrived.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterator

import numpy as np

# Localisation sources, best first, with what their X is worth (shown in the analysis notes).
POSE_SOURCES = {
    "ground_truth": "ground truth (exact)",
    "tf": "tf map -> <robot>/base_footprint (the localiser's estimate: X as good as it)",
    "amcl": "amcl_pose (localiser estimate, published on change only: positions held between "
            "updates)",
    "odom": "odom (dead reckoning, taken as the map frame: drift makes X approximate)",
}


def yaw_from_quaternion(x: float, y: float, z: float, w: float) -> float:
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def robot_chains(names: list[str], root: str = "map", base: str = "base_footprint") -> list:
    """One tf chain root -> <name>/<base> per robot (tpuaf.navigation.frames.FrameChain, as the agents')."""
    from tpuaf.navigation.frames import FrameChain

    return [FrameChain(root, f"{name}/{base}") for name in names]


def chain_pose(chain) -> tuple[float, float, float] | None:
    """(x m, y m, stamp s) of a chain's base in its root, stamped by the base's own link (the
    moving one: a localiser's map -> odom may be older), or None while incomplete."""
    pose = chain.pose()
    if pose is None:
        return None
    link = chain.links.get(chain.base)
    return pose[0], pose[1], (link[2] if link else pose[3])


def feed_chains(chains: list, transforms) -> list[int]:
    """Feed tf transforms (geometry_msgs/TransformStamped-like: header.frame_id, child_frame_id,
    transform.translation/rotation) to every chain; the robots whose chain they touched."""
    touched = set()
    for tr in transforms:
        t, q = tr.transform.translation, tr.transform.rotation
        yaw = yaw_from_quaternion(q.x, q.y, q.z, q.w)
        st = tr.header.stamp
        stamp = st.to_sec() if hasattr(st, "to_sec") else st.sec + st.nanosec * 1e-9
        for r, chain in enumerate(chains):
            if chain.update(tr.header.frame_id, tr.child_frame_id, t.x, t.y, yaw, stamp):
                touched.add(r)
    return sorted(touched)


class PoseSampler:
    """Pose groups at ticks k * period_s [s] from per-robot poses at arbitrary stamps."""

    def __init__(self, n_robots: int, period_s: float = 0.1, lag_s: float = 0.5):
        if not period_s > 0:
            raise ValueError(f"period_s must be > 0, got {period_s}")
        self.n = int(n_robots)
        self.period_s = float(period_s)
        self.lag_s = float(lag_s)
        self._held: list[tuple[float, float, float] | None] = [None] * self.n  # at last tick
        self._queue: list[deque] = [deque() for _ in range(self.n)]  # newer poses, time order
        self._newest = -math.inf
        self._last_tick = -math.inf

    def add(self, robot: int, t: float, x: float, y: float) -> None:
        if not 0 <= robot < self.n or not (math.isfinite(t) and math.isfinite(x)
                                           and math.isfinite(y)):
            return
        if t <= self._last_tick:
            return  # its tick is out: too late
        q = self._queue[robot]
        q.append((float(t), float(x), float(y)))
        if len(q) > 1 and q[-2][0] > t:
            self._queue[robot] = deque(sorted(q))
        self._newest = max(self._newest, float(t))

    def _tick_at_or_after(self, t: float) -> float:
        return math.ceil(t / self.period_s - 1e-9) * self.period_s

    def ticks(self, flush: bool = False) -> Iterator[tuple[float, np.ndarray]]:
        """(tick time, positions (n, 2)) of the ticks now complete, in time order. Only ticks
        with new poses are emitted (a silent stretch is one linear step for the recorder), so
        a stamp far ahead cannot flood the output."""
        limit = self._newest if flush else self._newest - self.lag_s
        while any(self._queue):
            if self._last_tick == -math.inf:  # the first tick: every robot has a pose
                if not all(self._queue):
                    return
                tick = self._tick_at_or_after(max(q[0][0] for q in self._queue))
            else:
                tick = self._tick_at_or_after(min(q[0][0] for q in self._queue if q))
                tick = max(tick, self._last_tick + self.period_s)
            if tick > limit:
                return
            positions = np.empty((self.n, 2))
            for r, q in enumerate(self._queue):
                while q and q[0][0] <= tick:
                    self._held[r] = q.popleft()
                positions[r] = self._held[r][1:]
            self._last_tick = tick
            yield tick, positions


class MonitorFeed:
    """Poses into a FleetMonitor (tpuaf.measure.monitor), as the live monitor node and bag analysis
    feed it: ground truth as stamped (all robots stamped alike), any other source grouped on
    ticks by a PoseSampler. `close()` brings the monitor to the last poses: it processes pose
    groups `lag_s` behind the newest, so one more group that much later (every robot where it
    was last seen) is given."""

    def __init__(self, monitor, grouped: bool):
        self.monitor = monitor
        self.n = monitor.n
        self.sampler = PoseSampler(self.n) if grouped else None
        self._last: list[tuple[float, float] | None] = [None] * self.n
        self._newest = -math.inf

    def _feed(self, robot: int, t: float, x: float, y: float) -> None:
        self.monitor.on_pose(robot, t, x, y)
        self._last[robot] = (x, y)
        self._newest = max(self._newest, t)

    def add(self, robot: int, t: float, x: float, y: float) -> None:
        if not (math.isfinite(t) and math.isfinite(x) and math.isfinite(y)):
            return
        if self.sampler is None:
            self._feed(robot, t, x, y)
            return
        self.sampler.add(robot, t, x, y)
        self._ticks()

    def _ticks(self, flush: bool = False) -> None:
        for tick, positions in self.sampler.ticks(flush):
            for r in range(self.n):
                self._feed(r, tick, float(positions[r, 0]), float(positions[r, 1]))

    def close(self) -> None:
        if self.monitor.finished:
            return
        if self.sampler is not None:
            self._ticks(flush=True)
        if not self.monitor.finished and all(p is not None for p in self._last):
            t = self._newest + self.monitor.lag_s + 1e-3
            for r, (x, y) in enumerate(self._last):
                self.monitor.on_pose(r, t, x, y)
            self.monitor.drain()  # the groups a live monitor held for late events
