"""Team messages in lock-step (tpuaf.team.lockstep, ROS-free): the same set of messages at each
tick, in one order whatever order they arrived in, and the counts of the simulator's team
barrier; and the sender rule the agents share with the monitor (tpuaf.team.inbox.SenderCheck,
issue 33)."""

from __future__ import annotations

import itertools

from tpuaf.measure.traffic import TrafficGuard
from tpuaf.team import messages as m
from tpuaf.team.inbox import SenderCheck, TeamInbox
from tpuaf.team.lockstep import LockstepTeam
from tpuaf.topics import GOAL

# (stamp [s], sender, topic rank, label): two ticks' messages of two teammates
MESSAGES = [(10.0, 1, 0, "v1"), (10.0, 1, 1, "i1"), (10.0, 2, 1, "i2"), (10.1, 2, 0, "v2"),
            (10.0, 2, 1, "i2b")]


def handled(arrival_order, ticks=(10.1, 10.2)) -> list[list[str]]:
    team = LockstepTeam(3, 0)
    out = []
    pending = list(arrival_order)
    for t in ticks:
        while pending:  # everything sent before the tick arrived (the barrier)
            stamp, robot, topic, label = pending.pop(0)
            team.put(stamp, robot, topic, label)
        out.append([label for _, _, label in team.due(t)])
    return out


def test_one_order_whatever_the_arrival_order():
    """Every arrival order that keeps one topic's order (a TCP connection per topic) gives the
    same messages at the same ticks in the same order."""
    results = set()
    for order in itertools.permutations(MESSAGES):
        labels = [x[3] for x in order]
        if labels.index("i2") > labels.index("i2b"):
            continue  # one sender's messages on one topic arrive in the order sent
        results.add(tuple(map(tuple, handled(order))))
    assert results == {(("v1", "i1", "i2", "i2b"), ("v2",))}


def test_a_message_of_the_tick_itself_waits_for_the_next_one():
    team = LockstepTeam(3, 0)
    team.put(10.1, 1, 0, "sent at the tick")  # a teammate that handled tick 10.1 first
    team.put(10.0 + 1e-9, 2, 0, "sent before")  # ns rounding of the stamp
    assert [x[2] for x in team.due(10.1)] == ["sent before"]
    assert len(team) == 1
    assert [x[2] for x in team.due(10.2)] == ["sent at the tick"]


def test_counts_for_the_barrier():
    team = LockstepTeam(3, 1)
    team.on_sent()
    team.on_sent()
    team.on_received(0)
    team.on_received(2)
    team.on_received(2)
    team.on_received(7)  # no such robot: not counted
    assert team.counts(123_000_000) == [123_000_000, 2, 1, 0, 2]


def test_the_agents_inbox_refuses_a_message_from_another_node_and_counts_it():
    names = ["robot_0", "robot_1", "robot_2"]
    inbox = TeamInbox(3, 15, 0, names=names)
    assert inbox.sender_problem(1, "/robot_1/patrol_agent") is None
    why = inbox.sender_problem(1, "/robot_2/patrol_agent")  # robot 2's node as robot 1
    assert why is not None and "/robot_2/patrol_agent" in why
    assert inbox.sender_problem(1, "/hostile") is not None  # robot 1's own node came first
    assert inbox.rejections == {"sender": 2} and inbox.rejected == 2
    inbox.accept(m.Visit(1, 3, 1e9, 2), now=10.0)  # the other reasons are counted too
    inbox.accept(m.Visit(2, 99, 9.0, 2), now=10.0)
    assert inbox.rejections == {"sender": 2, "clock": 1, "malformed": 1}
    assert inbox.sender_problem(2, "") is None  # rospy did not say: nothing to check


def test_one_sender_rule_for_agents_and_monitor():
    """The monitor's TrafficGuard and the agents' TeamInbox decide with the same SenderCheck:
    the same answers for the same sequence of (robot, caller id)."""
    names = ["robot_0", "robot_1", "robot_2"]
    calls = [(1, "/relay"), (1, "/robot_1/patrol_agent"), (1, "/relay"), (2, "/relay"),
             (2, "/other"), (0, "/robot_2/x"), (0, "/robot_0/patrol_agent")]
    rule = SenderCheck(3, names)
    expected = [rule.ok(r, s) for r, s in calls]
    assert expected == [True, True, False, True, False, False, True]
    guard = TrafficGuard(3, 15, names)
    inbox = TeamInbox(3, 15, 0, names=names)
    for k, ((r, s), ok) in enumerate(zip(calls, expected, strict=True)):
        assert (guard.check(r, GOAL, 1, 0, 10.0 + k, float("nan"), s) != "sender") == ok
        assert (inbox.sender_problem(r, s) is None) == ok


def test_a_message_stamped_far_ahead_is_refused_at_once():
    """It would never be due (the clock check of the inbox, at receipt in lock-step)."""
    team = LockstepTeam(3, 0, max_ahead_s=30.0)
    assert team.put(1000.0, 1, 0, "before any tick")  # no clock yet: queued
    team.due(10.0)
    assert not team.put(40.2, 1, 0, "30.2 s ahead")
    assert not team.put(float("nan"), 1, 0, "no time")
    assert team.put(39.9, 1, 0, "29.9 s ahead")
    assert len(team) == 2
