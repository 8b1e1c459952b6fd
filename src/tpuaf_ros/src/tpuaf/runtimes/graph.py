"""Batch runtime: an event-driven simulation of the team without ROS (the reference runtime).

Robots drive shortest paths along graph edges at nominal speed (straight segments between
vertex positions, each taking edge length / speed) and decide on reaching their goal. Team
messages go through `TeamBus` (delay, loss). Ground truth (uncertainty, idleness, interference)
is measured by `tpuaf.metrics.RunRecorder` from the true, piecewise-linear positions. Runs are
deterministic for a seed.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ..errors import TpuafError
from ..maps import load_map, start_vertices
from ..metrics import RunRecorder
from ..navigation import GraphRoute
from ..policies import REGISTRY, Policy, RobotContextBase
from .bus import TeamBus

_ARRIVE, _WAKE, _DELIVER = 0, 1, 2
STAY_S = 1.0  # [s] a robot whose goal is its own vertex dwells this long, then visits it again
DEFAULT_RETRY_S = 1.0  # [s] a policy that waits without asking for a wake-up is asked again after


class ConfigError(TpuafError):
    """An invalid run configuration; the message names the field and the valid choices."""


@dataclass
class RunConfig:
    map: str = "grid"
    strategy: str = "tpuaf"
    robots: int = 4
    duration_s: float = 3600.0
    seed: int = 0
    delay_s: float = 0.0  # team message delay [s]
    loss: float = 0.0  # probability that one recipient loses one message
    strategy_params: dict[str, Any] = field(default_factory=dict)
    sample_period_s: float = 1.0  # time series period [s]

    def validate(self) -> None:
        names = REGISTRY.names()
        if self.strategy.lower() not in names:
            raise ConfigError(f"unknown strategy '{self.strategy}' (valid: {', '.join(names)})")
        self.strategy = self.strategy.lower()
        if not (isinstance(self.robots, int) and self.robots >= 1):
            raise ConfigError(f"robots must be an integer >= 1, got {self.robots!r}")
        if not (self.duration_s > 0 and math.isfinite(self.duration_s)):
            raise ConfigError(
                f"duration must be a finite number of seconds > 0, got {self.duration_s}"
            )
        if not (self.delay_s >= 0 and math.isfinite(self.delay_s)):
            raise ConfigError(f"delay must be >= 0 s, got {self.delay_s}")
        if not 0.0 <= self.loss <= 1.0:
            raise ConfigError(f"loss must be a probability in [0, 1], got {self.loss}")
        if not self.sample_period_s > 0:
            raise ConfigError(f"sample period must be > 0 s, got {self.sample_period_s}")

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


class _Robot(RobotContextBase):
    """One simulated robot; also the RobotContext its policy sees."""

    def __init__(self, engine: BatchRun, index: int, start_vertex: int, policy: Policy, rng):
        self.engine = engine
        self.robot = index
        self.n_robots = engine.config.robots
        self.patrol_map = engine.patrol_map
        self.rng = rng
        self.policy = policy
        self._start_vertex = start_vertex
        self._current = start_vertex
        position = engine.patrol_map.positions[start_vertex].astype(float)
        self._start_position = (float(position[0]), float(position[1]))
        # Current straight segment: from p0 at t0 to p1 at t1.
        self.p0 = position.copy()
        self.p1 = position.copy()
        self.t0 = self.t1 = 0.0
        self.route: GraphRoute | None = None  # shared with the ROS navigator
        self.goal: int | None = None
        self.travelled_m = 0.0
        self.travel_time_s = 0.0
        self.wake_pending = False
        self.redirect: int | None = None  # a new goal asked for while driving

    # --- RobotContext ---
    @property
    def now(self) -> float:
        return self.engine.now

    @property
    def position(self) -> tuple[float, float]:
        p = self.engine.position_of(self.robot, self.engine.now)
        return (float(p[0]), float(p[1]))

    def send(self, message) -> None:
        self.engine.bus.send(self.robot, message, self.engine.now, self.engine.schedule_delivery)

    def wake_at(self, time: float) -> None:
        self.engine.push(max(time, self.engine.now), _WAKE, self.robot)
        self.wake_pending = True

    def change_goal(self, vertex: int) -> None:
        """Redirect a moving robot: it finishes its current edge, then heads to `vertex`."""
        self.redirect = self.checked_vertex(vertex)


class BatchRun:
    """One batch run. `run()` returns the summary; the recorder holds visits and time series."""

    def __init__(self, config: RunConfig, patrol_map=None):
        config.validate()
        self.config = config
        self.patrol_map = patrol_map if patrol_map is not None else load_map(config.map)
        graph = self.patrol_map.graph  # validates the graph (MapError on a bad one)
        self.graph = graph
        self.speed = float(self.patrol_map.settings.nominal_speed)
        self.now = 0.0
        self._events: list = []
        self._seq = 0
        seed = int(config.seed)
        self.bus = TeamBus(
            config.robots, config.delay_s, config.loss, np.random.default_rng([seed, 1])
        )
        cls = REGISTRY.get(config.strategy)
        starts = start_vertices(self.patrol_map, config.robots)
        self.robots = [
            _Robot(
                self, i, starts[i], cls(config.strategy_params), np.random.default_rng([seed, 2, i])
            )
            for i in range(config.robots)
        ]
        self.recorder = RunRecorder(
            self.patrol_map, config.robots, sample_period_s=config.sample_period_s
        )
        self._last_positions_time = -1.0
        # Segment table of all robots, for vectorised positions.
        self._p0 = np.array([r.p0 for r in self.robots])
        self._velocity = np.zeros_like(self._p0)
        self._t0 = np.zeros(config.robots)
        self._t1 = np.zeros(config.robots)

    # --- event queue ---
    def push(self, time: float, kind: int, payload) -> None:
        self._seq += 1
        heapq.heappush(self._events, (time, kind, self._seq, payload))

    def schedule_delivery(self, time: float, message, recipients: list[int]) -> None:
        self.push(time, _DELIVER, (message, recipients))

    def position_of(self, robot: int, t: float) -> np.ndarray:
        """True position of one robot at time t [m], from the same segment table."""
        elapsed = min(max(t - self._t0[robot], 0.0), self._t1[robot] - self._t0[robot])
        return self._p0[robot] + self._velocity[robot] * elapsed

    def positions(self, t: float) -> np.ndarray:
        """True positions of all robots at time t [m], vectorised over robots."""
        elapsed = np.minimum(np.maximum(t - self._t0, 0.0), self._t1 - self._t0)
        return self._p0 + self._velocity * elapsed[:, None]

    def _deliver_ready(self) -> None:
        ready = self.bus.ready
        robots = self.robots
        while ready:
            message, recipients = ready.popleft()
            for r in recipients:
                robot = robots[r]
                robot.policy.on_message(message, robot)
            self.bus.stats.delivered += len(recipients)

    # --- robot logic ---
    def _decide(self, robot: _Robot) -> None:
        robot.wake_pending = False
        goal = robot.call_decide(robot.policy)
        robot.redirect = None
        if goal is None:
            robot.goal = None
            if not robot.wake_pending:
                robot.wake_at(self.now + DEFAULT_RETRY_S)
            return
        robot.goal = goal
        here = robot.current_vertex
        robot.route = GraphRoute(self.graph, self.patrol_map.positions, here, goal)
        self._start_segment(robot)

    def _start_segment(self, robot: _Robot) -> None:
        here, nxt = robot.current_vertex, robot.route.next_waypoint
        robot.p0 = self.patrol_map.positions[here].astype(float)
        robot.p1 = self.patrol_map.positions[nxt].astype(float)
        robot.t0 = self.now
        if nxt == here:
            duration = STAY_S
        else:
            length = self.graph.edge_length(here, nxt)
            duration = length / self.speed
            robot.travelled_m += length
            robot.travel_time_s += duration
        robot.t1 = self.now + duration
        i = robot.robot
        self._p0[i], self._t0[i], self._t1[i] = robot.p0, robot.t0, robot.t1
        self._velocity[i] = (robot.p1 - robot.p0) / duration  # [m/s] along the straight segment
        self.push(robot.t1, _ARRIVE, robot.robot)

    def _arrive(self, robot: _Robot) -> None:
        vertex = robot.route.advance()
        robot._current = vertex
        robot.p0 = robot.p1
        if robot.redirect is not None and robot.goal is not None:
            robot.goal, robot.redirect = robot.redirect, None
            robot.route = GraphRoute(self.graph, self.patrol_map.positions, vertex, robot.goal)
            if vertex != robot.goal:
                self._start_segment(robot)
                return
        elif not robot.route.done:
            self._start_segment(robot)  # pass-through vertex: not a visit
            return
        self.recorder.record_visit(robot.robot, vertex, self.now)
        robot.goal = None
        self._decide(robot)

    def _record_positions(self, t: float) -> None:
        if t > self._last_positions_time:
            self.recorder.record_positions(t, self.positions(t))
            self._last_positions_time = t

    # --- main loop ---
    def run(self, progress: Callable[[float], None] | None = None) -> dict:
        """Simulate until duration_s. `progress(now)` is called now and then."""
        end = float(self.config.duration_s)
        self._record_positions(0.0)
        for robot in self.robots:
            robot.policy.start(robot)
        for robot in self.robots:
            self.recorder.record_visit(robot.robot, robot.current_vertex, 0.0)
        self._deliver_ready()
        for robot in self.robots:
            self._decide(robot)
            self._deliver_ready()
        next_progress = 0.0
        events = self._events
        while events and events[0][0] <= end:
            time, kind, _, payload = heapq.heappop(events)
            if time > self.now:
                self._record_positions(time)
                self.now = time
            if kind == _ARRIVE:
                self._arrive(self.robots[payload])
            elif kind == _WAKE:
                robot = self.robots[payload]
                if robot.goal is None:
                    self._decide(robot)
            else:
                message, recipients = payload
                self.bus.ready.append((message, recipients))
            self._deliver_ready()
            if progress is not None and self.now >= next_progress:
                progress(self.now)
                next_progress = self.now + end / 200.0
        self._record_positions(end)
        self.now = end
        if progress is not None:
            progress(end)
        return self.summary()

    def effective_config(self) -> dict:
        """Everything that determines this run, with defaults resolved (written to config.yaml)."""
        from .. import __version__

        settings = asdict(self.patrol_map.settings)
        return {
            "runtime": "batch",
            "tpuaf_version": __version__,
            **self.config.to_dict(),
            "strategy_params": dict(self.robots[0].policy.params),
            "map_name": self.patrol_map.name,
            "map_source": str(self.patrol_map.source) if self.patrol_map.source else "built-in",
            "map_settings": settings,
            "start_vertices": [
                int(self.patrol_map.vertex_ids[r.start_vertex]) for r in self.robots
            ],
            "motion": "straight segments between vertices, edge length / nominal speed each",
        }

    def summary(self) -> dict:
        summary = self.recorder.summary(self.now)
        summary["messages"] = asdict(self.bus.stats)
        return summary
