"""One robot protocol (issue 31): the C++ core's `RobotProtocol` is the state machine of every
runtime. The graph runtime's loop drives it in C++; `RobotMachine` (physics runtime, ROS agents)
is a Python adapter that forwards events to it and answers its callbacks. These tests drive the
adapter with a scripted driver and policy, and check that no second state machine is left."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import tpuaf_core
from tpuaf import topics
from tpuaf.maps import load_map
from tpuaf.policies import Policy
from tpuaf.robot.machine import DEFAULT_RETRY_S, STAY_S, RobotMachine

REPO = Path(__file__).resolve().parents[1]


class Driver:
    """A RobotDriver that records the protocol's calls; the robot is where `pose` says."""

    def __init__(self, patrol_map):
        self.now = 0.0
        self.pm = patrol_map
        self.pose = (0.0, 0.0)
        self.calls: list[tuple] = []

    def position_of(self, robot):
        return self.pose

    def transmit(self, robot, message):
        self.calls.append(("transmit", message))

    def schedule_wake(self, robot, time):
        self.calls.append(("wake", time))

    def drive(self, robot, from_vertex, goal):
        self.calls.append(("drive", from_vertex, goal))

    def dwell(self, robot, vertex, duration_s):
        self.calls.append(("dwell", vertex, duration_s))

    def halt(self, robot):
        self.calls.append(("halt",))

    def at(self, vertex, t):
        self.now = float(t)
        self.pose = tuple(float(c) for c in self.pm.positions[vertex])


class Script(Policy):
    """Goals in turn (None: wait); a redirect or a wake-up can be asked for inside decide."""

    name = "script_protocol"
    goals: list = []

    def __init__(self, params=None):
        super().__init__(params)
        self.log: list[tuple] = []
        self.wake_in = None

    def start(self, ctx):
        self.log.append(("start", ctx.current_vertex))

    def decide(self, ctx):
        self.log.append(("decide", ctx.now, ctx.current_vertex))
        if self.wake_in is not None:
            ctx.wake_at(ctx.now + self.wake_in)
        return self.goals.pop(0) if self.goals else None

    def on_goal_failed(self, vertex, ctx):
        self.log.append(("failed", vertex, ctx.current_vertex))

    def on_teammate_lost(self, robot, ctx):
        self.log.append(("lost", robot))


@pytest.fixture()
def grid():
    return load_map("grid")


def _machine(grid, goals, start=0):
    driver = Driver(grid)
    policy = Script()
    policy.goals = list(goals)
    events: list[tuple] = []
    machine = RobotMachine(driver, 0, 3, grid, policy, np.random.default_rng(0),
                           emit=lambda *e: events.append(e), start_vertex=start,
                           teammate_timeout_s=5.0)
    driver.at(start, 0.0)
    return machine, driver, policy, events


def test_the_event_kinds_are_the_protocols():
    ev = tpuaf_core.robot_event
    assert (ev.START, ev.GOAL, ev.REACHED, ev.FAILED, ev.DWELL) == (
        topics.START, topics.GOAL, topics.REACHED, topics.FAILED, topics.DWELL)


def test_machine_is_the_cores_protocol_and_visits_along_a_route(grid):
    machine, driver, policy, events = _machine(grid, [2, 0])
    assert isinstance(machine.protocol, tpuaf_core.RobotProtocol)
    machine.start()
    machine.decide()
    assert events == [(topics.START, 0, -1, 0.0), (topics.GOAL, 2, 0, 0.0)]
    assert driver.calls == [("drive", 0, 2)] and machine.goal == 2
    driver.at(1, 5.0)
    machine.observe(*driver.pose)
    assert machine.on_vertex(1, False) is True  # pass-through: the driver goes on
    driver.at(2, 10.0)
    machine.observe(*driver.pose)
    assert machine.on_vertex(2, True) is False
    assert events[2] == (topics.REACHED, 2, 2, 10.0) and machine.visits == 1
    # Vel(i): the leg's plan metres over its driving time
    assert machine.travelled_m == pytest.approx(grid.graph.distance(0, 2))
    assert machine.travel_time_s == 10.0
    assert policy.log == [("start", 0), ("decide", 0.0, 0), ("decide", 10.0, 2)]
    assert driver.calls[-1] == ("drive", 2, 0) and machine.current_vertex == 2


def test_a_goal_on_its_own_vertex_dwells_and_a_wait_retries(grid):
    machine, driver, policy, events = _machine(grid, [0])
    machine.start()
    machine.decide()
    assert machine.dwelling and driver.calls == [("dwell", 0, STAY_S)]
    driver.at(0, STAY_S)
    assert machine.on_vertex(0, True) is False
    assert events[-1] == (topics.DWELL, 0, 0, STAY_S)
    assert (machine.dwells, machine.dwell_time_s, machine.visits) == (1, STAY_S, 0)
    # no goal left: halt, and decide again after the retry
    assert driver.calls[-2:] == [("halt",), ("wake", STAY_S + DEFAULT_RETRY_S)]
    assert machine.goal is None and machine.wake_pending


