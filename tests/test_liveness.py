"""Liveness in the robot state machine (issue 19 item 4): every runtime feeds the machine's
`TeammateLiveness` with the team messages and heartbeats a robot actually hears, and a death is
noticed from the silence, with the agent node's timeout. No oracle tells the survivors."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from tpuaf.maps import load_map
from tpuaf.policies import REGISTRY
from tpuaf.runtimes.agent import AgentRuntime
from tpuaf.runtimes.config import PhysicsConfig, RunConfig
from tpuaf.runtimes.graph import GraphRun
from tpuaf.runtimes.physics import PhysicsRun
from tpuaf.team.liveness import heartbeat_links

QUIET = "cr"  # a strategy that sends no team messages: only heartbeats are heard


def listening(engine, machines) -> list[tuple[int, int, float]]:
    """(observer, lost teammate, run time [s]) of every on_teammate_lost the policies get."""
    heard = []
    for m in machines:
        base = type(m.policy)

        class Listener(base):
            def on_teammate_lost(self, robot, ctx, _base=base):
                heard.append((ctx.robot, robot, ctx.now))
                _base.on_teammate_lost(self, robot, ctx)

        m.policy.__class__ = Listener
    return heard


def graph(**kwargs) -> tuple[GraphRun, dict, list]:
    engine = GraphRun(RunConfig(**{"map": "grid", "strategy": QUIET, **kwargs}))
    heard = listening(engine, engine.robots)
    return engine, engine.run(), heard


# --- the heartbeat links ----------------------------------------------------------------------


def test_links_without_loss_hear_every_heartbeat_until_the_death():
    links = heartbeat_links(3, 100.0, timeout_s=10.0, delay_s=0.5)
    assert links.last_arrival_s(0, 1, 0.4) == -math.inf  # the first arrives at 0.5 s
    assert links.last_arrival_s(0, 1, 7.2) == 6.5
    assert links.next_check_s(0, 1, 6.5, False, 7.2) == 110.5  # the last (100 s) + 0.5 + 10
    links.died(1, 50.3)  # heartbeats of 0..50 s were sent
    assert links.last_arrival_s(0, 1, 99.0) == 50.5
    assert links.next_check_s(0, 1, 50.5, False, 51.0) == 60.5
    assert links.next_check_s(0, 1, 50.5, True, 61.0) == math.inf  # never heard again
    links.died(2, 20.0)  # dying at a heartbeat's instant: that one was sent
    assert links.last_arrival_s(0, 2, 99.0) == 20.5


def test_lossy_links_draw_per_recipient_and_find_each_silence():
    links = heartbeat_links(3, 3600.0, timeout_s=10.0, loss=0.6, seed=4)
    again = heartbeat_links(3, 3600.0, timeout_s=10.0, loss=0.6, seed=4)
    a = [links.last_arrival_s(r, 2, 1000.0) for r in (0, 1)]
    assert a == [again.last_arrival_s(r, 2, 1000.0) for r in (0, 1)]  # seeded
    received, silences = links.received(0, 2), links.silences(0, 2)
    assert 0.3 < len(received) / links.count < 0.5  # 60 % lost
    # A silence: two heartbeats heard more than the timeout apart; none in between is heard.
    assert len(silences) > 0
    p = int(silences[0])
    gap_start, gap_end = float(received[p]), float(received[p + 1])
    assert gap_end - gap_start > 10.0
    assert links.last_arrival_s(0, 2, gap_end - 0.5) == gap_start
    # Heard at gap_start: the next check is the silence's end, not the next heartbeat sent.
    assert links.next_check_s(0, 2, gap_start, False, gap_start) == gap_start + 10.0
    assert links.next_check_s(0, 2, gap_start, True, gap_start + 10.0) == gap_end  # back


# --- the graph runtime ------------------------------------------------------------------------


def test_a_death_is_noticed_a_timeout_after_the_last_heartbeat():
    engine, summary, heard = graph(robots=3, duration_s=300, fail=["2@50.5"],
                                   teammate_timeout_s=10.0)
    # The last heartbeat of robot 2 went out at 50 s: silent for 10 s at 60 s, not at 60.5.
    assert sorted(heard) == [(0, 2, 60.0), (1, 2, 60.0)]
    (death,) = summary["liveness"]["deaths"]
    assert death == {"robot": 2, "time_s": 50.5, "noticed_by": 2, "first_delay_s": 9.5,
                     "last_delay_s": 9.5}
    assert summary["liveness"]["false_losses"] == 0
    assert sorted(engine.losses) == [(60.0, 0, 2), (60.0, 1, 2)]


def test_the_timeout_and_the_delay_set_the_detection_time():
    _, _, heard = graph(robots=3, duration_s=300, fail=["2@50"], teammate_timeout_s=25.0,
                        delay_s=2.0)
    assert sorted(heard) == [(0, 2, 77.0), (1, 2, 77.0)]  # 50 + 2 (in flight) + 25


def test_team_messages_count_as_heard():
    """TPUAF's Visit and Intention messages are heard too: a last message sent after the last
    heartbeat (between two) postpones the detection to its arrival + timeout."""
    engine, summary, heard = graph(strategy="tpuaf", robots=4, duration_s=600, seed=1,
                                   fail=["1@200.9"], teammate_timeout_s=10.0)
    sent = [t for t, r, _ in engine.recorder.visits if r == 1 and 200.0 < t <= 200.9]
    lost = sorted(t for t, _, r in engine.losses if r == 1)  # tpuaf runs in C++: no listener
    assert len(lost) == 3
    # Messages are heard at once (no delay): the detection is 10 s after the later of the
    # last heartbeat (200 s) and robot 1's last message.
    assert lost[0] >= 210.0 and all(t == lost[0] for t in lost)
    if sent:
        assert lost[0] >= max(sent) + 10.0


def test_loss_moves_each_survivors_detection_to_its_last_heartbeat_heard():
    """Under loss every survivor notices the death a timeout after the last heartbeat it heard
    (never later than without loss: a lost heartbeat only starts the silence earlier), each at
    its own time."""
    _, clean, clean_heard = graph(robots=8, duration_s=900, seed=3, fail=["5@400"])
    engine, lossy, lossy_heard = graph(robots=8, duration_s=900, seed=3, fail=["5@400"],
                                       loss=0.5)
    assert {t for _, r, t in clean_heard if r == 5} == {410.0}
    times = {o: t for o, r, t in lossy_heard if r == 5}
    assert sorted(times) == [0, 1, 2, 3, 4, 6, 7]
    links = heartbeat_links(8, 900.0, timeout_s=10.0, loss=0.5, seed=3)  # the run's own draws
    links.died(5, 400.0)
    for o, t in times.items():
        assert t == links.last_arrival_s(o, 5, 900.0) + 10.0
        assert t <= 410.0
    assert len(set(times.values())) > 1  # the links lose different heartbeats
    d = lossy["liveness"]["deaths"][0]
    assert d["first_delay_s"] < d["last_delay_s"] <= clean["liveness"]["deaths"][0][
        "last_delay_s"]


def test_heavy_loss_takes_live_teammates_for_lost_until_heard_again():
    """On a link losing most heartbeats a live teammate can be silent for the timeout: it is
    reported lost (as on hardware), and counts as back at the next heartbeat heard."""
    engine, summary, heard = graph(robots=4, duration_s=1800, seed=2, fail=["3@1700"], loss=0.7)
    false = [(o, r, t) for o, r, t in heard if r != 3 or t < 1700.0]
    assert summary["liveness"]["false_losses"] == len(false) > 0
    o, r, t = false[0]
    links = heartbeat_links(4, 1800.0, timeout_s=10.0, loss=0.7, seed=2)  # the run's own draws
    links.died(3, 1700.0)
    assert links.last_arrival_s(o, r, 1800.0) > t  # heard again later


def test_a_stalled_robot_keeps_talking_and_is_not_lost():
    engine, summary, heard = graph(robots=4, duration_s=1200, seed=1, stall=["0@100"],
                                   fail=["1@600"], loss=0.2)
    assert summary["stalled_robots"] == [0]
    assert [r for _, r, _ in heard if r == 0] == []
    assert sorted(o for o, r, _ in heard if r == 1) == [0, 2, 3]  # the stalled one notices too


def test_checks_are_event_driven_not_polled():
    """A 1 h run with 8 robots and one death schedules a handful of liveness checks per robot
    (when a silence can reach the timeout), not one per heartbeat."""
    engine = GraphRun(RunConfig(map="grid", strategy="tpuaf", robots=8, duration_s=3600,
                                seed=1, fail=["2@1800"], loss=0.1))
    summary = engine.run()
    assert summary["liveness"]["deaths"][0]["noticed_by"] == 7
    quiet = GraphRun(RunConfig(map="grid", strategy="tpuaf", robots=8, duration_s=3600,
                               seed=1, loss=0.1))
    quiet.run()
    # 8 robots x 3600 heartbeats polled would add 28,800 events; the checks add a few hundred
    assert engine.events - quiet.events < 8 * 100


def test_runs_without_faults_carry_no_heartbeats():
    engine = GraphRun(RunConfig(map="grid", robots=3, duration_s=60, loss=0.5))
    summary = engine.run()
    assert "liveness" not in summary and not engine.losses


# --- the physics and agent runtimes -----------------------------------------------------------


def test_the_physics_runtime_notices_a_death_from_heartbeats():
    engine = PhysicsRun(PhysicsConfig(map="grid", strategy=QUIET, robots=3, duration_s=50,
                                      seed=2, fail=["1@20.3"], stall=["2@10"],
                                      teammate_timeout_s=8.0))
    heard = listening(engine, [a.machine for a in engine.agents])
    summary = engine.run()
    # Last heartbeat at 20 s: lost at the control tick of 28 s (the policies' clock is the
    # agents' last tick, as for messages); the stalled robot is not lost.
    assert sorted((o, r) for o, r, _ in heard) == [(0, 1), (2, 1)]
    assert [(t, r) for t, _, r in engine.losses] == [(pytest.approx(28.0), 1)] * 2
    assert all(28.0 - 0.1 - 1e-9 <= t <= 28.0 for _, _, t in heard)
    assert summary["liveness"]["deaths"][0]["noticed_by"] == 2


def test_the_agent_runtime_liveness_is_the_machines():
    """What the ROS agent node runs: it feeds `hear` from team messages and heartbeat events
    and calls `check_liveness` at 4 Hz; the machine tells the policy."""
    pm = load_map("grid")
    agent = AgentRuntime(pm, REGISTRY.create(QUIET), 0, 3, 0, lambda m: None,
                         lambda *a: None, teammate_timeout_s=5.0)
    heard = listening(agent, [agent.machine])
    agent.on_pose(0.0, *pm.positions[0], 0.0)
    agent.begin(0.0)
    assert agent.hear(1, 1.0) is False and agent.hear(2, 2.0) is False
    assert agent.check_liveness(5.9) == []
    assert agent.check_liveness(6.0) == [1] and heard == [(0, 1, 0.0)]
    assert agent.check_liveness(7.0) == [2]
    assert agent.hear(1, 1.0) is False  # nothing newer: still lost
    assert agent.hear(1, 8.0) is True and 1 not in agent.machine.liveness.lost
    source = (Path(__file__).resolve().parents[1] / "src/tpuaf_ros/src/tpuaf/ros/agent_node.py")
    text = source.read_text()
    assert "TeammateLiveness(" not in text
    assert "self.runtime.hear(" in text and "self.runtime.check_liveness(" in text
