"""Graph runtime: an event-driven simulation of the team without ROS (the reference runtime).

The event loop is the C++ core's `tpuaf_core.GraphEngine` (engine.cpp), the only one: robots
drive shortest paths along graph edges at nominal speed (straight segments between vertex
positions, each taking edge length / speed), the team bus delays and loses messages, faults
(deaths, `--fail-random`, stalls) are injected at their times, heartbeats (heartbeats.cpp, loss
draws from the streams [seed, 4, sender]) feed every robot's teammate liveness, and the
ground-truth recorder measures visits, idleness, interference and X. Runs are deterministic
for a seed. Two kinds of strategies:

- a strategy of the core (`CoreStrategyPolicy`: tpuaf, tpuaf_plus) runs in C++ between start
  and finish; its messages go straight to the other robots' C++ state;
- any other strategy is the Python `Policy` it is, called back from C++ only at its decisions,
  message deliveries, goal failures and lost teammates, with a `RobotContext`.

`GraphRun` has the interface every runtime's run has (config, patrol_map, now, recorder,
run(progress), summary(), effective_config()).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import asdict

import numpy as np

from tpuaf.maps import load_map, start_vertices
from tpuaf.measure.metrics import RecorderView, RunRecorder
from tpuaf.navigation import navigator_give_up_s
from tpuaf.policies import REGISTRY, RobotContextBase
from tpuaf.policies.core import CoreStrategyPolicy
from tpuaf.robot.lanes import narrow_headway_s
from tpuaf.robot.machine import DEFAULT_RETRY_S, STAY_S, announced_vertex
from tpuaf.robot.model import AUTO, choose_robot
from tpuaf.runtimes.base import TeamRun, liveness_summary
from tpuaf.runtimes.config import RunConfig, run_description, run_robot, travel_map
from tpuaf.runtimes.faults import DEATH
from tpuaf.team.bus import BusStats, bus_stream
from tpuaf.team.liveness import heartbeat_streams


def _recorder_default(name: str) -> float:
    """A RunRecorder keyword default (refractory_s, max_substep_s, field_merge_s)."""
    return float(inspect.signature(RunRecorder).parameters[name].default)


def _rng_stream(seed: int, *key: int):
    import tpuaf_core

    return tpuaf_core.NumpyPcg64(np.random.default_rng([seed, *key]).bit_generator.state)


def one_way_layer(source_map, plan_map, body):
    """The lane layer with one-way lanes of `source_map` (the geometry) for the footprint of
    `body` (a RobotModel), oriented on `plan_map`'s travel; None without lanes."""
    from tpuaf.navigation.planner import shared_planner
    from tpuaf.robot.lanes import lane_layer

    return lane_layer(shared_planner(source_map, body.radius_m), source_map, plan_map, True)


def make_run(config: RunConfig, patrol_map=None):
    """The graph runtime's run of `config` (the C++ event loop)."""
    config.validate()
    return GraphRun(config, patrol_map)


class _GraphRobot(RobotContextBase):
    """The RobotContext a Python policy sees, backed by the C++ engine."""

    def __init__(self, run: GraphRun, index: int, start_vertex: int, policy, rng):
        self._engine = run._engine
        self.robot = index
        self.n_robots = run.config.robots
        self.patrol_map = run.patrol_map
        self.rng = rng
        self.policy = policy
        self._start_vertex = start_vertex
        p = run.patrol_map.positions[start_vertex]
        self._start_position = (float(p[0]), float(p[1]))

    @property
    def now(self) -> float:
        return self._engine.now

    @property
    def current_vertex(self) -> int:
        return self._engine.current_vertex(self.robot)

    @property
    def _current(self) -> int:
        return self._engine.current_vertex(self.robot)

    @property
    def travelled_m(self) -> float:
        return self._engine.travelled_m(self.robot)

    @property
    def travel_time_s(self) -> float:
        return self._engine.travel_time_s(self.robot)

    @property
    def average_speed(self) -> float:
        return self._engine.average_speed(self.robot)

    @property
    def position(self) -> tuple[float, float]:
        return self._engine.position(self.robot)

    def send(self, message) -> None:
        self._engine.send(self.robot, message, announced_vertex(message))

    def wake_at(self, time: float) -> None:
        self._engine.wake_at(self.robot, float(time))

    def change_goal(self, vertex: int) -> None:
        """Redirect a moving robot: it finishes its current edge, then heads to `vertex`."""
        self._engine.change_goal(self.robot, self.checked_vertex(vertex))


class _PythonTeam:
    """The callbacks the C++ loop makes into Python policies (only at their decisions)."""

    def __init__(self, robots: list[_GraphRobot]):
        self.robots = robots

    def start(self, i: int) -> None:
        robot = self.robots[i]
        robot.policy.start(robot)

    def decide(self, i: int):
        robot = self.robots[i]
        return robot.call_decide(robot.policy)

    def on_message(self, i: int, message) -> None:
        robot = self.robots[i]
        robot.policy.on_message(message, robot)

    def on_goal_failed(self, i: int, vertex: int) -> None:
        robot = self.robots[i]
        robot.policy.on_goal_failed(vertex, robot)

    def on_teammate_lost(self, i: int, lost: int) -> None:
        robot = self.robots[i]
        hook = getattr(robot.policy, "on_teammate_lost", None)
        if hook is not None:
            hook(int(lost), robot)


