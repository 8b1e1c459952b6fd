"""Native graph runtime: the graph runtime's event loop in the C++ core (`tpuaf_core.GraphEngine`).

It gives the same results, to the last digit, as the Python graph runtime
(`tpuaf.runtimes.graph.BatchRun`) for the same configuration and seed: same event order, same
motion, same bus (numpy's PCG64 stream reproduced in C++), same recorder arithmetic
(tests/test_engine_golden.py). Two kinds of strategies:

- a strategy with a C++ decision path (`NATIVE_STRATEGIES`: tpuaf, gbs, dtag) runs
  entirely in C++ between start and finish (the GIL is released); its messages go straight to
  the C++ state of the other robots. GBS's exp is the C library's where numpy's differs by up
  to 1 ulp; its decisions compare probabilities with a 1e-9 tolerance, so runs agree unless
  one lands within 1 ulp of that threshold (the golden test checks several configurations);
- any other strategy stays the Python `Policy` it is, called back from C++ only at its
  decisions, message deliveries, goal failures and lost teammates, with a RobotContext like
  the Python runtime's.

Faults (deaths, `--fail-random` resolved here as BatchRun resolves it, stalls), the heartbeats
(`HeartbeatLinks`, loss draws from the streams [seed, 4, sender]) and the teammate liveness
checks run in the C++ loop as in `TeamRun` / `BatchRun`; the summary's faults, liveness and
recovery are BatchRun's.

`NativeRun` has BatchRun's interface (config, patrol_map, now, recorder, run(progress),
summary(), effective_config()). Select the runtime with `make_run(config, engine=...)`.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import asdict
from typing import Any

import numpy as np

from tpuaf.maps import load_map, start_vertices
from tpuaf.measure.metrics import RunRecorder, build_summary, recovery_after_deaths
from tpuaf.navigation import navigator_give_up_s
from tpuaf.policies import REGISTRY, Policy, RobotContextBase
from tpuaf.robot.machine import announced_vertex
from tpuaf.runtimes.base import TeamRun, liveness_summary
from tpuaf.runtimes.config import RunConfig, run_description, travel_map
from tpuaf.runtimes.faults import DEATH
from tpuaf.runtimes.graph import DEFAULT_RETRY_S, STAY_S, BatchRun
from tpuaf.team.bus import BusStats

ENGINES = ("auto", "native", "python")


class EngineChoiceError(ValueError):
    """`--engine native` asked for something the native engine does not support."""


def _recorder_default(name: str) -> float:
    """A RunRecorder keyword default (refractory_s, max_substep_s, field_merge_s)."""
    return float(inspect.signature(RunRecorder).parameters[name].default)


def _rng_stream(seed: int, *key: int):
    import tpuaf_core

    return tpuaf_core.NumpyPcg64(np.random.default_rng([seed, *key]).bit_generator.state)


def _tpuaf_strategy(run: NativeRun, params: dict, any_vertex: bool):
    import tpuaf_core

    from tpuaf.policies.tpuaf import new_knowledge

    knowledge = new_knowledge(
        run.patrol_map, params["intention_timeout_s"], params["silence_timeout_s"]
    )
    form = (
        tpuaf_core.UtilityForm.EQ14 if params["utility"] == "eq14" else tpuaf_core.UtilityForm.EQ13
    )
    rngs = [_rng_stream(run.seed, 2, i) for i in range(run.config.robots)]
    colocation = params.get("colocation", False) in (True, 1, "true")  # as Tpuaf.start
    return tpuaf_core.TpuafStrategy(knowledge, form, any_vertex, rngs, colocation)


def _gbs_strategy(run: NativeRun, params: dict):
    import types

    import tpuaf_core

    # G2 and edge_min resolved exactly as GreedyBayesian.start does (per-map table by N).
    policy = run.policies[0]
    ctx = types.SimpleNamespace(patrol_map=run.patrol_map, n_robots=run.config.robots)
    g2, edge_min = policy.defaults(ctx)
    g2 = float(params["g2"]) if params["g2"] is not None else g2
    edge_min = float(params["edge_min"]) if params["edge_min"] is not None else edge_min
    rngs = [_rng_stream(run.seed, 2, i) for i in range(run.config.robots)]
    return tpuaf_core.GbsStrategy(float(params["g1"]), g2, edge_min, rngs)


def _dtag_strategy(run: NativeRun, params: dict):
    import tpuaf_core

    pos = np.asarray(run.patrol_map.positions, dtype=float)
    origin_distance = []
    for v in run.start_vertices:  # DTAG's origin term, with numpy's hypot as the policy
        origin = np.asarray((float(pos[v][0]), float(pos[v][1])), dtype=float)
        origin_distance.append(np.hypot(*(pos - origin).T).tolist())
    rngs = [_rng_stream(run.seed, 2, i) for i in range(run.config.robots)]
    return tpuaf_core.DtagStrategy(
        float(params["initial_estimate"]), float(params["w_idleness"]),
        float(params["w_path"]), float(params["w_origin"]), origin_distance, rngs,
    )


def _tpuaf_plus_strategy(run: NativeRun, params: dict):
    """TPUAF+'s C++ decision path; its plans are the Python planner's (tpuaf_plus.make_plan),
    called back when a robot's view of the team changes."""
    import types

    import tpuaf_core

    from tpuaf.policies import tpuaf_plus
    from tpuaf.policies.cyclic import team_start_vertices
    from tpuaf.policies.tpuaf import new_knowledge

    pm, n = run.patrol_map, run.config.robots
    speed = float(pm.settings.nominal_speed)
    ctx = types.SimpleNamespace(patrol_map=pm, n_robots=n)
    all_starts = tuple(team_start_vertices(ctx))
    out = tpuaf_core.TpuafPlusParams()
    out.speed_mps = speed
    out.gain = float(params["gain"])
    out.deadband_s = float(params["deadband_s"])
    out.dwell_revisit_s = float(params["dwell_revisit_s"])
    out.silence_timeout_s = tpuaf_plus.silence_timeout(pm.graph, speed,
                                                       params["silence_timeout_s"])
    out.stay_s = tpuaf_plus.STAY_S

    def plans(team: list[int]):
        plan = tpuaf_plus.make_plan(pm, tuple(team), all_starts, params["plan"],
                                    params["repair"])
        routes = [(list(r.walk), list(r.arc), r.length, list(r.robots)) for r in plan.routes]
        route_of = [plan.route_of.get(k, -1) for k in range(n)]
        schedule = [plan.schedule.get(k, (-1, 0.0)) for k in range(n)]
        return routes, route_of, schedule

    knowledge = new_knowledge(pm, tpuaf_plus.INTENTION_TIMEOUT_S, out.silence_timeout_s)
    return tpuaf_core.TpuafPlusStrategy(knowledge, out, plans)


