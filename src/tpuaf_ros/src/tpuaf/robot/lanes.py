"""A robot's lane layer: the map's lanes (navigation/lanes.py) with its lock table
(team/lane_locks.py), as its navigator asks for them (docs/LANES.md).

The navigator asks `may_start(u, v, now)` before every leg u -> v that starts at a vertex and
`arrive(u, now)` at a route's goal: reaching a vertex outside the held lane (a waiting spot)
releases it; a leg into a lane not held asks for the lane and waits at u until it is granted.
With one-way lanes (navigation/one_way.py) only the lanes that stay two-way (`locked`: the
bridges) are locked; a one-way lane is entered without a lock (robots in it only follow), and
the robot whose leg drives it holds it off its route too (`driven`, `allowed`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from tpuaf.navigation.lanes import LaneMap, find_lanes
from tpuaf.navigation.one_way import Orientation, orient_lanes
from tpuaf.team.lane_locks import LaneLocks
from tpuaf.team.messages import LaneClaim
from tpuaf.topics import LANE_ENTER, LANE_WAIT


@dataclass(frozen=True)
class LaneLayer:
    """The team's lanes on one map and footprint: the lane map, the one-way orientation (None:
    locks only) and the plan's map, whose graph follows the one-way arcs."""

    lane_map: LaneMap
    orientation: Orientation | None
    plan_map: Any

    @property
    def locked(self) -> frozenset[int] | None:
        """The lanes entered holding a lock (None: all)."""
        return self.orientation.locked if self.orientation is not None else None

    @property
    def one_way_count(self) -> int:
        """The lanes driven one way."""
        return len(self.orientation.chains) if self.orientation is not None else 0

    def describe(self) -> str:
        """'K lane(s)[, M one-way]'."""
        one_way = f", {self.one_way_count} one-way" if self.orientation is not None else ""
        return f"{len(self.lane_map.lanes)} lane(s){one_way}"


def lane_layer(planner: Any, world_map: Any, plan_map: Any, one_way: bool) -> LaneLayer | None:
    """The lane layer of every runtime (physics, ROS agents): the lanes of `world_map` for the
    footprint of `planner`, oriented when `one_way`; None when the map has no lane (the run is
    then the run without the layer). Every robot of one model computes the same lanes (their
    indices are shared in LaneClaim)."""
    lane_map = find_lanes(planner, world_map)
    if not lane_map.lanes:
        return None
    orientation = orient_lanes(lane_map, plan_map) if one_way else None
    if orientation is not None and orientation.chains:
        plan_map = replace(plan_map, one_way=tuple(orientation.arcs))
    return LaneLayer(lane_map, orientation, plan_map)


