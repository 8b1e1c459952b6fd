"""The monitor announces the run start only once every agent is connected to its /fleet/start
publisher (a latched start reaching an agent through a connection still being set up came
seconds of wall time late under load, while lock-step sim time ran on). No master needed: the
check reads the publisher's connections."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

pytestmark = [pytest.mark.ros]


def monitor_with(callers: list[str], names=("robot_0", "robot_1")):
    from tpuaf.ros.monitor_node import MonitorNode

    stats = [(k, c, "o", "TCPROS", "/fleet/start", True, "") for k, c in enumerate(callers)]
    pub = SimpleNamespace(impl=SimpleNamespace(get_stats_info=lambda: stats))
    return MonitorNode.agents_listening(SimpleNamespace(start_pub=pub, names=list(names)))


def test_start_waits_for_every_agent_connected_to_the_start_topic():
    assert monitor_with(["/robot_0/patrol_agent", "/robot_1/patrol_agent", "/recorder"])
    # robot_1's agent not connected yet (the recorder does not count for it)
    assert not monitor_with(["/robot_0/patrol_agent", "/recorder"])
    assert not monitor_with([])
    # a robot_10 agent is not robot_1's
    assert not monitor_with(["/robot_0/patrol_agent", "/robot_10/patrol_agent"])
    # hardware names: tb3_<i>
    assert monitor_with(["/tb3_0/patrol_agent", "/tb3_1/patrol_agent"], ("tb3_0", "tb3_1"))


def recorder_ready_with(subscribers: list[str], recorder_node: str, monkeypatch) -> bool:
    import rospy
    from tpuaf.ros import convert
    from tpuaf.ros.monitor_node import MonitorNode

    state = [[], [(convert.EVENTS_TOPIC, subscribers), ("/clock", ["/recorder"])], []]
    master = SimpleNamespace(getSystemState=lambda: (1, "", state))
    monkeypatch.setattr(rospy, "get_master", lambda: master)
    node = SimpleNamespace(p=SimpleNamespace(recorder_node=recorder_node))
    return MonitorNode.recorder_ready(node)


def test_start_waits_for_the_named_recorder_not_any_subscriber(monkeypatch):
    # the agents subscribe to the events too: they do not stand for the recorder
    assert not recorder_ready_with(["/robot_0/patrol_agent", "/robot_1/patrol_agent"],
                                   "recorder", monkeypatch)
    assert recorder_ready_with(["/robot_0/patrol_agent", "/recorder"], "recorder", monkeypatch)
    # the name the launch file gives it (~recorder_node), not a fixed one
    assert not recorder_ready_with(["/recorder"], "bag_writer", monkeypatch)
    assert recorder_ready_with(["/fleet/bag_writer"], "bag_writer", monkeypatch)
    # no recorder to wait for
    assert recorder_ready_with([], "", monkeypatch)
