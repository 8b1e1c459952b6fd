"""The recorder is written once (issue 31): the graph runtime's event loop feeds the core's
`GroundTruthRecorder` in C++, the physics runtime, the monitor and bag analysis feed the same
class through `RunRecorder`. Fed the same visit and position stream, both give the same figures (to the last bit),
and the read side they share (`RecorderView`) gives the same summary."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import tpuaf_core
from tpuaf.maps import load_map, start_vertices
from tpuaf.measure.metrics import RecorderView, RunRecorder

N_ROBOTS, DURATION_S = 4, 300.0


class _Walker:
    """A Python strategy of the loop: every robot steps to a neighbour of its vertex (turning
    through them in order, so the walk never stands still); at each decision it logs every
    robot's position, which is what the loop gave its recorder at that time."""

    def __init__(self, patrol_map):
        self.patrol_map = patrol_map
        self.engine = None
        self.turns = [0] * N_ROBOTS
        self.log: list[tuple[float, np.ndarray]] = []

    def start(self, robot: int) -> None:
        pass

    def decide(self, robot: int) -> int:
        e = self.engine
        if not self.log or e.now > self.log[-1][0]:
            self.log.append((e.now, np.array([e.position(i) for i in range(N_ROBOTS)])))
        around = sorted(self.patrol_map.graph.neighbours(e.current_vertex(robot)))
        self.turns[robot] += 1
        return around[(self.turns[robot] * (robot + 1)) % len(around)]

    def on_message(self, robot: int, message) -> None:
        pass


class _LoopView(RecorderView):
    """The shared read side over the loop's recorder (as the graph runtime's GraphRecorder)."""

    def __init__(self, engine, patrol_map):
        self._engine = engine
        self._core = engine.recorder
        self.patrol_map = patrol_map
        self.n_robots = N_ROBOTS
        self.n_vertices = patrol_map.num_vertices
        self.start_time = 0.0
        self.sample_period_s = 1.0
        self.d_if = float(patrol_map.settings.interference_distance)
        self.ground_truth = True
        self.speed_mps = float(patrol_map.settings.nominal_speed)
        self.teammate_timeout_s = None
        self._start_view()

    def finish(self, end_time: float) -> None:
        self._engine.finish()


def _graph_run(pm, defaults):
    s = pm.settings
    ec = tpuaf_core.EngineConfig()
    ec.robots = N_ROBOTS
    ec.duration_s = DURATION_S
    ec.nominal_speed_mps = float(s.nominal_speed)
    ec.visit_radius_m = pm.visit_radius_m
    for name in ("refractory_s", "max_substep_s", "field_merge_s", "sample_period_s"):
        setattr(ec, name, getattr(defaults, name))
    ec.interference_distance_m = float(s.interference_distance)
    ec.sensing_peak = float(s.sensing_peak)
    ec.sensing_radius_m = float(s.sensing_radius)
    ec.start_vertices = [int(v) for v in start_vertices(pm, N_ROBOTS)]
    positions = np.asarray(pm.positions, dtype=float)
    field = tpuaf_core.UncertaintyField(positions, np.asarray(pm.importance, dtype=float),
                                       np.asarray(pm.initial_uncertainty, dtype=float),
                                       pm.uncertainty_model())
    rng = tpuaf_core.NumpyPcg64(np.random.default_rng([0, 1]).bit_generator.state)
    engine = tpuaf_core.GraphEngine(pm.graph, positions, ec, field, rng)
    walker = _Walker(pm)
    walker.engine = engine
    strategy = tpuaf_core.PythonStrategy(walker)
    engine.set_strategy(strategy)
    engine.run()
    end = np.array([engine.position(i) for i in range(N_ROBOTS)])
    return engine, walker.log + [(DURATION_S, end)], strategy


def _close(a, b, tol=0.0) -> bool:
    if isinstance(a, dict):
        return set(a) == set(b) and all(_close(a[k], b[k], tol) for k in a)
    if isinstance(a, list | tuple):
        return len(a) == len(b) and all(_close(x, y, tol) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) or isinstance(b, float):
        if a is None or b is None:
            return a is b
        return (math.isnan(a) and math.isnan(b)) or abs(a - b) <= tol * max(1.0, abs(a))
    return a == b