class LaneAccess:
    """One robot's lanes and locks (see the module docstring)."""

    def __init__(self, lane_map: LaneMap, locks: LaneLocks,
                 locked: frozenset[int] | None = None,
                 report: Callable[[int, int, float], None] | None = None):
        self.lane_map = lane_map
        self.locks = locks
        # report(kind, waiting spot, t [s]): LANE_WAIT (stamped at the request) and LANE_ENTER
        self.report = report
        self.now = 0.0  # [s] the last time asked
        # the lanes entered holding a lock (None: every lane)
        self.locked = (frozenset(lane.index for lane in lane_map.lanes) if locked is None
                       else frozenset(locked))
        self.one_way = len(self.locked) < len(lane_map.lanes)  # some lanes driven one way
        self.started = False  # start_at called: the start's lane is held

    def start_at(self, vertex: int, now: float) -> None:
        """The robot starts at `vertex` [index] at run time `now` [s]: inside a locked lane, it
        holds that lane at once (first in its queue)."""
        self.started = True
        inside = self.lane_map.interior_of(vertex)
        self.locks.hold(inside if inside in self.locked else -1, now)

    def locked_lane(self, u: int, v: int) -> int:
        """The locked lane of the edge u-v, -1 when none (wide, or a one-way lane)."""
        lane = self.lane_map.lane_of(u, v)
        return lane if lane in self.locked else -1

    def enters(self, prev: int | None, u: int, nxt: int | None) -> bool:
        """Whether the route ... prev -> u -> nxt enters a lane at u (u is then a waiting spot
        the robot must reach, not just pass near)."""
        if nxt is None:
            return False
        lane = self.locked_lane(u, nxt)
        return lane >= 0 and (prev is None or self.lane_map.lane_of(prev, u) != lane)

    def arrive(self, u: int, now: float) -> None:
        """At vertex u: outside the held lane, release it."""
        self.now = now
        held = self.locks.held
        if held >= 0 and self.lane_map.interior_of(u) != held:
            self.locks.release(now)

    def may_start(self, u: int, v: int, now: float) -> bool:
        """May the robot, at vertex u, drive the edge u -> v now? (Asks for its lane.)"""
        self.arrive(u, now)
        lane = self.locked_lane(u, v)
        if lane < 0:
            return True
        locks = self.locks
        waits, waited = locks.waits, locks.wait_s
        granted = locks.may_enter(lane, now)
        if self.report is not None:
            if locks.waits > waits:
                self.report(LANE_WAIT, u, locks.mine.stamp)
            if locks.wait_s > waited:
                self.report(LANE_ENTER, u, now)
        return granted

    def queued_behind_waiter(self, u: int, v: int) -> bool:
        """Is another robot waiting for the lane of u -> v ahead of us (not only a holder)?"""
        lane = self.locked_lane(u, v)
        for claim in self.locks.queue(lane):
            if claim.robot == self.locks.robot:
                return False
            if not claim.held:
                return True
        return False

    def follows(self, u: int | None, v: int, points) -> bool:
        """On the leg u -> v of a one-way lane, is what holds us (map-frame points (k, 2) [m])
        inside that lane, i.e. a robot ahead driving the same way (wait behind it: no way
        round, no giving way)?"""
        lane = -1 if u is None else self.lane_map.lane_of(u, v)
        if lane < 0 or lane in self.locked:
            return False
        return bool((self.lane_map.lane_at(points) == lane).any())

    def driven(self, u: int | None, v: int | None) -> int:
        """The one-way lane of the leg u -> v when the leg drives it along its arc, -1 when
        none: the robot holds the one-way lane it drives (docs/LANES.md, section 2b)."""
        if u is None or v is None or not self.one_way:
            return -1
        lane = self.lane_map.lane_of(u, v)
        return lane if lane >= 0 and lane not in self.locked else -1

    def allowed(self, points, driven: int = -1) -> np.ndarray:
        """Mask of map-frame points (k, 2) [m] outside every lane but the one held and the
        one-way lane `driven` (the lane of the robot's leg, -1: none)."""
        lanes = self.lane_map.lane_at(points)
        return (lanes < 0) | (lanes == self.locks.held) | ((lanes == driven) & (driven >= 0))

    def withdraw(self) -> None:
        """The route changed: a request not granted yet is dropped (a held lane is kept)."""
        if self.locks.mine.lane >= 0 and not self.locks.mine.held:
            self.locks.release(self.now)

    def tick(self, now: float) -> None:
        self.now = now
        self.locks.tick(now)


def attach_lanes(agent: Any, lane_map: LaneMap, start_vertex: int | None,
                 locked: frozenset[int] | None = None) -> LaneAccess:
    """Give an `AgentRuntime` the lane layer: its machine hears the claims, its navigator asks
    at lane entries, its ticks re-announce the claim; a robot that starts inside a locked lane
    holds it (`start_vertex` [index]; None: not known yet, then when the runtime begins).
    `locked`: the lanes entered with a lock (None: all; with one-way lanes the two-way ones)."""
    machine = agent.machine

    def send(claim: LaneClaim) -> None:
        if machine.alive:
            machine.driver.transmit(machine.robot, claim)

    def report(kind: int, spot: int, t: float) -> None:
        if machine.alive:
            machine.emit(kind, int(spot), -1, float(t))

    locks = LaneLocks(machine.robot, send, lambda r: r in machine.liveness.lost)
    access = LaneAccess(lane_map, locks, locked, report)
    machine.lane_locks = locks
    agent.navigator.lanes = access
    if start_vertex is not None:
        access.start_at(start_vertex, 0.0)
    return access
