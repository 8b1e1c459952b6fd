"""Navigator: follows a `GraphRoute` with the local controller along planned paths, ROS-free
(goal_navigator.py: the same interface over an external planner, move_base)."""

from __future__ import annotations

import math
from enum import Enum

import numpy as np

from tpuaf.navigation.controller import GOAL_TOLERANCE_M, Command, LocalController, Status
from tpuaf.navigation.give_way import (
    BLOCKING_RANGE_M,
    HELD_M,
    GiveWay,
    GivingWay,
    map_points,
    obstacle_discs,
    robot_centre,
)
from tpuaf.navigation.lane_gate import LaneGate
from tpuaf.navigation.route import GraphRoute, polyline_length

# ---------------------------------------------------------------------------------------------
# Navigator: route + controller


class Event(Enum):
    NONE = 0
    WAYPOINT = 1  # passed a waypoint that is not the goal
    ARRIVED = 2  # within goal tolerance of the goal vertex (or short of it: `near_goal_m`)
    FAILED = 3  # gave up on the goal


class Navigator(LaneGate, GivingWay):
    """Follows a `GraphRoute` with a `LocalController`, along planned paths when it has a
    `PathPlanner` (navigation/planner.py), else along the straight edges.

    Each leg (to the next vertex of the route) is the planner's path: the cached path of the
    graph edge when the leg starts at a vertex, else a plan from the pose, kept `keep_right_m`
    [m] right of its way where the walls leave room (`keep_right`: right-hand traffic; not
    with lanes). The controller drives to the path's corners one by one (reached within
    `corner_tolerance` [m]), then to the vertex.
    After a recovery (the controller was stuck and backed off) the leg is replanned from the
    pose, with the laser's points as obstacles for that plan (another robot, an unmapped
    obstacle), so the robot takes another way when there is a reasonable one. A robot held
    by another robot (no progress toward its aim) gives way when there is no way round: it
    backs to a refuge behind it, off the other's way (or another refuge when none is behind);
    a robot without a route makes room for one that comes up to it (`park_step`). Pass-through waypoints count as
    reached within `waypoint_tolerance` [m], the goal within `goal_tolerance` [m] (the agents:
    the map's visit radius). A robot within `near_goal_m` [m] of its goal (the map's goal
    tolerance; None: never) whose goal another robot covers (stands on it), held there or
    with its controller given up, ends the route short (ARRIVED; `short_arrivals` counts
    them): the visit rule then makes it a dwell, not a visit. Not covered, it keeps trying.
    `step` returns (Command, Event, vertex): the vertex is the waypoint or goal reached, or the
    goal that failed."""

    def __init__(self, controller: LocalController, goal_tolerance: float = GOAL_TOLERANCE_M,
                 waypoint_tolerance: float = 0.6, planner=None, corner_tolerance: float = 0.3,
                 robot_index: int = 0, near_goal_m: float | None = None):
        self.controller = controller
        self.goal_tolerance = float(goal_tolerance)
        self.near_goal_m = near_goal_m  # [m] a held robot ends its route short within this
        self.short_arrivals = 0
        self._short = False  # the route ends short at the next step
        self.waypoint_tolerance = float(waypoint_tolerance)
        self.corner_tolerance = float(corner_tolerance)
        self.planner = planner
        self.route: GraphRoute | None = None
        self._corners: list[tuple[float, float]] = []  # of the current leg, next first
        self._leg_from: int | None = None  # vertex the leg starts at (edge path cache)
        self._plan_pending = False
        self._retries_seen = 0
        self.replans = 0  # legs replanned (after a recovery, or to give way)
        self.yields = 0  # replans round a robot (or unmapped obstacle) that held us still
        self._blocked_since: float | None = None  # [s] no progress toward the aim since
        self._held_aim: tuple[float, float] | None = None  # [m] the aim point watched
        self._held_best = math.inf  # [m] the nearest the robot came to it meanwhile
        # (where the robot stood, [m] from there to the robot ahead) half way to acting
        self._held_gap: tuple[tuple[float, float], float] | None = None
        # [s] held still this long by an unmapped obstacle ahead: replan round it or give way
        # (1.5-3 s, staggered with the controller's retry wait, and by 0.1 s per four robot
        # indices: two robots held by each other do not act at the same instant)
        self.robot_index = max(0, int(robot_index))
        self.yield_after_s = (1.0 + controller.config.retry_wait_s
                              + 0.1 * min(self.robot_index // 4, 4))
        self.give_ways = 0  # refuges driven to (to let another robot pass)
        self.reversals = 0  # ... of them driven backward (the refuge behind the robot)
        # the laser sees behind the robot (a full circle): refuges behind are reversed into
        self.sees_behind = True
        self._give_way: GiveWay | None = None
        self._give_ways_this_leg = 0
        self._trail: list[tuple[float, float]] = []  # [m] recent positions, newest last
        self._near_since: float | None = None  # [s] parked with a robot near since
        self._near_d = math.inf  # [m] the nearest it came meanwhile
        self.unplanned_legs = 0  # legs without a path (driven straight)
        # [m] a corner counts as passed (within corner_tolerance) only when the point after it
        # is in line of sight with this clearance from the walls: the bare footprint + 2 cm
        self.sight_clearance_m = controller.config.robot_radius + SIGHT_MARGIN_M
        self._corner_tight = False  # the first corner must be reached within TIGHT_CORNER_M
        # The lane layer (robot/lanes.py LaneAccess; None: no lanes): a leg into a lane starts
        # only from its waiting spot holding the lane (lane_gate.py).
        self.lanes = None
        self._gate: tuple[int, bool] | None = None  # waiting at: (next vertex, advance route)
        self._gate_corners: list[tuple[float, float]] | None = None  # to a waiting point
        self.gate_waits = 0  # waits at a lane's waiting spot
        # [m] legs keep this far right of the planned path where the walls leave room: two
        # robots driving an edge in opposite directions meet side by side (0: off)
        self.keep_right_m = KEEP_RIGHT_SHARE * self._pass_clearance_m()

    def set_route(self, route: GraphRoute, t: float) -> None:
        self.route = route
        self._short = False
        self._give_way = None
        self._near_since = None
        self._gate = self._gate_corners = None
        at_start = bool(route.waypoints) and route.waypoints[0] != route.start
        if self.lanes is not None:
            self.lanes.withdraw()
            if at_start and not self.lanes.may_start(route.start, route.waypoints[0], t):
                self._gate = (route.start, False)
                self.gate_waits += 1
        self._new_leg(route.start if at_start else None)
        self._retries_seen = 0
        self._aim(t, new_goal=True)

    def cancel(self) -> None:
        self.route = None
        self._give_way = None
        self._gate = self._gate_corners = None
        if self.lanes is not None:
            self.lanes.withdraw()
        self._corners = []
        self._plan_pending = False
        self.controller.target = None

    def pause(self) -> None:
        """The robot is stopped by its runtime (stale inputs); nothing to do here."""

    def resume(self, t: float) -> None:
        """After a pause (stale inputs, robot stopped): restart the progress watch at t [s], so
        the standstill does not count as being stuck."""
        self.controller.restart_progress(t)

    @property
    def corners(self) -> list[tuple[float, float]]:
        """The corners [m] still ahead on the current leg."""
        return list(self._corners)

    def _new_leg(self, from_vertex: int | None) -> None:
        self._give_ways_this_leg = 0
        self._corners = []
        self._corner_tight = False
        self._leg_from = from_vertex
        self._plan_pending = self.planner is not None

    def _aim(self, t: float, new_goal: bool, keep_clock: bool = False) -> None:
        route = self.route
        if self._corners:
            tol = TIGHT_CORNER_M if self._corner_tight else self.corner_tolerance
            self.controller.set_target(self._corners[0], tol, t, new_goal=new_goal,
                                       keep_clock=keep_clock)
            return
        tol = self._gate_tolerance(route, self.goal_tolerance if route.is_last
                                   else self.waypoint_tolerance)
        self.controller.set_target(route.next_position(), tol, t, new_goal=new_goal,
                                   keep_clock=keep_clock)

    def _plan_leg(self, t: float, pose: tuple[float, float, float],
                  points: np.ndarray | None = None, keep_obstacles: bool = False,
                  keep_clock: bool = False) -> None:
        """The corners from the pose to the next vertex of the route. `points`: map-frame
        laser points, temporary obstacles (only those the map does not explain, unless
        `keep_obstacles`: already filtered). `keep_clock`: the controller's stuck timer runs
        on (a replan round a robot that holds us: the robot may still be stuck)."""
        self._plan_pending = False
        route = self.route
        goal = route.next_waypoint
        target = route.next_position()
        x, y = pose[0], pose[1]
        path = None
        u = self._leg_from
        if u is not None and points is None:
            # The edge's cached path only from (about) its first vertex: a waypoint passed
            # within waypoint_tolerance may lie round a corner, and the straight line from the
            # pose to the edge path's next point then crosses a wall.
            p = route.positions[u]
            if math.hypot(x - p[0], y - p[1]) <= self.corner_tolerance:
                path = self.planner.edge_path(u, goal)
        if path is None:
            obstacles = obstacle_discs(points if keep_obstacles else self._unmapped(points))
            path = self.planner.plan((x, y), target, obstacles)
            if obstacles is not None:
                # Round another robot only when that is not much longer than the free way:
                # it will move anyway (waiting, or giving way, is then quicker).
                free = self.planner.plan((x, y), target)
                if path is None or (free is not None and not (
                        _reasonable_detour(path, free) and self._lane_free_path(path))):
                    path = free
        if path is None:
            self.unplanned_legs += 1
            corners: list[tuple[float, float]] = []
        else:
            if self.keep_right_m > 0.0 and points is None and (
                    self.lanes is None or not self.lanes.has_lanes):
                # (not with lanes: their locks and waiting spots order the passing there)
                path = keep_right(path, self.keep_right_m, self.planner, self._right_room_m())
            corners = [(float(px), float(py)) for px, py in path[1:-1]]
        tol = self.corner_tolerance
        self._corners = corners
        self._corner_tight = False
        while (corners and math.hypot(corners[0][0] - x, corners[0][1] - y) <= tol
               and self._corner_passable(pose)):
            corners.pop(0)
        self._aim(t, new_goal=False, keep_clock=keep_clock)

    def _right_room_m(self) -> float:
        """[m] a point kept right stays this far from the walls: the controller's wide
        clearance (robot radius + plan margin), which it keeps from walls when it can."""
        c = self.controller.config
        return c.robot_radius + max(c.plan_margin, c.safety_margin)

    def _corner_passable(self, pose: tuple[float, float, float]) -> bool:
        """Whether the first corner may be left behind: the point after it is in line of
        sight of the pose (a corner within corner_tolerance may still be round a wall's end,
        where the corridors are narrower than the tolerance)."""
        clear = getattr(self.planner, "segment_clear", None)
        if clear is None or not self._corners:
            return True
        after = self._corners[1] if len(self._corners) > 1 else self.route.next_position()
        return clear(pose[:2], after, self.sight_clearance_m)

    def _unmapped(self, xy: np.ndarray | None) -> np.ndarray | None:
        """The map-frame laser points the map does not explain (farther than
        UNMAPPED_DISTANCE_M from every mapped obstacle): other robots, unmapped obstacles."""
        if xy is None or len(xy) == 0:
            return None
        keep = self._unexplained(xy)
        return xy[keep] if keep.any() else None

    def _unexplained(self, xy: np.ndarray) -> np.ndarray:
        """Mask of the map-frame points (k, 2) [m] farther than UNMAPPED_DISTANCE_M from every
        mapped obstacle."""
        return self.planner.distances_to_obstacle(xy) > UNMAPPED_DISTANCE_M

    def _movers(self, pose: tuple[float, float, float],
                points: np.ndarray | None) -> np.ndarray | None:
        """The robot-frame laser points within the controller's reach that the map does not
        explain (other robots: they may move toward us), or None."""
        if self.planner is None:
            return None
        near = self.controller.relevant(points)
        if near is None:
            return None
        keep = self._unexplained(map_points(pose, near, math.inf))
        return near[keep] if keep.any() else None

    def _watch_blocked(self, t: float, pose: tuple[float, float, float],
                       points: np.ndarray | None, cmd: Command) -> None:
        """The right of way between robots: a robot held still for `yield_after_s` (staggered
        by its retry wait and index, so that of two robots face to face one acts first) by
        something the map does not explain, ahead of it, replans round it when there is a
        reasonable way round (another corridor), else gives way (drives to a refuge off the
        other's way and waits there, give_way.py), without waiting to be stuck. The other then
        finds its way clear."""
        x, y = pose[0], pose[1]
        # Held: no progress toward the point we aim at (HELD_M closer than the nearest we came
        # since the watch started); turning on the spot, dithering or stepping aside is still
        # being held. A new aim point starts the watch anew.
        aim = self.controller.target or self.route.next_position()
        d = math.hypot(aim[0] - x, aim[1] - y)
        if (self._blocked_since is None or self._held_aim != aim
                or d < self._held_best - HELD_M):
            self._held_aim, self._held_best, self._blocked_since = aim, d, t
            self._held_gap = None
            self._follow_since = None  # moving on: a new wait behind a robot starts anew
            return
        held = t - self._blocked_since
        if held < 0.5 * self.yield_after_s:
            return
        if self._held_gap is None:  # half way: how far the robot ahead is (from here)
            self._held_gap = ((x, y), self._gap_ahead(pose, points, aim, (x, y))[0])
            return
        if held < self.yield_after_s:
            return
        self._blocked_since = t  # at most one such replan per yield_after_s
        origin, gap0 = self._held_gap
        self._held_gap = None
        gap, unmapped, ahead = self._gap_ahead(pose, points, aim, origin)
        if gap > gap0 + HELD_M:  # it moves away (gives way itself): wait on
            return
        if ahead is None:
            return
        if self._near_goal(pose) and self._goal_covered(pose, unmapped):
            self._short = True  # another robot stands on our goal: end the route short
            return
        if self._following(t, pose, ahead):  # behind a robot in a one-way lane: wait, not stuck
            self.controller.restart_progress(t)
            return
        self.yields += 1
        x, y = pose[0], pose[1]
        obstacles = obstacle_discs(ahead)
        target = self.route.next_position()
        detour = self.planner.plan((x, y), target, obstacles)
        free = self._remaining_path(pose)
        if detour is not None and not self._lane_free_path(detour):
            detour = None  # a way round through a lane we do not hold: not taken
        if detour is not None and (free is None or _reasonable_detour(detour, free)):
            self.replans += 1
            self._plan_leg(t, pose, ahead, keep_obstacles=True, keep_clock=True)
            return
        if self._give_ways_this_leg < MAX_GIVE_WAYS_PER_LEG and self._start_give_way(
                t, pose, ahead, parked=False, others=unmapped):
            self._give_ways_this_leg += 1
            return
        if detour is not None:  # a long way round is still better than none
            self.replans += 1
            self._plan_leg(t, pose, ahead, keep_obstacles=True, keep_clock=True)

    def _gap_ahead(self, pose: tuple[float, float, float], points: np.ndarray | None,
                   aim: tuple[float, float], origin: tuple[float, float]):
        """(distance [m] from `origin` to the nearest point the map does not explain within
        BLOCKING_RANGE_M of the pose toward `aim` (inf: none), all such points near (map
        frame), those of them ahead; None for none)."""
        unmapped = self._unmapped(map_points(pose, points))
        if unmapped is None:
            return math.inf, None, None
        # Ahead: toward the point we aim at (not the heading, which may be turning), in range.
        x, y = pose[0], pose[1]
        ux, uy = aim[0] - x, aim[1] - y
        rel = unmapped - np.array([x, y])
        dist = np.hypot(rel[:, 0], rel[:, 1])
        keep = (rel[:, 0] * ux + rel[:, 1] * uy > 0.0) & (dist <= BLOCKING_RANGE_M)
        if not keep.any():
            return math.inf, unmapped, None
        ahead = unmapped[keep]
        gap = np.hypot(ahead[:, 0] - origin[0], ahead[:, 1] - origin[1]).min()
        return float(gap), unmapped, ahead

    def _remaining_path(self, pose: tuple[float, float, float]) -> np.ndarray | None:
        """The polyline [m] still ahead on this leg: pose, corners, next vertex."""
        if self.route is None:
            return None
        return np.array([pose[:2], *self._corners, self.route.next_position()], dtype=float)

    def step(self, t: float, pose: tuple[float, float, float],
             points: np.ndarray | None) -> tuple[Command, Event, int]:
        route = self.route
        if route is None:
            return Command(0.0, 0.0, Status.REACHED), Event.NONE, -1
        ctl = self.controller
        self._remember(pose)
        ctl.set_movers(t, self._movers(pose, points))
        if self._give_way is not None:
            return self._step_give_way(t, pose, points), Event.NONE, -1
        if self._gate is not None:
            waiting = self._step_gate(t, pose, points)
            if waiting is not None:
                return waiting
        if self._plan_pending:
            self._plan_leg(t, pose)
        elif (self.planner is not None and ctl.retries > self._retries_seen
              and not ctl.recovering):
            # Back from a recovery: another way round what blocked us, if there is one.
            self._retries_seen = ctl.retries
            self.replans += 1
            self._plan_leg(t, pose, map_points(pose, points))
        cmd = ctl.step(t, pose, points)
        if cmd.status == Status.FAILED:
            goal = route.goal
            if route.is_last and self._near_goal(pose) and self._goal_covered(pose, self._unmapped(
                    map_points(pose, points))):
                return self._end_short(goal)
            self.cancel()
            return cmd, Event.FAILED, goal
        if self.planner is not None and cmd.status == Status.DRIVING:
            self._watch_blocked(t, pose, points, cmd)
            if self._short and route.is_last:
                return self._end_short(route.goal)
            if self._short:  # a lane's waiting spot another robot stands on: reached here
                self._short = False
                self._corners = []
                cmd = Command(0.0, 0.0, Status.REACHED)
            if self._give_way is not None:
                return self._step_give_way(t, pose, points), Event.NONE, -1
        for _ in range(2 * len(self._corners)):
            if cmd.status != Status.REACHED or not self._corners:
                break
            if self._corner_tight or self._corner_passable(pose):
                self._corners.pop(0)  # a corner of the path: on to the next point
                self._corner_tight = False
            else:  # the next point is round a wall's end: reach this corner itself first
                self._corner_tight = True
            self._aim(t, new_goal=False)
            cmd = ctl.step(t, pose, points)
        if cmd.status != Status.REACHED:
            return cmd, Event.NONE, -1
        if self.lanes is not None and not route.is_last and not self.lanes.may_start(
                route.next_waypoint, route.waypoints[route._k + 1], t):
            self._gate = (route.next_waypoint, True)  # wait here, at the lane's waiting spot
            self.gate_waits += 1
            return Command(0.0, 0.0, Status.DRIVING), Event.NONE, -1
        return self._pass_waypoint(t, pose, points, cmd)

    def _pass_waypoint(self, t: float, pose: tuple[float, float, float],
                       points: np.ndarray | None, cmd: Command) -> tuple[Command, Event, int]:
        """The next waypoint is reached: the goal (ARRIVED), or on to the next leg."""
        route = self.route
        ctl = self.controller
        last = route.is_last
        vertex = route.advance()
        if last:
            if self.lanes is not None:
                self.lanes.arrive(vertex, t)
            self.cancel()
            return cmd, Event.ARRIVED, vertex
        self._new_leg(vertex)
        if self._plan_pending:
            self._plan_leg(t, pose)
        else:
            self._aim(t, new_goal=False)
        # Steer toward the next waypoint right away (no standstill tick at a pass-through).
        cmd = ctl.step(t, pose, points)
        return cmd, Event.WAYPOINT, vertex


    def _step_gate(self, t: float, pose: tuple[float, float, float],
                   points: np.ndarray | None) -> tuple[Command, Event, int] | None:
        """At a lane's waiting spot: None once the lane is held (drive on), else stand (and
        wait: lane_gate.py)."""
        route = self.route
        u, advance = self._gate
        nxt = route.waypoints[route._k + 1] if advance else route.next_waypoint
        if self.lanes.may_start(u, nxt, t):
            self._gate = self._gate_corners = None
            self.controller.restart_progress(t)
            if advance:
                return self._pass_waypoint(t, pose, points, Command(0.0, 0.0, Status.REACHED))
            return None
        obstacles = obstacle_discs(self._unmapped(map_points(pose, points)))
        return self._gate_wait(t, pose, points, u, nxt, obstacles), Event.NONE, -1

    def _near_goal(self, pose: tuple[float, float, float]) -> bool:
        """Within `near_goal_m` of the goal, or of a lane's waiting spot next on the route,
        within the clearance of two robots side by side at least (the other waypoints count
        as reached farther off: waypoint_tolerance)."""
        route = self.route
        if self.near_goal_m is None or route is None:
            return False
        near = self.near_goal_m if route.is_last else max(self.near_goal_m,
                                                          self._pass_clearance_m())
        gx, gy = route.next_position()
        return math.hypot(pose[0] - gx, pose[1] - gy) <= near

    def _goal_covered(self, pose: tuple[float, float, float],
                      unmapped: np.ndarray | None) -> bool:
        """Another robot stands on the goal: the centre of what the map does not explain near
        the goal (map-frame points [m] within a radius of `near_goal_m`; their mean, a robot
        radius farther from us) is within the goal tolerance (the visit radius) +
        COVERED_MARGIN_M of the goal vertex, or COVERED_MARGIN_M nearer to it than we are.
        Of two robots after the same vertex, side by side, only the farther gives it up."""
        if unmapped is None or self.route is None:
            return False
        gx, gy = self.route.next_position()
        r = self.controller.config.robot_radius
        near = max(self.near_goal_m or 0.0, self.goal_tolerance + COVERED_MARGIN_M)
        rim = unmapped[np.hypot(unmapped[:, 0] - gx, unmapped[:, 1] - gy) <= r + near]
        if len(rim) == 0:
            return False
        cx, cy = robot_centre(rim, (pose[0], pose[1]), r)
        other = math.hypot(cx - gx, cy - gy)
        mine = math.hypot(pose[0] - gx, pose[1] - gy)
        return other <= min(near, max(self.goal_tolerance + COVERED_MARGIN_M,
                                      mine - COVERED_MARGIN_M))

    def _end_short(self, goal: int) -> tuple[Command, Event, int]:
        self.short_arrivals += 1
        self.route.advance()
        self.cancel()
        self._short = False
        return Command(0.0, 0.0, Status.REACHED), Event.ARRIVED, goal


SIGHT_MARGIN_M = 0.02  # [m] beyond the robot's radius: a line of sight past a wall's end
TIGHT_CORNER_M = 0.05  # [m] tolerance of a corner whose next point is not in sight
UNMAPPED_DISTANCE_M = 0.1  # [m] a laser point this close to a mapped wall is that wall
COVERED_MARGIN_M = 0.05  # [m] another robot's centre within the goal tolerance + this of the
# goal, or this nearer to it than we are, covers it


MAX_DETOUR_FACTOR = 1.5  # a way round another robot may be this much longer than the free way
MAX_DETOUR_EXTRA_M = 1.0  # [m] ... plus this
MAX_GIVE_WAYS_PER_LEG = 2  # then the usual recovery decides (a robot that does not move)


KEEP_RIGHT_SHARE = 0.5  # legs keep right by this share of the pass clearance (0: off)
KEEP_RIGHT_STEP_M = 1.0  # [m] a path kept right has a point at least this often


def keep_right(path: np.ndarray, offset_m: float, planner, room_m: float) -> np.ndarray:
    """The path (k, 2) [m] with its inner points moved `offset_m` to the right of the way
    (right-hand traffic: two robots driving an edge in opposite directions meet side by side),
    long segments first split every KEEP_RIGHT_STEP_M. Its ends stay (the vertices). A point
    moves only where it stays `room_m` from the walls, by half the offset else, or not at all;
    a segment that would then come nearer the walls than the planner's lethal radius keeps
    its points where they were. Unchanged with a planner that knows no walls."""
    distances = getattr(planner, "distances_to_obstacle", None)
    clear = getattr(planner, "segment_clear", None)
    if distances is None or clear is None:
        return path
    pts = [path[0]]
    for a, b in zip(path[:-1], path[1:], strict=True):
        n = max(1, int(math.ceil(math.hypot(*(b - a)) / KEEP_RIGHT_STEP_M)))
        pts += [a + (b - a) * (j / n) for j in range(1, n + 1)]
    pts = np.array(pts, dtype=float)
    if len(pts) < 3:
        return path
    way = pts[2:] - pts[:-2]  # the direction of travel at each inner point
    norm = np.hypot(way[:, 0], way[:, 1])
    norm[norm < 1e-9] = np.inf
    right = np.column_stack((way[:, 1], -way[:, 0])) / norm[:, None]
    moved = pts.copy()
    for f in (1.0, 0.5):
        trial = pts[1:-1] + f * offset_m * right
        ok = (distances(trial) >= room_m) & (moved[1:-1] == pts[1:-1]).all(axis=1)
        moved[1:-1][ok] = trial[ok]
    lethal = planner.inscribed_radius_m
    for _ in range(len(pts)):  # each round puts back at least one point, or ends
        shifted = (moved != pts).any(axis=1)
        bad = [i for i in range(len(pts) - 1) if (shifted[i] or shifted[i + 1])
               and not clear(moved[i], moved[i + 1], lethal)]
        if not bad:
            break
        for i in bad:
            moved[i:i + 2] = pts[i:i + 2]
    return moved


def _reasonable_detour(detour: np.ndarray, free: np.ndarray) -> bool:
    """A way round another robot worth taking instead of waiting for it to move."""
    return polyline_length(detour) <= MAX_DETOUR_FACTOR * polyline_length(free) + MAX_DETOUR_EXTRA_M


# ---------------------------------------------------------------------------------------------
# Navigation by an external planner (move_base): same interface as Navigator
