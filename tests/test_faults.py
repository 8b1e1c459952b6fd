"""Fault injection (issue 12 items 1-2): deaths and stalls in the graph and physics runtimes,
recorded in the config and summary, with recovery metrics; every strategy survives them."""

from __future__ import annotations

import math
import subprocess

import pytest
from tpuaf.maps.tours import reference_tours
from tpuaf.policies import REGISTRY
from tpuaf.runtimes.config import ConfigError, RunConfig
from tpuaf.runtimes.faults import DEATH, STALL, resolve_faults
from tpuaf.runtimes.graph import GraphRun

from .conftest import REPO

TPUAF = [str(REPO / ".venv" / "bin" / "tpuaf")]


def run(**kwargs) -> tuple[dict, GraphRun]:
    engine = GraphRun(RunConfig(**kwargs))
    return engine.run(), engine


def test_a_dead_robot_stops_moving_visiting_and_sending():
    summary, engine = run(map="grid", robots=4, duration_s=900, seed=2, fail=[(1, 300.0)])
    assert summary["deaths"] == 1 and summary["dead_robots"] == [1]
    assert summary["faults"] == [{"kind": DEATH, "robot": 1, "time_s": 300.0}]
    assert [r for t, r, _ in engine.recorder.visits if t > 300.0 and r == 1] == []
    assert [r for t, r, _ in engine.recorder.visits if t > 300.0 and r != 1]  # others go on
    assert not engine._engine.alive(1)
    _, earlier = run(map="grid", robots=4, duration_s=450, seed=2, fail=[(1, 300.0)])
    assert earlier._engine.position(1) == engine._engine.position(1)  # frozen where it died
    assert "faults" in engine.effective_config()


def test_teammates_are_not_told_but_hear_the_silence():
    lost = []

    class Listener(REGISTRY.get("cgg")):
        def on_teammate_lost(self, robot, ctx):
            lost.append((ctx.robot, robot, ctx.now))

    engine = GraphRun(RunConfig(map="grid", strategy="cgg", robots=3, duration_s=200,
                                fail=[(2, 50.0)], teammate_timeout_s=10.0))
    for r in engine.robots:
        r.policy.__class__ = Listener
    engine.run()
    assert sorted(lost) == [(0, 2, 60.0), (1, 2, 60.0)]


def test_recovery_metrics_after_two_deaths():
    summary, engine = run(map="grid", robots=8, duration_s=3600, seed=0,
                          fail=[(0, 600.0), (3, 1200.0)])
    rec = summary["recovery"]
    assert [(r["robot"], r["time_s"], r["survivors"]) for r in rec] == [(0, 600.0, 7),
                                                                         (3, 1200.0, 6)]
    grid = engine.patrol_map
    for r in rec:
        ideal = reference_tours(grid, r["survivors"], 1.0)["best_worst_idleness_s"]
        assert r["ideal_worst_idleness_survivors_s"] == pytest.approx(ideal)
        assert 0 < r["recovery_time_s"] < 600
        # Every vertex is visited again after the recovery time, not before.
        after = {v for t, _, v in engine.recorder.visits
                 if r["time_s"] < t <= r["time_s"] + r["recovery_time_s"]}
        assert len(after) == grid.num_vertices
        before = {v for t, _, v in engine.recorder.visits
                  if r["time_s"] < t < r["time_s"] + r["recovery_time_s"] - 1e-9}
        assert len(before) < grid.num_vertices
        assert r["worst_idleness_after_s"] >= r["recovery_time_s"]
        # both floors are lower bounds of what happened (the graph runtime drives the graph)
        assert r["worst_idleness_after_s"] >= r["floor_worst_idleness_after_s"] - 1e-6
        assert r["worst_idleness_after_s"] >= r["detection_floor_worst_idleness_after_s"] - 1e-6
        assert r["worst_idleness_ratio_to_detection_reference"] == pytest.approx(
            r["worst_idleness_after_s"] / max(r["detection_floor_worst_idleness_after_s"],
                                              r["ideal_worst_idleness_survivors_s"]))
        assert 0 <= r["intentions_honoured"] <= len(r["intentions"])
    assert rec[0]["window_end_s"] == 1200.0 and rec[1]["window_end_s"] == 3600.0


def test_intentions_of_the_dead_robot_are_tracked():
    summary, engine = run(map="grid", strategy="tpuaf", robots=4, duration_s=1200, seed=1,
                          fail=[(2, 400.0)])
    r = summary["recovery"][0]
    # TPUAF announces its next goal (Intention) at every decision: the dead robot had one.
    assert len(r["intentions"]) >= 1
    for v_id, delay in zip(r["intentions"], r["intention_delays_s"], strict=True):
        v = list(engine.patrol_map.vertex_ids).index(v_id)
        later = [t for t, rr, vv in engine.recorder.visits if vv == v and rr != 2 and t > 400]
        assert (delay is None) == (not later)
        if later:
            assert delay == pytest.approx(min(later) - 400.0)


