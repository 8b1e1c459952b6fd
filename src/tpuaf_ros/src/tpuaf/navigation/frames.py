"""A robot's planar pose from a stream of transforms (ROS-free; the agent feeds it /tf).

A tf2 listener per agent costs more than everything else together (ROS_PERFORMANCE.md), so the
agent keeps only the chain from its base frame (e.g. tb3_0/base_footprint) up to the global frame
(map): each transform whose child is on the chain is kept (its parent joins the chain), all others
(other robots, sensors) are skipped. Works with any localiser that publishes map -> odom (amcl,
cartographer, slam_toolbox) or map -> base directly. Frame ids without a leading '/'.
"""

from __future__ import annotations

import math


def compose(a: tuple[float, float, float], b: tuple[float, float, float]):
    """Planar pose a * b (x [m], y [m], yaw [rad])."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])


class FrameChain:
    """Pose of `base` in `root` from the latest transform of each link of the chain."""

    def __init__(self, root: str = "map", base: str = "base_footprint", max_links: int = 8):
        self.root = root.lstrip("/")
        self.base = base.lstrip("/")
        self.max_links = int(max_links)
        self.links: dict[str, tuple[str, tuple[float, float, float], float]] = {}  # child ->
        #   (parent, transform, stamp [s])
        self._on_chain = {self.base}

    def update(self, parent: str, child: str, x: float, y: float, yaw: float,
               stamp: float) -> bool:
        """Transform parent -> child; True when it is a link of our chain."""
        child = child.lstrip("/")
        if child not in self._on_chain or child == self.root:
            return False
        parent = parent.lstrip("/")
        self.links[child] = (parent, (float(x), float(y), float(yaw)), float(stamp))
        self._on_chain.add(parent)
        return True

    def pose(self) -> tuple[float, float, float, float] | None:
        """(x [m], y [m], yaw [rad], stamp [s]) of base in root, or None while the chain is
        incomplete; stamp = the oldest link's stamp (static links, stamp 0, excluded)."""
        frame, out, stamp = self.base, (0.0, 0.0, 0.0), math.inf
        for _ in range(self.max_links):
            if frame == self.root:
                yaw = (out[2] + math.pi) % (2.0 * math.pi) - math.pi
                return out[0], out[1], yaw, (stamp if math.isfinite(stamp) else 0.0)
            link = self.links.get(frame)
            if link is None:
                return None
            parent, tf, t = link
            out = compose(tf, out)
            if t > 0:
                stamp = min(stamp, t)
            frame = parent
        return None

    def missing(self) -> str:
        """The first frame of the chain without a parent yet (for the waiting message)."""
        frame = self.base
        for _ in range(self.max_links):
            if frame == self.root:
                return ""
            link = self.links.get(frame)
            if link is None:
                return frame
            frame = link[0]
        return frame


class StaticFrames:
    """The static transforms (/tf_static) heard so far, for the chains that need them: the
    robot's own chain and the laser's mounting on its base."""

    def __init__(self) -> None:
        self.links: dict[str, tuple[str, float, float, float]] = {}  # child -> (parent, x, y, yaw)

    def add(self, parent: str, child: str, x: float, y: float, yaw: float) -> None:
        self.links[child.lstrip("/")] = (parent, x, y, yaw)

    def feed(self, chain: FrameChain) -> None:
        """The static transforms into `chain`, in as many passes as links join it."""
        for _ in range(chain.max_links):
            before = len(chain.links)
            for child, (parent, x, y, yaw) in self.links.items():
                chain.update(parent, child, x, y, yaw, 0.0)
            if len(chain.links) == before:
                break

    def pose_in(self, base: str, frame: str) -> tuple[float, float, float, float] | None:
        """(x [m], y [m], yaw [rad], stamp) of `frame` in `base` from the static transforms,
        None while incomplete or when `frame` is `base` itself."""
        chain = FrameChain(base, frame)
        self.feed(chain)
        return chain.pose() if frame.lstrip("/") != base else None