def test_the_adapter_and_the_loop_give_the_same_figures_on_the_same_stream():
    pm = load_map("grid")
    engine, log, _strategy = _graph_run(pm, tpuaf_core.RecorderConfig())
    loop = _LoopView(engine, pm)
    visits = loop.visits
    assert len(visits) > 100 and len(log) > 100
    rec = RunRecorder(pm, N_ROBOTS)
    k = 0
    for t, positions in log:  # positions at t, then the visits at t, as the loop records them
        rec.record_positions(t, positions)
        while k < len(visits) and visits[k][0] <= t:
            rec.record_visit(visits[k][1], visits[k][2], visits[k][0])
            k += 1
    assert k == len(visits)
    want = json.loads(json.dumps(loop.summary(DURATION_S)))
    got = json.loads(json.dumps(rec.summary(DURATION_S)))
    assert want["interferences"] > 0  # the walk makes robots meet: interference is compared
    assert _close(got, want), {key: (got.get(key), want.get(key)) for key in want
                               if not _close(got.get(key), want.get(key))}
    assert rec.visits == visits and _close(rec.visit_idleness, loop.visit_idleness)
    assert _close(rec.timeseries, loop.timeseries)
    assert _close(rec.interferences, loop.interferences)
    assert _close(rec.uncertainty().tolist(), loop.uncertainty().tolist())


def test_runrecorder_defaults_are_the_cores():
    """One declaration of the recorder's defaults: RecorderConfig (recorder.hpp)."""
    import inspect

    defaults = tpuaf_core.RecorderConfig()
    params = inspect.signature(RunRecorder).parameters
    for name, core in (("sample_period_s", "sample_period_s"), ("refractory_s", "refractory_s"),
                       ("max_substep_s", "max_substep_s"), ("field_merge_s", "field_merge_s"),
                       ("start_time", "start_time_s")):
        assert params[name].default == getattr(defaults, core), name


def test_outage_back_and_death_in_the_core():
    """An outage ended by record_robot_back is no death; one never ended is; a dead robot
    neither senses nor interferes while out, and senses again once back."""
    pm = load_map("grid")
    rec = RunRecorder(pm, 2, teammate_timeout_s=10.0)
    far = np.array([[0.0, 0.0], [30.0, 30.0]])
    rec.record_positions(0.0, far)
    rec.record_robot_outage(1, 5.0, "silent")
    rec.record_robot_outage(1, 6.0, "silent")  # already out: ignored
    rec.record_robot_back(1, 20.0)
    rec.record_robot_back(1, 21.0)  # not out: ignored
    rec.record_robot_outage(0, 40.0, "silent")
    rec.record_robot_death(0, 50.0)  # out of contact already: not a second death
    rec.record_positions(60.0, far)
    assert rec.outage_list() == [
        {"robot": 1, "start_s": 5.0, "end_s": 20.0, "cause": "silent"},
        {"robot": 0, "start_s": 40.0, "end_s": None, "cause": "silent"}]
    assert rec.final_deaths() == [(40.0, 0)] and rec.deaths == []
    with pytest.raises(IndexError, match="unknown robot 2"):
        rec.record_robot_outage(2, 1.0, "silent")
    summary = rec.summary(60.0)
    assert summary["deaths"] == 1 and summary["dead_robots"] == [0]
    assert [r["robot"] for r in summary["recovery"]] == [0]


def test_dwells_count_the_time_standing_on_the_goal_stood_on():
    rec = RunRecorder(load_map("grid"), 2, ground_truth=False)
    rec.record_goal(0, 3, 3, 10.0)  # its goal is the vertex it stands on
    rec.record_dwell(0, 3, 12.5)
    rec.record_goal(1, 4, 2, 10.0)  # a drive that ended without a visit: no standing time
    rec.record_dwell(1, 4, 30.0)
    rec.record_dwell(1, 5, 31.0)  # no goal there: counted, no time
    assert (rec.dwells, rec.dwell_time_s) == (3, 2.5)