# Strategies with a C++ decision path: name -> (Python class it mirrors, builder(run, params)).
NATIVE_STRATEGIES: dict[str, tuple[str, Callable[[NativeRun, dict], Any]]] = {
    "tpuaf": ("Tpuaf", lambda run, params: _tpuaf_strategy(run, params, any_vertex=False)),
    "gbs": ("GreedyBayesian", _gbs_strategy),
    "dtag": ("DynamicTaskAssignmentGreedy", _dtag_strategy),
    "tpuaf_plus": ("TpuafPlus", _tpuaf_plus_strategy),
}


def native_builder(strategy: str):
    """The C++ strategy builder of `strategy`, or None. Only when the registered class is the
    one the C++ path mirrors (a replaced or renamed class runs as Python)."""
    entry = NATIVE_STRATEGIES.get(strategy)
    if entry is None:
        return None
    mirrored, builder = entry
    try:
        cls = REGISTRY.get(strategy)
    except KeyError:
        return None
    return builder if cls.__name__ == mirrored else None


def unsupported_options(config: RunConfig) -> list[str]:
    """Options of `config` the native engine does not support (empty: it can run it). Every
    option of the graph runtime is supported, faults included (deaths, random deaths, stalls,
    with the heartbeats and liveness checks of BatchRun)."""
    del config
    return []


def make_run(config: RunConfig, patrol_map=None, engine: str = "auto"):
    """The graph runtime for `config`: 'python' (BatchRun), 'native' (NativeRun, C++ loop) or
    'auto' (native whenever every option is supported: with the strategy's C++ decision path,
    or its Python policy called back from C++, which is still faster than BatchRun with the
    same results; benchmarks/results/native_faults.md). Returns (run, reason): reason says why
    auto chose what it chose."""
    if engine not in ENGINES:
        raise EngineChoiceError(f"unknown engine '{engine}' (valid: {', '.join(ENGINES)})")
    config.validate()
    missing = unsupported_options(config)
    if engine == "python":
        return BatchRun(config, patrol_map), "python engine requested"
    if engine == "native":
        if missing:
            raise EngineChoiceError(
                f"the native engine does not support {', '.join(missing)}; use --engine python"
            )
        return NativeRun(config, patrol_map), "native engine requested"
    if missing:
        return BatchRun(config, patrol_map), (
            f"python engine: the native engine does not support {', '.join(missing)} yet"
        )
    if native_builder(config.strategy) is not None:
        return NativeRun(config, patrol_map), "native engine, C++ decision path"
    return NativeRun(config, patrol_map), (
        f"native engine, strategy '{config.strategy}' called back in Python (no C++ decision "
        "path; faster than the python engine, same results)"
    )


