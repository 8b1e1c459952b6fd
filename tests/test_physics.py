"""Physics runtime (issue 9 item 2): the C++ world, the agents' navigator, the team bus and the
recorder, without ROS; deterministic per seed; faults; the results folder of `tpuaf run`."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest
import yaml
from tpuaf.errors import TpuafError
from tpuaf.policies import REGISTRY
from tpuaf.runtimes.config import ConfigError, PhysicsConfig
from tpuaf.runtimes.physics import PhysicsRun

from .conftest import REPO

TPUAF = [str(REPO / ".venv" / "bin" / "tpuaf")]


def physics(**kwargs) -> tuple[dict, PhysicsRun]:
    engine = PhysicsRun(PhysicsConfig(**kwargs))
    return engine.run(), engine


def test_cli_physics_run_on_grid_visits_every_vertex(tmp_path):
    """The done-when of issue 9: `tpuaf run --runtime physics --map grid --robots 4
    --duration 600` visits every vertex, into the same results folder as the graph runtime."""
    out = tmp_path / "run"
    proc = subprocess.run([*TPUAF, "run", "--runtime", "physics", "--map", "grid", "--robots",
                           "4", "--duration", "600", "--quiet", "--out", str(out)],
                          capture_output=True, text=True, timeout=900, start_new_session=True)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["unvisited_vertices"] == 0 and summary["visits"] > 4 * 25
    assert summary["collisions"] == 0
    config = yaml.safe_load((out / "config.yaml").read_text())
    assert config["runtime"] == "physics" and config["robot_model"]["speed_mps"] == 1.0
    rows = (out / "visits.csv").read_text().splitlines()
    assert len(rows) == summary["visits"] + 1


def test_same_seed_same_run_and_the_bus_delays_and_loses():
    kwargs = dict(map="grid", strategy="gbs", robots=3, duration_s=120, delay_s=1.5, loss=0.3)
    a, ea = physics(seed=4, **kwargs)
    b, eb = physics(seed=4, **kwargs)
    c, _ = physics(seed=5, **kwargs)
    assert a == b and ea.recorder.visits == eb.recorder.visits
    assert a != c
    stats = ea.bus.stats
    assert stats.sent > 0 and 0 < stats.lost < 2 * stats.sent
    assert stats.delivered + stats.lost <= 2 * stats.sent


def test_visits_are_reached_events_at_goal_vertices():
    summary, engine = physics(map="grid", robots=2, duration_s=120, seed=1)
    tol = engine.patrol_map.settings.goal_tolerance
    visits = engine.recorder.visits
    assert len(visits) == summary["visits"] > 2
    assert sum(a.machine.visits for a in engine.agents) + 2 == len(visits)  # + 2 START
    # Every visit after the start happened with the robot within tolerance of the vertex.
    assert all(t > 0 for t, _, _ in visits[2:])
    final = np.asarray(engine.world.poses())[:, :2]
    for a in engine.agents:
        if a.machine.goal is None and not a.machine.dwelling:
            v = a.machine.current_vertex
            assert np.hypot(*(final[a.machine.robot] - engine.patrol_map.positions[v])) <= tol + 0.3


def test_death_and_stall_in_the_physics_world():
    summary, engine = physics(map="grid", strategy="tpuaf", robots=3, duration_s=240, seed=2,
                              fail=[(1, 60.0)], stall=[(2, 30.0)])
    assert summary["deaths"] == 1 and summary["dead_robots"] == [1]
    assert summary["stalled_robots"] == [2]
    assert [f["kind"] for f in summary["faults"]] == ["stall", "death"]
    assert not [t for t, r, _ in engine.recorder.visits if r == 1 and t > 60.0]
    stalled = engine.agents[2].machine
    assert stalled.alive and stalled.failures >= 2  # it keeps deciding, its navigator gives up
    v = np.asarray(engine.world.velocities())
    assert np.allclose(v[1:], 0.0)
    assert summary["recovery"][0]["survivors"] == 2


def test_lab_with_burgers_at_a_tenth_of_a_metre_per_second():
    """Table 4's setting: the lab map, TurtleBot3 Burgers at 0.1 m/s."""
    summary, engine = physics(map="lab", robot="burger", robots=2, duration_s=200, seed=0)
    assert engine.robot.preset == "burger" and engine.robot.speed_mps == 0.1
    assert engine.world.robot_spec(0).radius_m == pytest.approx(0.105)
    assert summary["visits"] > 2


def test_bad_physics_configs_are_refused():
    with pytest.raises(ConfigError, match="whole multiple"):
        PhysicsRun(PhysicsConfig(map="grid", control_period_s=0.1, physics_step_s=0.03))
    with pytest.raises(ConfigError, match="physics_step_s must be"):
        PhysicsRun(PhysicsConfig(map="grid", physics_step_s=-1.0))
    with pytest.raises(TpuafError, match="unknown robot preset 'tank'"):
        PhysicsRun(PhysicsConfig(map="grid", robot="tank"))


def test_cli_refuses_an_unknown_robot_preset_in_the_physics_runtime(tmp_path):
    proc = subprocess.run([*TPUAF, "run", "--runtime", "physics", "--robot", "tank",
                           "--duration", "10", "--quiet", "--out", str(tmp_path / "run")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "unknown robot preset 'tank'" in proc.stderr
    assert "Traceback" not in proc.stderr


@pytest.mark.parametrize("strategy", REGISTRY.names())
def test_every_strategy_survives_faults_in_the_physics_runtime(strategy):
    summary, engine = physics(map="grid", strategy=strategy, robots=4, duration_s=300, seed=1,
                              fail=["0@60"], stall=["2@90"], delay_s=0.5, loss=0.1)
    assert engine.now == 300.0 and summary["deaths"] == 1
    assert summary["visits"] > 4


def test_the_survivors_ideal_uses_the_robots_speed():
    """A Burger on grid drives 0.22 m/s, not the map's 1 m/s: the N - 1 ideal says so."""
    from tpuaf.maps.tours import reference_tours

    summary, engine = physics(map="grid", robot="burger", robots=3, duration_s=60,
                              fail=["2@10"])
    (r,) = summary["recovery"]
    want = reference_tours(engine.patrol_map, 2, 0.22)["best_worst_idleness_s"]
    assert r["ideal_worst_idleness_survivors_s"] == pytest.approx(want)
    assert r["time_s"] == pytest.approx(10.0)