def test_a_stalled_robot_keeps_talking_and_gives_up_goals():
    summary, engine = run(map="grid", strategy="tpuaf", robots=3, duration_s=600, seed=1,
                          stall=[(0, 100.0)])
    assert engine._engine.alive(0) and engine._engine.stalled(0)
    assert summary["stalled_robots"] == [0] and summary["deaths"] == 0
    _, earlier = run(map="grid", strategy="tpuaf", robots=3, duration_s=150, seed=1,
                     stall=[(0, 100.0)])
    p = engine._engine.position(0)
    assert earlier._engine.position(0) == p  # it stopped where it stalled
    # it keeps talking: its Visit and Intention messages went on after the stall
    assert summary["messages"]["sent"] > earlier.summary()["messages"]["sent"]
    # It never reaches a vertex it is not standing on.
    here = engine.patrol_map.nearest_vertex(*p)
    assert {v for t, r, v in engine.recorder.visits if r == 0 and t > 101.0} <= {here}


def test_fault_options_are_checked():
    with pytest.raises(ConfigError, match=r"robot index must be in 0\.\.3"):
        GraphRun(RunConfig(map="grid", robots=4, fail=[(4, 10.0)]))
    with pytest.raises(ConfigError, match="after the run's end"):
        GraphRun(RunConfig(map="grid", robots=4, duration_s=100, fail=["1@200"]))
    with pytest.raises(ConfigError, match="names a robot twice"):
        GraphRun(RunConfig(map="grid", robots=4, fail=["1@20", "1@30"]))
    with pytest.raises(ConfigError, match="only 2 robot"):
        GraphRun(RunConfig(map="grid", robots=3, fail=["1@20"], fail_random=3))
    with pytest.raises(ConfigError, match="expects ROBOT@TIME"):
        GraphRun(RunConfig(map="grid", robots=3, stall=["one@20"]))


def test_random_deaths_are_seeded_and_within_the_run():
    a = resolve_faults([], 3, [], 8, 1000.0, seed=5)
    b = resolve_faults([], 3, [], 8, 1000.0, seed=5)
    c = resolve_faults([], 3, [], 8, 1000.0, seed=6)
    assert a == b and a != c
    assert len({f.robot for f in a}) == 3 and all(100.0 <= f.time_s <= 500.0 for f in a)
    mixed = resolve_faults(["0@10"], 2, ["5@20"], 6, 1000.0, seed=1)
    assert [f.kind for f in mixed].count(DEATH) == 3 and [f.kind for f in mixed].count(STALL) == 1
    assert 0 not in {f.robot for f in mixed if f.kind == DEATH and f.time_s != 10}


@pytest.mark.parametrize("strategy", REGISTRY.names())
def test_every_strategy_survives_every_fault(strategy):
    """Deaths (one early, one random), a stall, all on grid N = 4 for 600 s: the run ends."""
    summary, engine = run(map="grid", strategy=strategy, robots=4, duration_s=600, seed=1,
                          fail=["0@100"], fail_random=1, stall=["3@200"],
                          delay_s=1.0, loss=0.2)
    assert engine.now == 600.0
    assert summary["deaths"] == 2 and len(summary["recovery"]) == 2
    assert math.isfinite(summary["worst_idleness_s"])


def test_every_strategy_survives_all_robots_dying():
    for strategy in REGISTRY.names():
        summary, engine = run(map="grid", strategy=strategy, robots=2, duration_s=300,
                              fail=["0@50", "1@60"])
        assert engine.now == 300.0 and summary["deaths"] == 2
        assert summary["recovery"][1]["ideal_worst_idleness_survivors_s"] is None


def test_cli_reports_deaths_recovery_and_the_ideal(tmp_path):
    out = tmp_path / "run"
    proc = subprocess.run(
        [*TPUAF, "run", "--map", "grid", "--robots", "8", "--fail",
         "0@600", "--fail", "3@1200", "--duration", "3600", "--quiet", "--out", str(out)],
        capture_output=True, text=True, cwd=REPO, timeout=600, start_new_session=True)
    assert proc.returncode == 0, proc.stderr
    assert "death of robot 0 at 600.0 s" in proc.stdout and "visited again in" in proc.stdout
    assert "death of robot 3 at 1,200.0 s" in proc.stdout
    assert proc.stdout.count("after its detection") == 2
    assert proc.stdout.count("ideal for the") == 2 and "ideal for the 6 survivors" in proc.stdout
    import json

    import yaml

    summary = json.loads((out / "summary.json").read_text())
    assert summary["deaths"] == 2 and len(summary["recovery"]) == 2
    config = yaml.safe_load((out / "config.yaml").read_text())
    assert [f["robot"] for f in config["faults"]] == [0, 3]
    bad = subprocess.run([*TPUAF, "run", "--fail", "9@10", "--quiet"],
                         capture_output=True, text=True, cwd=REPO, timeout=120)
    assert bad.returncode == 2 and "robot index must be in 0..3" in bad.stderr
    assert "Traceback" not in bad.stderr
