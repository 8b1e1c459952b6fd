"""The one team bus (issue 31): the graph loop's bus and the physics runtime's lose and deliver
the same messages to the same robots for the same seed, and the adapter keeps Python messages."""

from __future__ import annotations

import math

import pytest
import tpuaf_core
from tpuaf.runtimes.base import TeamRun
from tpuaf.runtimes.config import RunConfig
from tpuaf.runtimes.graph import GraphRun
from tpuaf.team.bus import TeamBus, bus_stream
from tpuaf.team.relay import RelayModel


def graph_run_traffic(config: RunConfig):
    """A graph run of a Python strategy: its sends [(t [s], sender, message)] in order, the
    deliveries {id(message): [(t [s], recipient)]} and the bus counters."""
    run = GraphRun(config)
    sends, heard = [], {}
    for robot in run.robots:
        def send(message, robot=robot, engine_send=robot.send):
            sends.append((run.now, robot.robot, message))
            engine_send(message)

        def on_message(message, ctx, hear=robot.policy.on_message):
            heard.setdefault(id(message), []).append((run.now, ctx.robot))
            hear(message, ctx)

        robot.send = send
        robot.policy.on_message = on_message
    run.run()
    return sends, heard, run.bus.stats


CASES = [
    dict(loss=0.3, delay_s=0.5),
    dict(loss=0.4, delay_s=0.0),
    dict(loss=0.25, delay_s=1.5, fail=["1@300"]),
    dict(loss=0.0, delay_s=1.0, fail=["2@200"]),
]


@pytest.mark.parametrize("case", CASES, ids=lambda c: ",".join(f"{k}={v}" for k, v in c.items()))
def test_graph_loop_and_physics_bus_draw_the_same_losses(case):
    config = RunConfig(map="grid", strategy="gbs", robots=4, duration_s=900, seed=11, **case)
    sends, heard, graph_stats = graph_run_traffic(config)
    deaths = {int(r): float(t) for r, t in (f.split("@") for f in case.get("fail", []))}
    bus = TeamRun(config).bus  # the physics runtime's bus, seeded as the physics runtime does
    dead = set()
    for t, sender, message in sends:
        for robot, died_s in deaths.items():
            if t > died_s and robot not in dead:
                dead.add(robot)
                bus.set_dead(robot)
        bus.send(sender, message, t)
    bus.release_due(math.inf)
    replayed = {id(message): recipients for message, recipients in bus.ready}
    send_time = {id(message): t for t, _, message in sends}
    expected = {}
    for key, recipients in replayed.items():
        due_s = send_time[key] + config.delay_s
        live = [r for r in recipients if deaths.get(r, math.inf) >= due_s]  # alive when due
        if due_s <= config.duration_s and live:
            expected[key] = [(due_s, r) for r in live]
    got = {key: sorted(pairs, key=lambda p: p[1]) for key, pairs in heard.items()}
    assert len(sends) > 100
    assert got == expected
    physics = bus.stats
    assert (graph_stats.sent, graph_stats.lost) == (physics.sent, physics.lost)
    if case["loss"] > 0:
        assert 0 < physics.lost < 3 * physics.sent


def test_bus_keeps_python_messages_in_due_then_send_order():
    bus = TeamBus(3, 2.0, 0.0, bus_stream(5))
    first, second, third = object(), {"a": 1}, ["x"]
    bus.send(0, first, 1.0)
    bus.send(1, second, 1.0)
    bus.send(2, third, 0.5)  # sent later on a clock that went back: due first
    assert bus.in_flight == 3 and not bus.ready and bus.next_due_s() == 2.5
    bus.release_due(2.9)
    assert [m for m, _ in bus.ready] == [third]
    bus.release_due(3.0)
    assert [(m, r) for m, r in bus.ready] == [(third, [0, 1]), (first, [1, 2]), (second, [0, 2])]
    assert bus.in_flight == 0 and bus.next_due_s() == math.inf
    bus.count_delivered(6)
    assert (bus.stats.sent, bus.stats.delivered, bus.stats.lost) == (3, 6, 0)


def test_bus_draws_numpys_stream_as_the_old_python_bus():
    # the former Python bus: lost = default_rng([seed, 1]).random(n) < loss per send
    import numpy as np

    rng = np.random.default_rng([9, 1])
    bus = TeamBus(5, 0.0, 0.5, bus_stream(9))
    for k in range(200):
        sender = k % 5
        keep = ~(rng.random(5) < 0.5)
        keep[sender] = False
        bus.send(sender, k, 0.0)
        if keep.any():
            message, recipients = bus.ready.popleft()
            assert (message, recipients) == (k, np.flatnonzero(keep).tolist())
        assert not bus.ready


def test_bus_rejects_bad_settings_in_one_line():
    with pytest.raises(ValueError, match="message delay must be a finite number >= 0 s"):
        TeamBus(2, -1.0, 0.0, bus_stream(1))
    with pytest.raises(ValueError, match=r"message loss probability must be in \[0, 1\]"):
        TeamBus(2, 0.0, 1.5, bus_stream(1))
    assert isinstance(bus_stream(1), tpuaf_core.NumpyPcg64)


def test_relay_drops_foreign_senders_and_counts_deliveries():
    relay = RelayModel(3, 1.0, 0.0, seed=2)
    relay.submit(7, "foreign", 0.0)
    relay.submit(1, "hello", 0.0)
    assert relay.pending() == 1 and relay.due(0.5) == []
    assert relay.due(1.0) == [(0, "hello"), (2, "hello")]
    assert (relay.stats.sent, relay.stats.delivered) == (1, 2)