class _Bus:
    """The run's bus as the results writer reads it: only the counters."""

    def __init__(self, engine):
        self._engine = engine

    @property
    def stats(self) -> BusStats:
        sent, delivered, lost = self._engine.bus_stats
        return BusStats(sent=sent, delivered=delivered, lost=lost)


class GraphRecorder(RecorderView):
    """The read side of the C++ event loop's recorder (what results.ResultsWriter reads); the
    loop feeds it itself."""

    def __init__(self, run: GraphRun):
        self._engine = run._engine
        self._core = run._engine.recorder
        self.patrol_map = run.patrol_map
        self.n_robots = run.config.robots
        # [m/s] the survivors' ideal of the recovery metrics (RunRecorder's default)
        self.speed_mps = float(run.patrol_map.settings.nominal_speed)
        # [s] the survivors' teammate timeout (the floor at detection)
        self.teammate_timeout_s = float(run.config.teammate_timeout_s)
        # Runs with deaths keep every visit: the recovery metrics read the dead robots' own.
        self._keep_visits = any(f.kind == DEATH for f in run.faults)
        self.n_vertices = int(run.patrol_map.num_vertices)
        self.start_time = 0.0
        self.sample_period_s = float(run.config.sample_period_s)
        self.d_if = float(run.patrol_map.settings.interference_distance)
        self.ground_truth = True
        self._start_view()

    def finish(self, end_time: float) -> None:
        """The loop's recorder brought to the loop's now (the run's end)."""
        self._engine.finish()

    def _flush(self) -> None:
        self._engine.finish()

    def timeseries_since(self, first: int) -> list[dict]:
        """The 1 Hz rows from index `first` on, not cached here."""
        return self._core.timeseries(first)

    def forget_timeseries_before(self, first: int) -> None:
        """The recorder drops the rows before index `first` (a results writer has them on
        disk: a long run's memory stays bounded; `timeseries` can then no longer be read from
        the start)."""
        self._core.forget_rows_before(first)
        self._rows = []

    def visits_since(self, first: int) -> tuple[list, list]:
        """(visits, their idleness) from index `first` on, not cached here."""
        return self._core.visits(first), self._core.visit_idleness(first)

    def forget_visits_before(self, first: int) -> None:
        """The recorder drops the visits before index `first` (a results writer has them in
        visits.csv); the summary needs none of them (per-vertex times stay in the recorder),
        but `visits` can then no longer be read from the start. A run with deaths keeps them
        (its recovery metrics read them)."""
        if self._keep_visits:
            return
        self._core.forget_visits_before(first)
        self._visits = []
        self._idleness = []