def test_a_wake_up_asked_inside_decide_replaces_the_retry(grid):
    machine, driver, policy, _ = _machine(grid, [])
    policy.wake_in = 7.0
    machine.start()
    machine.decide()
    assert driver.calls == [("wake", 7.0), ("halt",)]
    policy.wake_in, policy.goals = None, [3]
    driver.now = 7.0
    machine.on_wake()
    assert driver.calls[-1] == ("drive", 0, 3)
    machine.on_wake()  # it has a goal now: ignored
    assert len(policy.log) == 3


def test_redirect_failure_death_and_liveness(grid):
    machine, driver, policy, events = _machine(grid, [2, 4])
    machine.start()
    machine.decide()
    machine.change_goal(3)
    with pytest.raises(IndexError):
        machine.change_goal(grid.num_vertices)
    driver.at(1, 5.0)
    assert machine.on_vertex(1, False) is False  # redirected at the next vertex
    assert events[-1] == (topics.GOAL, 3, 1, 5.0) and driver.calls[-1] == ("drive", 1, 3)
    machine.on_goal_failed(3, 2)
    assert events[-2][:3] == (topics.FAILED, 3, 1) and machine.failures == 1
    assert policy.log[-2:] == [("failed", 3, 2), ("decide", 5.0, 2)]
    assert machine.hear(1, 1.0) is False and machine.check_liveness(6.0) == [1]
    assert policy.log[-1] == ("lost", 1) and 1 in machine.liveness.lost
    assert machine.hear(1, 7.0) is True and 1 not in machine.liveness.lost
    machine.die()
    assert driver.calls[-1] == ("halt",) and not machine.alive and machine.goal is None
    n = len(policy.log)
    machine.decide()
    machine.on_wake()
    assert machine.on_vertex(4, True) is False and len(policy.log) == n


def test_no_second_robot_state_machine_is_left():
    """The graph loop and RobotMachine hold no goal, redirect or dwell state of their own: the
    protocol (robot_protocol.cpp) does."""
    core = REPO / "src" / "tpuaf_core_cpp"
    engine = "".join((core / "src" / f).read_text() for f in ("engine.cpp", "engine_faults.cpp"))
    engine += (core / "include" / "tpuaf_core" / "engine.hpp").read_text()
    assert not re.search(r"\b(redirect|wake_pending|dwelling|last_heard)\s*=", engine)
    machine = (REPO / "src/tpuaf_ros/src/tpuaf/robot/machine.py").read_text()
    assert not re.search(r"self\.(goal|redirect|dwelling|wake_pending|alive|_current)\s*=",
                         machine)
    assert "def _reach" not in machine and "TeammateLiveness(" not in machine


def test_the_heartbeat_feed_and_check_schedule_are_the_links_per_teammate_answers():
    """HeartbeatLinks.feed / next_check_of (what the graph loop and TeamRun plan a robot's
    liveness checks with) against last_arrival_s / next_check_s teammate by teammate."""
    from tpuaf.team.liveness import TeammateLiveness, heartbeat_links

    links = heartbeat_links(4, 300.0, 10.0, delay_s=0.5, loss=0.6, seed=2)
    links.died(3, 40.0)
    live = TeammateLiveness(4, 0, 10.0)
    for now in (0.2, 30.0, 55.0, 120.0):
        links.feed(live, now)
        want = [links.last_arrival_s(0, j, now) for j in range(4)]
        assert live.last_heard[1:] == want[1:]
        due = min(links.next_check_s(0, j, live.last_heard_s(j), live.is_lost(j), now)
                  for j in (1, 2, 3))
        assert links.next_check_of(live, now) == due
        live.check(max(now, due if np.isfinite(due) else now))
    assert 3 in live.lost  # dead at 40 s: silent for good


def test_a_policy_error_reaches_the_caller_and_a_protocol_without_its_machine_refuses(grid):
    machine, driver, policy, _ = _machine(grid, [])

    def broken(ctx):
        raise KeyError("boom")

    policy.decide = broken
    machine.start()
    with pytest.raises(RuntimeError, match="strategy 'script_protocol' failed for robot 0.*boom"):
        machine.decide()
    protocol = machine.protocol
    del machine
    import gc

    gc.collect()
    with pytest.raises(RuntimeError, match="RobotMachine of this RobotProtocol is gone"):
        protocol.decide()
