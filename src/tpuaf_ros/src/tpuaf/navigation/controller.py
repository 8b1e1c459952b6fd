"""The reactive local controller: (pose, obstacle points, target) -> velocity command.

Steers around obstacles and other robots seen by the laser (keeping right, so that two robots
meeting head-on in a corridor pass each other), and recovers when stuck: back off, wait, retry,
and after `max_retries` report the goal failed. Deterministic in its inputs (times [s], map-frame
poses [m, rad]); no clock, no ROS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from enum import Enum

import numpy as np
import tpuaf_core

from tpuaf.params import CONTROLLER_DEFAULTS as _D  # the defaults shared with the agent node

# [m] a goal is reached this close: the core's one default (vertex_geometry.hpp), which the
# maps' goal_tolerance setting also reads
GOAL_TOLERANCE_M = float(tpuaf_core.DEFAULT_GOAL_TOLERANCE_M)

# ---------------------------------------------------------------------------------------------
# Local controller


@dataclass
class ControllerConfig:
    """Parameters of the local controller (units in the comments)."""

    max_linear_speed: float = 1.0  # [m/s]
    max_angular_speed: float = _D.max_angular_speed  # [rad/s]
    robot_radius: float = 0.105  # [m]
    safety_margin: float = _D.safety_margin  # [m] kept between the robot's disc and any laser return
    plan_margin: float = _D.plan_margin  # [m] wider clearance wanted when choosing a heading
    lookahead: float = 1.0  # [m] free length wanted along the chosen heading
    slow_distance: float = 1.2  # [m] free length below which the speed drops linearly (0.8 m
    # let robots meeting in a corridor close in faster than 5 Hz scans see: contacts); at most
    # SLOW_TIME_S of driving at the top speed, not under SLOW_FLOOR_M (`slow_m`)
    heading_gain: float = 2.5  # [1/s] w = gain * heading error
    turn_in_place: float = 1.0  # [rad] heading error above which the robot only turns
    keep_right: float = 0.2  # [rad] extra cost of passing an obstacle on its right side
    n_headings: int = 24  # candidate headings around the robot
    stuck_timeout_s: float = _D.stuck_timeout_s  # [s] no progress of progress_m toward the target -> recover
    progress_m: float = 0.15  # [m]
    backoff_s: float = _D.backoff_s  # [s] reversing time of one recovery
    backoff_speed: float = 0.15  # [m/s]
    retry_wait_s: float = 1.0  # [s] standing still after backing off, before the retry
    max_retries: int = _D.max_retries  # recoveries before the goal is reported failed

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name in _NON_NEGATIVE:
                ok = value >= 0
            else:
                ok = value > 0
            if not ok or not math.isfinite(value):
                raise ValueError(f"controller parameter {f.name} must be "
                                 f"{'>= 0' if f.name in _NON_NEGATIVE else '> 0'}"
                                 f", got {value!r}")


# Physics runtime timing (docs/RUNTIMES.md), read by runtimes.config and the travel-time model.
PHYSICS_STEP_S = 0.05  # [s] world step
CONTROL_PERIOD_S = 0.1  # [s] agents' control period (the fleet's 10 Hz odometry)
SLOW_TIME_S = 1.2  # [s] the slow-down zone is this many seconds at top speed (1.2 m at 1 m/s):
# a slow robot (a Burger at 0.1 m/s in a 0.5 m aisle) need not crawl its whole way
SLOW_FLOOR_M = 0.3  # [m] the slow-down zone is never shorter
CONTACT_M = 0.01  # [m] a laser point this close to the disc is touching it
APPROACH_MPS = 0.05  # [m/s] least speed toward a target nearer than any obstacle ahead
SNUG_MARGIN_M = 0.01  # [m] clearance of the last-resort (slow) headings
PASS_HORIZON_S = 2.0  # [s] another robot ahead within this many seconds at top speed: pass it
PASS_BIAS_RAD = 0.35  # [rad] ... aiming this much beside the target, away from it
NARROW_COST_RAD = 0.5  # [rad] extra cost of a heading free with the safety margin only (not the
# plan margin): a wide heading is chosen over it only if it turns less than this much farther
_NON_NEGATIVE = ("keep_right", "retry_wait_s", "max_retries", "safety_margin", "plan_margin")


class Status(Enum):
    DRIVING = "driving"
    REACHED = "reached"  # within tolerance of the target
    RECOVERING = "recovering"  # backing off or waiting before a retry
    FAILED = "failed"  # gave up after max_retries recoveries


@dataclass(frozen=True)
class Command:
    v: float  # [m/s]
    w: float  # [rad/s]
    status: Status


STOP_FAILED = Command(0.0, 0.0, Status.FAILED)


class LocalController:
    """Drives toward one target point at a time (see module docstring).

    `set_target` starts a new target (and resets the recovery counter when `new_goal`);
    `step(t, pose, points)` returns the command for pose (x, y, th) at time t, with laser
    points (k, 2) in the robot frame (from `scan_points`; None = no laser)."""

    _DRIVE, _BACK, _WAIT, _FAILED = range(4)

    def __init__(self, config: ControllerConfig | None = None):
        self.config = config or ControllerConfig()
        c = self.config
        k = np.arange(c.n_headings)
        self._headings = wrap_angle_array(-math.pi + 2.0 * math.pi * k / c.n_headings)
        self.target: tuple[float, float] | None = None
        self.tolerance = GOAL_TOLERANCE_M
        self.reverse = False  # drive to the target backward (giving way: back the way we came)
        self.retries = 0
        self._state = self._DRIVE
        self._state_t = 0.0
        self._best = math.inf
        self._best_t = 0.0
        self._keep_clock = False  # the next target's first distance keeps _best_t
        self._back_w = 0.0
        # Robot-frame laser points of other robots (the navigator's points the map does not
        # explain: they may move toward us) at the time of `set_movers`: one in the way ahead
        # bends the way to the target (`_pass_bias`). None: none or not known.
        self.movers: np.ndarray | None = None
        self._movers_t: float | None = None
        self._shared: np.ndarray | None = None  # the movers of the current step (its frame)
        # The last scan given to `relevant` and its result: the navigator and the step filter
        # the same scan once per tick.
        self._relevant_of: np.ndarray | None = None
        self._relevant: np.ndarray | None = None

    def set_target(self, xy: tuple[float, float], tolerance_m: float, t: float,
                   new_goal: bool = True, reverse: bool = False,
                   keep_clock: bool = False) -> None:
        """`reverse`: drive to it backward (the rear as the front: same rules, v negated).
        `keep_clock`: the stuck timer runs on from the last progress (a replan round what
        holds the robot is no progress)."""
        self.target = (float(xy[0]), float(xy[1]))
        self.tolerance = float(tolerance_m)
        self.reverse = bool(reverse)
        if new_goal:
            self.retries = 0
            self._state = self._DRIVE
        self._best = math.inf
        self._keep_clock = bool(keep_clock) and not new_goal
        if not self._keep_clock:
            self._best_t = float(t)

    def set_movers(self, t: float, points: np.ndarray | None) -> None:
        """The points (k, 2) [m, robot frame] of the scan of the steps at time t [s] that may
        move toward the robot (steps at another time see none)."""
        self.movers, self._movers_t = points, float(t)

    def restart_progress(self, t: float) -> None:
        """Forget the progress made so far toward the target (the stuck timer restarts at t)."""
        self._best = math.inf
        self._best_t = float(t)
        self._keep_clock = False
        if self._state in (self._BACK, self._WAIT):
            self._state_t = float(t)

    def resume_driving(self, t: float) -> None:
        """Leave a recovery (back off, wait) at t [s] and drive again, the retries kept."""
        if self._state != self._FAILED:
            self._state = self._DRIVE
        self._best = math.inf
        self._best_t = float(t)
        self._keep_clock = False

    # -- geometry ---------------------------------------------------------------------------

    def free_lengths(self, points: np.ndarray | None, headings: np.ndarray,
                     margin: float | None = None) -> np.ndarray:
        """Free travel length [m] of the robot's disc, grown by `margin` [m] (default the safety
        margin), along each heading [rad]: how far it can translate before touching a point,
        capped at `self.cap`. Points beside or behind the robot do not block (moving away from
        them is allowed)."""
        c = self.config
        return self._free(points, np.atleast_1d(headings),
                          (c.safety_margin if margin is None else margin,))[0]

    @property
    def cap(self) -> float:
        """Longest free length that matters [m]."""
        c = self.config
        return max(c.lookahead, c.slow_distance) + 0.5

    def _free(self, points: np.ndarray | None, headings: np.ndarray,
              margins: tuple[float, ...]) -> list[np.ndarray]:
        cap = self.cap
        if points is None or len(points) == 0:
            return [np.full(len(headings), cap) for _ in margins]
        ch, sh = np.cos(headings)[:, None], np.sin(headings)[:, None]
        px, py = points[:, 0][None, :], points[:, 1][None, :]
        along = px * ch + py * sh
        lat2 = py * ch - px * sh
        lat2 *= lat2
        ahead = along > 0
        out = []
        for margin in margins:
            rm = self.config.robot_radius + margin
            hit = ahead & (lat2 < rm * rm)
            reach = np.where(hit, along - np.sqrt(np.maximum(rm * rm - lat2, 0.0)), cap)
            out.append(np.minimum(np.maximum(reach.min(axis=1), 0.0), cap))
        return out

    @property
    def slow_m(self) -> float:
        """[m] free length below which the speed drops linearly: slow_distance, at most
        SLOW_TIME_S at top speed, at least SLOW_FLOOR_M."""
        c = self.config
        return min(c.slow_distance, max(SLOW_FLOOR_M, SLOW_TIME_S * c.max_linear_speed))

    @property
    def reach_m(self) -> float:
        """[m] from the base beyond which obstacle points cannot matter (cap + radius + the
        larger margin)."""
        c = self.config
        return self.cap + c.robot_radius + max(c.plan_margin, c.safety_margin)

    def relevant(self, points: np.ndarray | None) -> np.ndarray | None:
        """The points close enough to matter (within reach_m)."""
        if points is None or len(points) == 0:
            return None
        if points is self._relevant_of:
            return self._relevant
        r = self.reach_m
        near = points[:, 0] * points[:, 0] + points[:, 1] * points[:, 1] < r * r
        self._relevant_of, self._relevant = points, (points[near] if near.any() else None)
        return self._relevant

    # -- control ----------------------------------------------------------------------------

    def step(self, t: float, pose: tuple[float, float, float],
             points: np.ndarray | None) -> Command:
        movers = self.movers if self._movers_t == float(t) else None
        if self.reverse:  # the robot turned round on paper: its rear leads
            x, y, th = pose
            flipped = None if points is None else -np.asarray(points)
            self._shared = None if movers is None else -np.asarray(movers)
            cmd = self._step(t, (x, y, wrap_angle(th + math.pi)), flipped)
            return Command(-cmd.v, cmd.w, cmd.status)
        self._shared = movers
        return self._step(t, pose, points)

    def _step(self, t: float, pose: tuple[float, float, float],
              points: np.ndarray | None) -> Command:
        if self.target is None:
            return Command(0.0, 0.0, Status.REACHED)
        c = self.config
        x, y, th = pose
        dx, dy = self.target[0] - x, self.target[1] - y
        dist = math.hypot(dx, dy)
        if self._state == self._FAILED:
            return STOP_FAILED
        if dist <= self.tolerance:
            self._state = self._DRIVE
            return Command(0.0, 0.0, Status.REACHED)
        points = self.relevant(points)
        if self._state == self._BACK:
            if t - self._state_t < c.backoff_s:
                rear = self.free_lengths(points, np.array([math.pi]))[0]
                v = -c.backoff_speed if rear > c.backoff_speed * 0.5 else 0.0
                return Command(v, self._back_w, Status.RECOVERING)
            self._state, self._state_t = self._WAIT, t
        if self._state == self._WAIT:
            if t - self._state_t < c.retry_wait_s:
                return Command(0.0, 0.0, Status.RECOVERING)
            self._state = self._DRIVE
            self._best, self._best_t = dist, t
        # Progress watch: progress_m, or half of what is left to the tolerance (the last
        # centimetres next to a wall are driven slowly).
        needed = min(c.progress_m, 0.5 * max(self._best - self.tolerance, 0.0) + 0.01)
        if self._best == math.inf and self._keep_clock:
            self._best, self._keep_clock = dist, False  # the clock runs on (set_target)
        elif dist < self._best - needed or self._best == math.inf:
            self._best, self._best_t = dist, t
        elif t - self._best_t > c.stuck_timeout_s:
            if self.retries >= c.max_retries:
                self._state = self._FAILED
                return STOP_FAILED
            self.retries += 1
            self._state, self._state_t = self._BACK, t
            # Turn while reversing, alternating sides between retries.
            self._back_w = 0.5 * (1 if self.retries % 2 else -1)
            return Command(0.0, 0.0, Status.RECOVERING)
        escape = self._escape(points)
        if escape is not None:
            return escape
        return self._drive(dist, wrap_angle(math.atan2(dy, dx) - th), points)

    def _escape(self, points: np.ndarray | None) -> Command | None:
        """Touching something (a laser point within CONTACT_M of the disc): move straight away
        from it, backward when it is in front, forward when behind, so that two robots in
        contact part instead of pushing on (the simulator stops a robot that would overlap)."""
        if points is None or len(points) == 0:
            return None
        c = self.config
        d = np.hypot(points[:, 0], points[:, 1])
        k = int(np.argmin(d))
        if d[k] >= c.robot_radius + CONTACT_M:
            return None
        speed = min(c.backoff_speed, 0.5 * c.max_linear_speed)
        ahead = points[k, 0] > 0.0
        room = self.free_lengths(points, np.array([math.pi if ahead else 0.0]), margin=0.0)[0]
        if room < 0.5 * speed:
            return None  # wedged: the usual headings and recovery decide
        return Command(-speed if ahead else speed, 0.0, Status.DRIVING)

    def _pass_bias(self, dist: float, bearing: float) -> float:
        """[rad] added to the target's bearing while another robot (a mover) is in the way
        ahead, nearer than the target and within PASS_HORIZON_S at top speed: PASS_BIAS_RAD
        away from it, so that two robots meeting head-on start passing each other early
        instead of meeting nose to nose; else 0."""
        movers = self._shared
        if movers is None or len(movers) == 0:
            return 0.0
        c = self.config
        ux, uy = math.cos(bearing), math.sin(bearing)
        along = movers[:, 0] * ux + movers[:, 1] * uy
        lat = movers[:, 1] * ux - movers[:, 0] * uy
        horizon = min(dist, PASS_HORIZON_S * c.max_linear_speed)
        way = (along > 0.0) & (along < horizon) & (np.abs(lat) < 2.0 * c.robot_radius
                                                      + c.plan_margin)
        if not way.any():
            return 0.0
        # Away from the side it is on (both robots then turn the same way: to their right
        # when each sees the other on its left), to the right when it is straight ahead.
        return -PASS_BIAS_RAD if lat[way].mean() >= 0.0 else PASS_BIAS_RAD

    def _drive(self, dist: float, bearing: float, points: np.ndarray | None) -> Command:
        c = self.config
        bias = self._pass_bias(dist, bearing)
        bearing = wrap_angle(bearing + bias)  # beside the target, away from another robot
        to_target = None if bias else dist  # [m] along the heading straight to the target
        need = min(dist, c.lookahead)
        # Snug: the bare disc plus 1 cm. A robot already closer to a wall beside it than the
        # safety margin (a narrow aisle, a Burger 7 cm off its centre) may still drive along
        # it, slowly, instead of turning in place for good.
        margins = (c.safety_margin, c.plan_margin, min(c.safety_margin, SNUG_MARGIN_M))
        # Fast path: the straight line to the target is open with the plan margin.
        safe, wide, _ = self._free(points, np.array([bearing]), margins)
        if wide[0] >= need:
            return self._command(bearing, float(safe[0]), to_target)
        headings = np.append(self._headings, bearing)
        safe, wide, snug = self._free(points, headings, margins)
        rel = wrap_angle_array(headings - bearing)
        # Passing on the left of the target direction (heading > bearing) costs keep_right.
        cost = np.abs(rel) + c.keep_right * (rel > 1e-9)
        # Only headings within 90 degrees of the target direction make progress.
        forward = np.abs(rel) <= 0.5 * math.pi + 1e-9
        room = safe
        # The wide clearance is preferred, but not at any price: a heading with only the
        # safety margin costs NARROW_COST_RAD more (a door narrower than the plan margin is
        # driven straight through, not turned away from toward the open room beside it).
        wide_ok = (wide >= need) & forward
        ok = wide_ok | ((safe >= need) & forward)
        cost = cost + np.where(wide_ok, 0.0, NARROW_COST_RAD)
        if not ok.any():  # step aside: any direction with a little room
            ok = safe >= min(need, 0.5)
        if not ok.any():
            ok, room = (snug >= need) & forward, 0.5 * snug
        if not ok.any():
            ok, room = snug >= min(need, 0.5), 0.5 * snug
        if ok.any():
            k = int(np.argmin(np.where(ok, cost, np.inf)))
            return self._command(float(headings[k]), float(room[k]),
                                 to_target if k == len(headings) - 1 else None)
        k = int(np.argmax(safe - 0.1 * np.abs(rel)))  # the most open direction: turn there
        w = max(-c.max_angular_speed, min(c.max_angular_speed, c.heading_gain * headings[k]))
        return Command(0.0, float(w), Status.DRIVING)

    def _command(self, heading: float, ahead: float, target_m: float | None = None) -> Command:
        """Drive along `heading` (relative [rad]) with `ahead` [m] free; `target_m` [m] = the
        distance to the target when heading straight for it."""
        c = self.config
        w = max(-c.max_angular_speed, min(c.max_angular_speed, c.heading_gain * heading))
        if abs(heading) > c.turn_in_place:
            return Command(0.0, w, Status.DRIVING)
        scale = min(1.0, ahead / self.slow_m)
        if target_m is not None and ahead >= target_m:
            # The target is nearer than the obstacle: do not crawl the last centimetres.
            scale = max(scale, min(1.0, APPROACH_MPS / c.max_linear_speed))
        v = c.max_linear_speed * scale * math.cos(heading)
        return Command(max(0.0, v), w, Status.DRIVING)

    @property
    def failed(self) -> bool:
        return self._state == self._FAILED

    @property
    def recovering(self) -> bool:
        """Backing off or waiting before a retry."""
        return self._state in (self._BACK, self._WAIT)


def wrap_angle(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def wrap_angle_array(a: np.ndarray) -> np.ndarray:
    return (np.asarray(a) + math.pi) % (2.0 * math.pi) - math.pi


def navigator_give_up_s(c: ControllerConfig | None = None) -> float:
    """[s] for the navigator to report a goal failed when the robot cannot move at all: no
    progress for stuck_timeout_s, then max_retries times (back off, wait, no progress again)."""
    c = c or ControllerConfig()
    return (c.max_retries + 1) * c.stuck_timeout_s + c.max_retries * (c.backoff_s + c.retry_wait_s)


def retry_wait_for(robot_index: int) -> float:
    """[s] wait of a recovery for robot `robot_index`: staggered over 4 robots (0.5-2 s), so
    that two robots stuck on each other do not retry in lock-step (a symmetric deadlock)."""
    return 0.5 + 0.5 * (int(robot_index) % 4)