class _NativeRobot(RobotContextBase):
    """The RobotContext a Python policy sees, backed by the C++ engine."""

    def __init__(self, run: NativeRun, index: int, start_vertex: int, policy: Policy, rng):
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

    def __init__(self, robots: list[_NativeRobot]):
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
    """BatchRun.bus look-alike: only the counters."""

    def __init__(self, engine):
        self._engine = engine

    @property
    def stats(self) -> BusStats:
        sent, delivered, lost = self._engine.bus_stats
        return BusStats(sent=sent, delivered=delivered, lost=lost)


class NativeRecorder:
    """RunRecorder's read side over the C++ recorder (what results.ResultsWriter reads)."""

    def __init__(self, run: NativeRun):
        self._engine = run._engine
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
        self._visits: list = []
        self._idleness: list = []
        self._rows: list = []

    @property
    def visits(self) -> list[tuple[float, int, int]]:
        if len(self._visits) < self._engine.visit_count:
            self._visits.extend(self._engine.visits(len(self._visits)))
        return self._visits

    @property
    def visit_idleness(self) -> list[float]:
        if len(self._idleness) < self._engine.visit_count:
            self._idleness.extend(self._engine.visit_idleness(len(self._idleness)))
        return self._idleness

    @property
    def timeseries(self) -> list[dict]:
        if len(self._rows) < self._engine.row_count:
            self._rows.extend(self._engine.timeseries(len(self._rows)))
        return self._rows

    def timeseries_since(self, first: int) -> list[dict]:
        """The 1 Hz rows from index `first` on, not cached here."""
        return self._engine.timeseries(first)

    def forget_timeseries_before(self, first: int) -> None:
        """The engine drops the rows before index `first` (a results writer has them on
        disk: a long run's memory stays bounded; `timeseries` can then no longer be read from
        the start)."""
        self._engine.forget_rows_before(first)
        self._rows = []

    def visits_since(self, first: int) -> tuple[list, list]:
        """(visits, their idleness) from index `first` on, not cached here."""
        return self._engine.visits(first), self._engine.visit_idleness(first)

    def forget_visits_before(self, first: int) -> None:
        """The engine drops the visits before index `first` (a results writer has them in
        visits.csv); the summary needs none of them (per-vertex times stay in the engine), but
        `visits` can then no longer be read from the start. A run with deaths keeps them (its
        recovery metrics read them)."""
        if self._keep_visits:
            return
        self._engine.forget_visits_before(first)
        self._visits = []
        self._idleness = []

    @property
    def interferences(self) -> list[tuple[float, int, int]]:
        return self._engine.interferences

    @property
    def interval_samples(self) -> list[float]:
        return self._engine.interval_samples.tolist()

    @property
    def first_visit_times(self) -> list[float]:
        """[s] each vertex's first visit (NaN: none), without reading the visit log."""
        return list(self._engine.first_visit_times)

    @property
    def visit_counts(self) -> list[int]:
        return [int(c) for c in self._engine.visit_counts]

    @property
    def deaths(self) -> list[tuple[float, int]]:
        return self._engine.deaths

    @property
    def stalls(self) -> list[tuple[float, int]]:
        return self._engine.stalls

    @property
    def announcements(self) -> list[tuple[float, int, int]]:
        return self._engine.announcements

    @property
    def vertex_times(self) -> list[list[float]]:
        """Per vertex, its visit times [s], sorted (runs with deaths keep every visit)."""
        return self._engine.vertex_times

    def recovery(self, end_time: float) -> list[dict]:
        """RunRecorder.recovery of the same run."""
        return recovery_after_deaths(
            self.patrol_map, self.n_robots, self.speed_mps, self.start_time,
            self._engine.vertex_times, self.visits, self.deaths, self.announcements, end_time,
            teammate_timeout_s=self.teammate_timeout_s)

    @property
    def _pos_time(self) -> float | None:
        return self._engine.positions_time

    def worst_idleness(self, end_time: float) -> float:
        return self._engine.worst_idleness(float(end_time))

    def uncertainty(self) -> np.ndarray:
        self._engine.finish()
        return np.asarray(self._engine.field_values, dtype=float)

    def summary(self, end_time: float) -> dict:
        """RunRecorder.summary of the same run, key for key and digit for digit."""
        engine = self._engine
        engine.finish()
        end_time = float(end_time)
        deaths = self.deaths
        return build_summary(
            self, end_time, interval_samples=engine.interval_samples, ins_sum=engine.ins_sum,
            n_rows=engine.row_count, worst=engine.worst_idleness(end_time), x_sum=engine.x_sum,
            x_count=engine.x_count, x_final=float(np.mean(engine.field_values)),
            n_interferences=len(engine.interferences), n_visits=engine.visit_count,
            deaths=deaths, stalls=self.stalls,
            recovery=self.recovery(end_time) if deaths else None)


