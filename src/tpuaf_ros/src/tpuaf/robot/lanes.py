"""A robot's lane layer: the map's lanes (navigation/lanes.py) with its lock table
(team/lane_locks.py), as its navigator asks for them (docs/LANES.md).

The navigator asks `may_start(u, v, now)` before every leg u -> v that starts at a vertex and
`arrive(u, now)` at a route's goal: reaching a vertex outside the held lane (a waiting spot)
releases it; a leg into a lane not held asks for the lane and waits at u until it is granted.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from tpuaf.navigation.lanes import LaneMap
from tpuaf.team.lane_locks import LaneLocks
from tpuaf.team.messages import LaneClaim


class LaneAccess:
    """One robot's lanes and locks (see the module docstring)."""

    def __init__(self, lane_map: LaneMap, locks: LaneLocks):
        self.lane_map = lane_map
        self.locks = locks
        self.now = 0.0  # [s] the last time asked

    def enters(self, prev: int | None, u: int, nxt: int | None) -> bool:
        """Whether the route ... prev -> u -> nxt enters a lane at u (u is then a waiting spot
        the robot must reach, not just pass near)."""
        if nxt is None:
            return False
        lane = self.lane_map.lane_of(u, nxt)
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
        lane = self.lane_map.lane_of(u, v)
        return lane < 0 or self.locks.may_enter(lane, now)

    def queued_behind_waiter(self, u: int, v: int) -> bool:
        """Is another robot waiting for the lane of u -> v ahead of us (not only a holder)?"""
        lane = self.lane_map.lane_of(u, v)
        for claim in self.locks.queue(lane):
            if claim.robot == self.locks.robot:
                return False
            if not claim.held:
                return True
        return False

    def allowed(self, points) -> np.ndarray:
        """Mask of map-frame points (k, 2) [m] outside every lane but the one held."""
        lanes = self.lane_map.lane_at(points)
        return (lanes < 0) | (lanes == self.locks.held)

    def withdraw(self) -> None:
        """The route changed: a request not granted yet is dropped (a held lane is kept)."""
        if self.locks.mine.lane >= 0 and not self.locks.mine.held:
            self.locks.release(self.now)

    def tick(self, now: float) -> None:
        self.now = now
        self.locks.tick(now)


def attach_lanes(agent: Any, lane_map: LaneMap, start_vertex: int) -> LaneAccess:
    """Give an `AgentRuntime` the lane layer: its machine hears the claims, its navigator asks
    at lane entries; a robot that starts inside a lane holds it."""
    machine = agent.machine

    def send(claim: LaneClaim) -> None:
        if machine.alive:
            machine.driver.transmit(machine.robot, claim)

    locks = LaneLocks(machine.robot, send, lambda r: r in machine.liveness.lost)
    access = LaneAccess(lane_map, locks)
    machine.lane_locks = locks
    agent.navigator.lanes = access
    locks.hold(lane_map.interior_of(start_vertex), 0.0)
    return access
