"""Giving way between robots in passages one robot wide (ROS-free, map frame [m]).

When two robots block each other and there is no reasonable way round, one of them (the one
whose yield timer fires first: staggered by robot index, navigator.py) gives way: it drives to
a *refuge*, the nearest free spot off the other robot's way (a side pocket, a junction, the
corridor it came from), waits there until the other has passed, then carries on. The navigator
looks behind the robot first (`behind_first`: back the way it came, away from the other
robot), where it backs into the refuge without turning round; only then anywhere near. A robot standing
still without a goal does the same when another comes right up to it. The other robot's way is
estimated from what one robot knows: it comes from where it stands, through our position, on
along the way we came (our trail) and straight on beyond us.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tpuaf.navigation.controller import Command, Status
from tpuaf.navigation.route import polyline_length

REFUGE_SEARCH_M = 2.5  # [m] refuges are looked for this far from the robot at most
REFUGE_STEP_M = 0.05  # [m] cells of the search for a refuge
REFUGE_PLANS = 3  # refuges planned to (nearest first) before giving up
REFUGE_PATH_FACTOR = 2.5  # a refuge's planned path may be this many times its wave distance
# (+ 1 m): the plan keeps from walls, the wave does not
WAY_EXTENSION_M = 1.5  # [m] the other robot's way goes on this far straight beyond us
WALL_MARGIN_M = 0.03  # [m] a refuge is this much farther from walls than the lethal radius
OBSTACLE_RADIUS_M = 0.05  # [m] of one laser point as a temporary obstacle of a replan
OBSTACLE_RANGE_M = 1.5  # [m] laser points farther than this are not added to a replan
HELD_M = 0.05  # [m] a robot that has not come this much closer to its aim is held
REVERSE_LOOK_M = 0.2  # [m] the way to a refuge starts toward its first corner this far off
BLOCKING_RANGE_M = 1.0  # [m] unmapped points ahead within this hold the robot
PASS_MARGIN_M = 0.05  # [m] added to the clearance two passing robots need
CLEAR_MARGIN_M = 0.3  # [m] the other robot is past when farther than the pass clearance + this
REFUGE_TOLERANCE_M = 0.08  # [m] a refuge is reached within this
CORNER_GIVE_WAY_M = 0.15  # [m] corners on the way to a refuge are reached within this
GIVE_WAY_WAIT_S = 2.0  # [s] in a refuge at least this long
GIVE_WAY_CLEAR_S = 1.0  # [s] ... and nothing unmapped near for this long
GIVE_WAY_STILL_S = 3.0  # [s] ... or the other robot near has stood still this long
GIVE_WAY_MIN_S = 10.0  # [s] least waiting budget of a give-way
GIVE_WAY_PASS_M = 2.0  # [m] the other robot drives this far to be past (the waiting budget)
PARKED_YIELD_S = 0.5  # [s] a parked robot makes room after another has been near this long
TRAIL_STEP_M = 0.1  # [m] between the remembered positions
TRAIL_POINTS = 30  # remembered positions (3 m)


@dataclass
class GiveWay:
    """One give-way manoeuvre: drive the corners to the refuge, then wait."""

    refuge: tuple[float, float]
    corners: list[tuple[float, float]]  # still ahead, the refuge last
    blocker: tuple[float, float]  # [m] where the other robot stood
    started_s: float
    deadline_s: float  # [s] waiting ends at the latest here
    arrived_s: float | None = None  # [s] at the refuge since
    clear_since_s: float | None = None  # [s] nothing unmapped near since
    passed: bool = False  # something unmapped came near while we waited (the other robot)
    parked: bool = False  # a robot without a goal making room
    reverse: bool = False  # driven backward (the refuge lies behind the robot)
    other_at: np.ndarray | None = None  # [m] centre of the other robot's points near us
    other_since_s: float = 0.0  # [s] ... there (within HELD_M) since


def segment_distances(points: np.ndarray, polyline: np.ndarray) -> np.ndarray:
    """[m] from each point (k, 2) to the nearest point of the polyline (m, 2)."""
    if len(polyline) == 1:
        return np.hypot(points[:, 0] - polyline[0, 0], points[:, 1] - polyline[0, 1])
    a, b = polyline[:-1], polyline[1:]
    ab = b - a
    len2 = np.maximum((ab * ab).sum(axis=1), 1e-12)
    rel = points[:, None, :] - a[None, :, :]
    f = np.clip((rel * ab[None]).sum(axis=2) / len2[None], 0.0, 1.0)
    closest = a[None] + f[:, :, None] * ab[None]
    d = np.hypot(points[:, None, 0] - closest[:, :, 0], points[:, None, 1] - closest[:, :, 1])
    return d.min(axis=1)


def other_way(me: tuple[float, float], blocker: tuple[float, float],
              trail: list[tuple[float, float]],
              heading_to: tuple[float, float] | None = None) -> np.ndarray:
    """The polyline (k, 2) [m] the other robot is expected to drive: from where it stands,
    through us, back along our trail (newest first), straight on beyond us, and (when we were
    driving toward `heading_to`, the point we aimed at: along a corridor) straight back from
    us away from that point."""
    points = [blocker, me]
    for fx, fy in ((blocker[0], blocker[1]), heading_to):
        dx, dy = me[0] - fx, me[1] - fy
        norm = math.hypot(dx, dy)
        if norm > 1e-6:
            points += [(me[0] + WAY_EXTENSION_M * dx / norm,
                        me[1] + WAY_EXTENSION_M * dy / norm), me]
        if heading_to is None:
            break
    return np.array([*points, *reversed(trail)], dtype=float)


def find_refuge(planner, me: tuple[float, float], blocker: tuple[float, float],
                trail: list[tuple[float, float]], pass_clearance_m: float,
                obstacles: np.ndarray | None,
                heading_to: tuple[float, float] | None = None,
                allowed=None, behind_first: bool = False) -> np.ndarray | None:
    """The planned path (k, 2) [m] from `me` to the nearest refuge: a free spot at least
    `pass_clearance_m` from the other robot's expected way (`other_way`) where the robot stops
    (REFUGE_TOLERANCE_M short of it at most), reachable without
    crossing `obstacles` (discs (x, y, radius) [m]: the other robots), where `allowed`
    (points (k, 2) -> bool mask; None: anywhere) lets the robot stand, or None. With
    `behind_first` the refuges behind `me` (on the far side from the blocker) come first.

    Nearest by a wave over a square of cells round `me` (free: not lethal for the robot, not
    within a disc's lethal reach), then a plan to the first few refuges the wave met."""
    distances = getattr(planner, "distances_to_obstacle", None)
    inscribed = getattr(planner, "inscribed_radius_m", None)
    if distances is None or inscribed is None:
        return None
    step = REFUGE_STEP_M
    k = int(round(REFUGE_SEARCH_M / step))
    s = np.arange(-k, k + 1) * step
    gx, gy = np.meshgrid(me[0] + s, me[1] + s)  # [row = y, col = x]
    cells = np.column_stack((gx.ravel(), gy.ravel()))
    wall = distances(cells).reshape(gx.shape)
    free = wall >= inscribed
    if obstacles is not None and len(obstacles):
        for ox, oy, r in np.asarray(obstacles, dtype=float):
            free &= np.hypot(gx - ox, gy - oy) >= r + inscribed
    # The wave: cells reached from our own cell (free or not: we stand there) step by step.
    reached = np.zeros_like(free)
    reached[k, k] = True
    order = np.full(free.shape, -1, dtype=int)
    order[k, k] = 0
    front = reached.copy()
    for wave in range(1, 4 * k):
        grown = front.copy()
        grown[1:, :] |= front[:-1, :]
        grown[:-1, :] |= front[1:, :]
        grown[:, 1:] |= front[:, :-1]
        grown[:, :-1] |= front[:, 1:]
        front = grown & free & ~reached
        if not front.any():
            break
        reached |= front
        order[front] = wave
    refuge = reached & (wall >= inscribed + WALL_MARGIN_M)
    refuge[k, k] = False
    if not refuge.any():
        return None
    idx = np.flatnonzero(refuge.ravel())
    way = other_way(me, blocker, trail, heading_to)
    # the robot may stop REFUGE_TOLERANCE_M short of the refuge, toward the way
    idx = idx[segment_distances(cells[idx], way) >= pass_clearance_m + REFUGE_TOLERANCE_M]
    if allowed is not None:  # e.g. not inside a lane the robot does not hold (lanes.py)
        idx = idx[allowed(cells[idx])]
    idx = idx[np.argsort(order.ravel()[idx], kind="stable")]
    groups = [idx]
    if behind_first:  # away from the blocker: (cell - me) . (me - blocker) > 0
        away = ((cells[idx, 0] - me[0]) * (me[0] - blocker[0])
                + (cells[idx, 1] - me[1]) * (me[1] - blocker[1])) > 0.0
        groups = [idx[away], idx[~away]]
    for group in groups:
        for j in group[:REFUGE_PLANS]:
            path = planner.plan(me, tuple(cells[j]), obstacles)
            if path is not None and polyline_length(path) <= (
                    REFUGE_PATH_FACTOR * order.ravel()[j] * step + 1.0):
                return path
    return None


class GivingWay:
    """Navigator methods of the give-way manoeuvre (state: `_give_way`, `_trail`,
    `_near_since`, `_near_d`, `give_ways`, `reversals`, `sees_behind`): drive to a refuge
    (backward when it lies behind), wait there until the other robot has passed, go on."""

    @property
    def giving_way(self) -> bool:
        """Driving to, or waiting in, a refuge to let another robot pass."""
        return self._give_way is not None

    def _pass_clearance_m(self) -> float:
        """[m] between the centre of a robot in a refuge and the other's way: two robot radii,
        the controller's safety margin and a little more."""
        c = self.controller.config
        return 2.0 * c.robot_radius + c.safety_margin + PASS_MARGIN_M

    def _start_give_way(self, t: float, pose: tuple[float, float, float],
                        blocking: np.ndarray, parked: bool,
                        others: np.ndarray | None = None) -> bool:
        """Look for a refuge off the way of the robot whose points (map frame) are
        `blocking`, reachable round `others` (every unmapped point near); start driving there
        if there is one."""
        if self.planner is None or blocking is None or len(blocking) == 0:
            return False
        me = (float(pose[0]), float(pose[1]))
        near = blocking[np.argsort(np.hypot(blocking[:, 0] - me[0],
                                            blocking[:, 1] - me[1]))[:8]]
        r = self.controller.config.robot_radius
        blocker = robot_centre(near, me, r)
        seen = blocking if others is None else others
        obstacles = np.vstack((obstacle_discs(seen), [(blocker[0], blocker[1], r)]))
        aim = None if parked else self.controller.target
        path = find_refuge(self.planner, me, blocker, [] if parked else self._trail,
                           self._pass_clearance_m(), obstacles, aim, self._lane_free,
                           behind_first=self.sees_behind)
        if path is None or (self.lanes is not None and self.lanes.one_way
                            and not self._lane_free_path(path)):
            return False  # with one-way lanes: never through a lane (against its flow)
        speed = self.controller.config.max_linear_speed
        # [s] the other robot drives past us and on: a few metres at its speed, at least 10 s
        wait = max(GIVE_WAY_MIN_S, (polyline_length(path) + GIVE_WAY_PASS_M) / speed)
        corners = [(float(px), float(py)) for px, py in path[1:]]
        # Backward when the way to the refuge starts behind the robot (no turning round, and
        # it faces the way it was going when it drives on); only with a laser that sees there.
        th = pose[2]
        first = next((c for c in corners if math.hypot(c[0] - me[0], c[1] - me[1])
                      >= REVERSE_LOOK_M), corners[-1])  # the path's cells next to us: no use
        reverse = self.sees_behind and (
            (first[0] - me[0]) * math.cos(th) + (first[1] - me[1]) * math.sin(th) < 0.0)
        self._give_way = GiveWay(refuge=corners[-1], corners=corners, blocker=blocker,
                                 started_s=t, deadline_s=t + wait + polyline_length(path) / speed,
                                 parked=parked, reverse=reverse)
        self.give_ways += 1
        self.reversals += int(reverse)
        self._blocked_since = None
        self._held_aim = None
        self._aim_give_way(t)
        return True

    def _aim_give_way(self, t: float) -> None:
        gw = self._give_way
        last = len(gw.corners) == 1
        self.controller.set_target(gw.corners[0], REFUGE_TOLERANCE_M if last
                                   else min(self.corner_tolerance, CORNER_GIVE_WAY_M), t,
                                   new_goal=False, reverse=gw.reverse)

    def _end_give_way(self, t: float, pose: tuple[float, float, float]) -> None:
        """Back to the route (a plan from the pose), or to standing still when parked."""
        self._give_way = None
        self._blocked_since = None
        self._held_aim = None
        self.controller.resume_driving(t)
        self.controller.reverse = False
        if self.route is None:
            self.controller.target = None
            return
        self._leg_from = None
        self.replans += 1
        self._plan_leg(t, pose)

    def _step_give_way(self, t: float, pose: tuple[float, float, float],
                       points: np.ndarray | None) -> Command:
        gw = self._give_way
        ctl = self.controller
        if gw.arrived_s is None:
            cmd = ctl.step(t, pose, points)
            if cmd.status in (Status.RECOVERING, Status.FAILED) or t > gw.deadline_s:
                self._end_give_way(t, pose)  # cannot get there: back to the route
                return Command(0.0, 0.0, Status.DRIVING)
            while cmd.status == Status.REACHED and len(gw.corners) > 1:
                gw.corners.pop(0)
                self._aim_give_way(t)
                cmd = ctl.step(t, pose, points)
            if cmd.status != Status.REACHED:
                return cmd
            gw.arrived_s = t
        # In the refuge: wait until nothing the map does not explain is near for a while
        # (the other robot has passed), at least GIVE_WAY_WAIT_S, at most until the deadline.
        near = map_points(pose, points)
        near = self._unmapped(near) if near is not None else None
        me = np.array(pose[:2])
        busy = near is not None and bool(
            (np.hypot(*(near - me).T) <= self._pass_clearance_m() + CLEAR_MARGIN_M).any())
        if busy:
            gw.clear_since_s = None
            gw.passed = True
        elif gw.clear_since_s is None:
            gw.clear_since_s = t
        # The other robot standing still near us (not passing: it waits for us, or has
        # arrived): waiting on achieves nothing.
        centre = near.mean(axis=0) if busy else None
        if centre is None or gw.other_at is None or math.hypot(
                centre[0] - gw.other_at[0], centre[1] - gw.other_at[1]) > HELD_M:
            gw.other_at, gw.other_since_s = centre, t
        waited = t - gw.arrived_s >= GIVE_WAY_WAIT_S
        # Clear: the other robot came by and has gone (not yet come: it may still be on its way)
        clear = (gw.passed and gw.clear_since_s is not None
                 and t - gw.clear_since_s >= GIVE_WAY_CLEAR_S)
        standing = gw.other_at is not None and t - gw.other_since_s >= GIVE_WAY_STILL_S
        if (waited and (clear or standing)) or t >= gw.deadline_s:
            self._end_give_way(t, pose)
            if self.route is None:
                return Command(0.0, 0.0, Status.REACHED)
            return ctl.step(t, pose, points)
        return Command(0.0, 0.0, Status.DRIVING)

    def _remember(self, pose: tuple[float, float, float]) -> None:
        """The trail: positions TRAIL_STEP_M apart, the last TRAIL_POINTS of them."""
        xy = (float(pose[0]), float(pose[1]))
        if not self._trail or math.hypot(xy[0] - self._trail[-1][0],
                                         xy[1] - self._trail[-1][1]) >= TRAIL_STEP_M:
            self._trail.append(xy)
            if len(self._trail) > TRAIL_POINTS:
                del self._trail[0]

    def park_step(self, t: float, pose: tuple[float, float, float],
                  points: np.ndarray | None) -> tuple[float, float]:
        """A robot standing without a route (no goal, or waiting to decide): it makes room
        (drives to a refuge, waits, stays there) when another robot within BLOCKING_RANGE_M
        has not moved away for PARKED_YIELD_S (+ 0.05 s per robot index, mod 8): sooner than
        a driving robot held still acts (yield_after_s), so the one that has a goal keeps it.
        Returns (v [m/s], w [rad/s])."""
        if self.planner is None:
            return 0.0, 0.0
        if self._give_way is not None:
            cmd = self._step_give_way(t, pose, points)
            return cmd.v, cmd.w
        near = self._unmapped(map_points(pose, points))
        nearest = math.inf
        if near is not None:
            d = np.hypot(near[:, 0] - pose[0], near[:, 1] - pose[1])
            near = near[d <= BLOCKING_RANGE_M]
            nearest = float(d.min())
        if near is None or len(near) == 0:
            self._near_since = None
            return 0.0, 0.0
        if self._near_since is None or nearest > self._near_d + HELD_M:
            # first seen, or moving away (passing by): start watching again
            self._near_since, self._near_d = t, nearest
            return 0.0, 0.0
        self._near_d = min(self._near_d, nearest)
        if t - self._near_since < PARKED_YIELD_S + 0.05 * (self.robot_index % 8):
            return 0.0, 0.0
        self._near_since = None
        if not self._start_give_way(t, pose, near, parked=True):
            return 0.0, 0.0
        cmd = self._step_give_way(t, pose, points)
        return cmd.v, cmd.w


def robot_centre(seen: np.ndarray, me: tuple[float, float], radius: float) -> tuple[float, float]:
    """Another robot's centre [m] from the map-frame points we see of it: their mean, a robot
    radius farther from us (the laser sees the side facing us)."""
    cx, cy = seen.mean(axis=0)
    d = math.hypot(cx - me[0], cy - me[1]) or 1.0
    return float(cx + radius * (cx - me[0]) / d), float(cy + radius * (cy - me[1]) / d)


def map_points(pose: tuple[float, float, float], points: np.ndarray | None,
               range_m: float = OBSTACLE_RANGE_M):
    """Laser points (robot frame) within `range_m` [m], in the map frame [m]."""
    if points is None or len(points) == 0:
        return None
    near = points if math.isinf(range_m) else points[
        np.hypot(points[:, 0], points[:, 1]) <= range_m]
    if len(near) == 0:
        return None
    x, y, th = pose
    c, s = math.cos(th), math.sin(th)
    return np.column_stack((x + c * near[:, 0] - s * near[:, 1],
                            y + s * near[:, 0] + c * near[:, 1]))


def obstacle_discs(xy: np.ndarray | None):
    """(k, 3) discs (x, y, radius) of map-frame points, or None."""
    if xy is None or len(xy) == 0:
        return None
    return np.column_stack((xy, np.full(len(xy), OBSTACLE_RADIUS_M)))