class NativeRun:
    """One graph-runtime run on the C++ event loop; the interface of BatchRun."""

    runtime = "graph"

    def __init__(self, config: RunConfig, patrol_map=None, *, native_policy: bool = True):
        """native_policy=False runs even a strategy with a C++ path as its Python policy."""
        import tpuaf_core

        config.validate()
        missing = unsupported_options(config)
        if missing:
            raise EngineChoiceError(f"the native engine does not support {', '.join(missing)}")
        self.config = config
        self.faults = config.faults()  # resolved (--fail-random drawn as BatchRun draws it)
        self.patrol_map = travel_map(config, patrol_map if patrol_map is not None
                                     else load_map(config.map))
        self.graph = self.patrol_map.graph  # validates the graph (MapError on a bad one)
        s = self.patrol_map.settings
        self.speed = float(s.nominal_speed)
        self.seed = int(config.seed)
        starts = [int(v) for v in start_vertices(self.patrol_map, config.robots)]
        self.start_vertices = starts
        ec = tpuaf_core.EngineConfig()
        ec.robots = config.robots
        ec.duration_s = float(config.duration_s)
        ec.delay_s = float(config.delay_s)
        ec.loss = float(config.loss)
        ec.sample_period_s = float(config.sample_period_s)
        ec.nominal_speed_mps = self.speed
        ec.stay_s = STAY_S
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
        positions = np.asarray(self.patrol_map.positions, dtype=float)
        field = tpuaf_core.UncertaintyField(
            positions,
            np.asarray(self.patrol_map.importance, dtype=float),
            np.asarray(self.patrol_map.initial_uncertainty, dtype=float),
            self.patrol_map.uncertainty_model(),
        )
        self._engine = tpuaf_core.GraphEngine(
            self.graph, positions, ec, field, _rng_stream(self.seed, 1)
        )
        if self.faults:
            # Heartbeat losses: stream [seed, 4, sender] (HeartbeatLinks), only drawn with loss.
            heartbeat_rngs = ([_rng_stream(self.seed, 4, j) for j in range(config.robots)]
                              if float(config.loss) > 0 else [])
            self._engine.set_faults([float(f.time_s) for f in self.faults],
                                    [int(f.robot) for f in self.faults],
                                    [f.kind == DEATH for f in self.faults], heartbeat_rngs)
        cls = REGISTRY.get(config.strategy)
        self.policies = [cls(config.strategy_params) for _ in range(config.robots)]
        self.params = dict(self.policies[0].params)  # resolved (ParameterError if invalid)
        builder = native_builder(config.strategy) if native_policy else None
        self.native_policy = builder is not None
        if builder is not None:
            self._strategy = builder(self, self.params)
            self.robots: list[_NativeRobot] = []
        else:
            self.robots = [
                _NativeRobot(self, i, starts[i], self.policies[i],
                             np.random.default_rng([self.seed, 2, i]))
                for i in range(config.robots)
            ]
            self._strategy = tpuaf_core.PythonStrategy(_PythonTeam(self.robots))
        self._engine.set_strategy(self._strategy)
        self.recorder = NativeRecorder(self)
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

    def effective_config(self) -> dict:
        """Everything that determines this run (as BatchRun's, plus the engine used)."""
        return run_description(
            self, self.start_vertices, self.params, self.faults,
            engine="native" + (" (C++ decision path)" if self.native_policy else ""),
            motion="straight segments between vertices, edge length / nominal speed each")

    def summary(self) -> dict:
        summary = self.recorder.summary(self.now)
        summary["messages"] = asdict(self.bus.stats)
        summary["faults"] = [f.to_dict() for f in self.faults if f.time_s <= self.now]
        if self.faults:
            died_at = {int(robot): float(t) for t, robot in self._engine.deaths}
            summary["liveness"] = liveness_summary(
                float(self.config.teammate_timeout_s), float(TeamRun.heartbeat_period_s),
                died_at, self.losses)
        return summary