class GraphRun:
    """One graph-runtime run on the C++ event loop."""

    runtime = "graph"

    def __init__(self, config: RunConfig, patrol_map=None):
        import tpuaf_core

        config.validate()
        self.config = config
        self.faults = config.faults()  # resolved (--fail-random drawn)
        self.source_map = patrol_map if patrol_map is not None else load_map(
            config.map, params=config.map_params, params_origin="map_params")
        self.robot = run_robot(config, self.source_map)  # None: the map's nominal figures
        self.patrol_map = travel_map(config, self.source_map, self.robot)
        self.lanes = None  # robot/lanes.py LaneLayer with config.one_way
        body = None  # the footprint the lanes are found for (the map's preset without a robot)
        if config.one_way:  # routes follow the one-way lanes, as in physics (no locks here)
            body = self.robot or choose_robot(AUTO, self.source_map.settings)
            self.lanes = one_way_layer(self.source_map, self.patrol_map, body)
            if self.lanes is not None:
                self.patrol_map = self.lanes.plan_map
        self.graph = self.patrol_map.graph  # validates the graph (MapError on a bad one)
        self.speed = float(self.patrol_map.settings.nominal_speed)
        self.seed = int(config.seed)
        starts = [int(v) for v in start_vertices(self.patrol_map, config.robots)]
        self.start_vertices = starts
        self.engine_config = ec = self._engine_config(config, starts, body)
        positions = np.asarray(self.patrol_map.positions, dtype=float)
        field = tpuaf_core.UncertaintyField(
            positions,
            np.asarray(self.patrol_map.importance, dtype=float),
            np.asarray(self.patrol_map.initial_uncertainty, dtype=float),
            self.patrol_map.uncertainty_model(),
        )
        self._engine = tpuaf_core.GraphEngine(
            self.graph, positions, ec, field, bus_stream(self.seed)
        )
        if self.faults:
            self._engine.set_faults([float(f.time_s) for f in self.faults],
                                    [int(f.robot) for f in self.faults],
                                    [f.kind == DEATH for f in self.faults],
                                    heartbeat_streams(config.robots, self.seed, float(config.loss)))
        cls = REGISTRY.get(config.strategy)
        first = cls(config.strategy_params)  # resolves the parameters (ParameterError)
        self.params = dict(first.params)
        self.core_strategy = issubclass(cls, CoreStrategyPolicy)
        if self.core_strategy:
            streams = [_rng_stream(self.seed, 2, i) for i in range(config.robots)]
            self._strategy = cls.core_strategy(self.params, self.patrol_map, config.robots,
                                               streams)
            self.robots: list[_GraphRobot] = []
        else:
            self.robots = [
                _GraphRobot(self, i, starts[i], first if i == 0 else cls(config.strategy_params),
                            np.random.default_rng([self.seed, 2, i]))
                for i in range(config.robots)
            ]
            self._strategy = tpuaf_core.PythonStrategy(_PythonTeam(self.robots))
        self._engine.set_strategy(self._strategy)
        self.recorder = GraphRecorder(self)
        self.bus = _Bus(self._engine)

    @property
    def now(self) -> float:
        return self._engine.now

    @property
    def events(self) -> int:
        """Events processed by the loop (arrivals, wake-ups, deliveries, faults, give-ups,
        liveness checks; stale ones included)."""
        return self._engine.events

    def run(self, progress: Callable[[float], None] | None = None) -> dict:
        """Simulate until duration_s. `progress(now)` is called now and then."""
        self._engine.run(progress, release_gil=self._strategy.is_native)
        return self.summary()

    @property
    def losses(self) -> list[tuple[float, int, int]]:
        """(t [s], observer, lost teammate) of every liveness loss (TeamRun.losses)."""
        return self._engine.losses

    def _engine_config(self, config: RunConfig, starts: list[int], body) -> object:
        """The C++ engine's settings of this run (`body`: the lanes' footprint, or None)."""
        import tpuaf_core

        s = self.patrol_map.settings
        ec = tpuaf_core.EngineConfig()
        ec.robots = config.robots
        ec.duration_s = float(config.duration_s)
        ec.delay_s = float(config.delay_s)
        ec.loss = float(config.loss)
        ec.sample_period_s = float(config.sample_period_s)
        ec.nominal_speed_mps = self.speed
        ec.stay_s = STAY_S
        ec.visit_radius_m = self.patrol_map.visit_radius_m
        ec.retry_s = DEFAULT_RETRY_S
        ec.refractory_s = _recorder_default("refractory_s")
        ec.max_substep_s = _recorder_default("max_substep_s")
        ec.field_merge_s = _recorder_default("field_merge_s")
        ec.interference_distance_m = float(s.interference_distance)
        ec.sensing_peak = float(s.sensing_peak)
        ec.sensing_radius_m = float(s.sensing_radius)
        ec.start_vertices = starts
        ec.goal_tolerance_m = float(s.goal_tolerance)
        ec.stall_give_up_s = float(navigator_give_up_s())
        ec.teammate_timeout_s = float(config.teammate_timeout_s)
        ec.heartbeat_period_s = float(TeamRun.heartbeat_period_s)
        # a timed map's turns: a robot turning back at a vertex takes longer (travel_time.py)
        ec.turn_times = [(w, u, v, s) for (w, u, v), s in self.patrol_map.turns.items()]
        if self.lanes is not None:  # one robot at a time on a lane's narrow vertices
            ec.narrow_vertices = sorted(int(v) for v in self.lanes.lane_map.narrow_vertices)
            ec.narrow_headway_s = narrow_headway_s(body.radius_m, self.speed)
        return ec

    def _narrow(self) -> dict:
        """The engine's narrow vertices (by vertex id) and headway [s], for config.yaml."""
        ec = self.engine_config
        return {"vertices": [self.patrol_map.vertex_ids[v] for v in ec.narrow_vertices],
                "headway_s": round(ec.narrow_headway_s, 3)}

    def effective_config(self) -> dict:
        """Everything that determines this run, the engine included."""
        return run_description(
            self, self.start_vertices, self.params, self.faults,
            engine="C++ event loop" + (", C++ strategy" if self.core_strategy
                                       else ", Python strategy called back"),
            **({"robot_model": self.robot.describe()} if self.robot is not None else {}),
            motion="straight segments between vertices, edge length / nominal speed each ("
                   f"travel {self.config.resolved_travel()})"
                   + ("; one robot at a time on the lanes' narrow vertices" if self.lanes else ""),
            **({"narrow_vertices": self._narrow()} if self.lanes is not None else {}))

    def summary(self) -> dict:
        summary = self.recorder.summary(self.now)
        summary["messages"] = asdict(self.bus.stats)
        summary["faults"] = [f.to_dict() for f in self.faults if f.time_s <= self.now]
        if self.lanes is not None:
            summary["lanes"] = len(self.lanes.lane_map.lanes)
            summary["one_way_lanes"] = self.lanes.one_way_count
        if self.faults:
            died_at = {int(robot): float(t) for t, robot in self.recorder.deaths}
            summary["liveness"] = liveness_summary(
                float(self.config.teammate_timeout_s), float(TeamRun.heartbeat_period_s),
                died_at, self.losses)
        return summary
