"""What a hardware agent checks on its inputs (ROS-free): team message checks and clock skew
(tpuaf.team.inbox), silent teammates and stale inputs (tpuaf.team.liveness), the tf pose chain
(tpuaf.navigation.frames) and the move_base navigator (tpuaf.navigation.GoalNavigator)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from tpuaf.maps import load_map
from tpuaf.navigation import Event, GoalClient, GoalNavigator, GraphRoute
from tpuaf.navigation.frames import FrameChain, StaticFrames
from tpuaf.policies import REGISTRY, RobotContextBase
from tpuaf.team import messages as m
from tpuaf.team.inbox import InboxConfig, TeamInbox
from tpuaf.team.liveness import InputWatchdog, TeammateLiveness

# --- team message checks ---------------------------------------------------------------------


@pytest.mark.parametrize("msg, why", [
    (m.Visit(7, 1, 10.0, 2), "unknown robot index 7"),
    (m.Visit(-1, 1, 10.0, 2), "unknown robot index -1"),
    (m.Visit(0, 1, 10.0, 2), "robot index 0 is ours"),
    (m.Visit(1, 15, 10.0, 2), "vertex 15 is outside the map"),
    (m.Visit(1, 3, 10.0, -5), "next vertex -5 is outside the map"),
    (m.Visit(1, 3, math.nan, 2), "time nan is not finite"),
    (m.Visit(1, 3, math.inf, 2), "time inf is not finite"),
    (m.Visit(1, 3, 1e9, 2), "from our clock"),
    (m.Intention(1, 0, 3, math.inf, 5.0, 10.0), "expected_arrival inf is not finite"),
    (m.Intention(1, 0, 3, 15.0, -1.0, 10.0), "travel time -1.0 s < 0"),
    (m.Intention(1, 0, 3, 1e7, 5.0, 10.0), "expected arrival"),
    (m.IdlenessEstimate(1, 10.0, (0.0,) * 3, 2), "estimate of 3 vertices"),
    (m.IdlenessEstimate(1, 10.0, (math.nan,) * 15, 2), "negative or non-finite"),
    (m.TaskBid(1, 3, -2.0, 10.0), "bid -2.0"),
])
def test_impossible_team_messages_are_refused_with_a_reason(msg, why):
    inbox = TeamInbox(3, 15, 0)
    out, reason = inbox.accept(msg, now=10.0)
    assert out is None and why in reason
    assert inbox.rejected == 1


def test_valid_messages_pass_unchanged_without_skew():
    inbox = TeamInbox(3, 15, 0)
    for msg in (m.Visit(1, 3, 9.99, -1), m.Intention(2, 3, 4, 20.0, 10.0, 9.99),
                m.IdlenessEstimate(1, 9.99, (1.0,) * 15, 4), m.TaskRequest(2, 0, 3.5, 9.99)):
        out, reason = inbox.accept(msg, now=10.0)
        assert reason is None and out.time == pytest.approx(9.99, abs=1e-9)
    assert inbox.skewed() == {}


def test_skew_is_estimated_corrected_and_named():
    inbox = TeamInbox(3, 15, 0, InboxConfig(skew_warn_s=1.0))
    rng = np.random.default_rng(0)
    for k in range(20):  # robot 1 runs 0.5 s ahead, robot 2 3 s ahead; 1-20 ms delay
        now = 10.0 + k
        delay = rng.uniform(0.001, 0.02)
        out1, _ = inbox.accept(m.Visit(1, 3, now - delay + 0.5, 4), now)
        out2, _ = inbox.accept(m.Intention(2, 3, 4, now - delay + 3.0 + 8.0, 8.0,
                                           now - delay + 3.0), now)
    assert inbox.skew.offset(1) == pytest.approx(0.5, abs=0.02)
    assert inbox.skew.offset(2) == pytest.approx(3.0, abs=0.02)
    assert out1.time == pytest.approx(now, abs=0.03) and out1.time <= now
    assert out2.expected_arrival == pytest.approx(now + 8.0, abs=0.03)
    assert set(inbox.skewed()) == {2}  # only beyond skew_warn_s


def test_one_forged_stamp_does_not_move_the_estimate():
    inbox = TeamInbox(2, 15, 0)
    for k in range(10):
        inbox.accept(m.Visit(1, 3, 10.0 + k, 4), 10.0 + k)
    inbox.accept(m.Visit(1, 3, 45.0, 4), 20.0)  # 25 s ahead: within max_skew, an outlier
    assert abs(inbox.skew.offset(1)) < 0.01


class _Ctx(RobotContextBase):
    def __init__(self, pm, robot):
        self.patrol_map, self.robot, self.n_robots = pm, robot, 2
        self.rng = np.random.default_rng(robot)
        self._current = self._start_vertex = 0
        self._start_position = tuple(pm.positions[0])
        self.now = 0.0
        self.sent = []

    @property
    def position(self):
        return tuple(self.patrol_map.positions[self._current])

    def send(self, message):
        self.sent.append(message)

    def wake_at(self, time):
        pass


def _decisions(skew_s, inbox=True):
    """Robot 0 (TPUAF on lab) hears robot 1's visits stamped by a clock skew_s ahead, through
    the inbox or raw."""
    pm = load_map("lab")
    checks = TeamInbox(2, pm.num_vertices, 0)
    policy = REGISTRY.create("tpuaf")
    ctx = _Ctx(pm, 0)
    policy.start(ctx)
    goals = []
    mate = [14, 13, 12, 11, 10, 9]  # robot 1 walks along the far side
    for k in range(30):
        ctx.now = 6.0 * (k + 1)
        if k % 5 == 0:
            v = mate[(k // 5) % len(mate)]
            msg = m.Visit(1, v, ctx.now - 0.01 + skew_s, v)
            if inbox:
                msg, _ = checks.accept(msg, ctx.now)
            policy.on_message(msg, ctx)
        goal = policy.decide(ctx)
        goals.append(goal)
        ctx._current = goal
    return goals, np.asarray(policy.knowledge.last_visit)


def test_half_a_second_of_skew_changes_no_decision():
    base_goals, base_last = _decisions(0.0)
    goals, last = _decisions(0.5)
    assert goals == base_goals
    assert np.allclose(last, base_last, atol=0.05)


def test_a_robot_ahead_no_longer_suppresses_our_visits():
    base_goals, base_last = _decisions(0.0)
    raw_goals, raw = _decisions(20.0, inbox=False)
    goals, corrected = _decisions(20.0)
    assert np.nanmax(raw - base_last) > 10.0  # visits from the future
    assert raw_goals != base_goals
    assert goals == base_goals and np.allclose(corrected, base_last, atol=0.05)


# --- liveness --------------------------------------------------------------------------------


def test_a_silent_teammate_is_lost_once_then_back():
    live = TeammateLiveness(3, 0, timeout_s=10.0)
    assert live.check(100.0) == []  # never heard: not lost
    live.heard(1, 0.0)
    live.heard(2, 0.0)
    live.heard(2, 8.0)
    assert live.check(10.5) == [1]
    assert live.check(11.0) == []  # reported once
    assert live.check(18.5) == [2]
    assert live.heard(1, 20.0) is True and 1 not in live.lost
    assert live.heard(1, 21.0) is False


def test_input_watchdog_needs_advancing_stamps():
    wd = InputWatchdog(("pose", "scan"), timeout_s=1.0)
    assert wd.check(0.0) == (("pose", "scan"), True)  # nothing yet
    wd.fed("pose", 5.0, 0.1)
    wd.fed("scan", 5.0, 0.1)
    assert wd.check(0.5) == ((), True)
    wd.fed("pose", 5.0, 1.0)  # the same stamp again: not fresh
    wd.fed("scan", 6.0, 1.0)
    assert wd.check(1.5) == (("pose",), True)
    assert wd.check(1.6) == (("pose",), False)
    wd.fed("pose", 6.1, 1.7)
    assert wd.check(1.8) == ((), True)


def test_policy_forgets_a_lost_teammates_intention():
    pm = load_map("lab")
    policy = REGISTRY.create("tpuaf")
    ctx = _Ctx(pm, 0)
    policy.start(ctx)
    policy.on_message(m.Intention(1, 14, 13, 20.0, 6.0, 14.0), ctx)
    assert [i[0] for i in policy.knowledge.intentions] == [1]
    policy.on_teammate_lost(1, ctx)
    assert policy.knowledge.intentions == []
    for name in REGISTRY.names():  # the hook exists for every strategy (no-op by default)
        assert callable(REGISTRY.get(name).on_teammate_lost)


# --- tf chain --------------------------------------------------------------------------------


def test_frame_chain_composes_map_odom_base_and_skips_other_robots():
    c = FrameChain("map", "tb3_0/base_footprint")
    assert c.pose() is None
    assert c.update("tb3_0/odom", "tb3_0/base_footprint", 1.0, 0.0, math.pi / 2, 5.0)
    assert not c.update("tb3_1/odom", "tb3_1/base_footprint", 9.0, 9.0, 0.0, 5.0)
    assert c.missing() == "tb3_0/odom"
    assert not c.update("map", "tb3_1/odom", 3.0, 3.0, 0.0, 5.0)
    assert c.update("/map", "tb3_0/odom", 2.0, 1.0, math.pi / 2, 4.9)
    x, y, yaw, stamp = c.pose()
    # map->odom (2, 1, 90 deg) * odom->base (1, 0, 90 deg) = (2, 2, 180 deg)
    assert (x, y) == pytest.approx((2.0, 2.0)) and abs(abs(yaw) - math.pi) < 1e-9
    assert stamp == pytest.approx(4.9)


def test_static_frames_give_the_laser_mount_and_complete_a_chain():
    statics = StaticFrames()
    assert statics.pose_in("tb3_0/base_footprint", "tb3_0/base_scan") is None
    statics.add("tb3_0/base_footprint", "/tb3_0/base_link", 0.0, 0.0, 0.0)
    statics.add("tb3_0/base_link", "tb3_0/base_scan", -0.032, 0.0, 0.5)
    assert statics.pose_in("tb3_0/base_footprint", "tb3_0/base_scan")[:3] == \
        pytest.approx((-0.032, 0.0, 0.5))
    assert statics.pose_in("tb3_0/base_footprint", "/tb3_0/base_footprint") is None  # itself
    chain = FrameChain("tb3_0/base_footprint", "tb3_0/base_scan")
    statics.feed(chain)  # two links, joined in two passes
    assert set(chain.links) == {"tb3_0/base_scan", "tb3_0/base_link"}


def test_the_odom_origin_is_the_initial_pose_else_the_start_vertex():
    from tpuaf.navigation.frames import compose
    from tpuaf.params import AgentParams
    from tpuaf.runtimes.agent_setup import odom_origin

    pm = load_map("grid")
    assert odom_origin(AgentParams(map="grid", localization="tf"), pm) is None
    given = AgentParams(map="grid", localization="odom", initial_pose=[1.0, 2.0, 0.5])
    assert odom_origin(given, pm) == (1.0, 2.0, 0.5)
    start = odom_origin(AgentParams(map="grid", localization="odom", robots=2, robot_index=1), pm)
    assert start[2] == 0.0 and any(np.allclose(start[:2], xy) for xy in pm.positions)
    # odom frame -> map frame: (1, 2, 90 deg) * (1, 0, 0) = (1, 3, 90 deg)
    assert compose((1.0, 2.0, math.pi / 2), (1.0, 0.0, 0.0)) == \
        pytest.approx((1.0, 3.0, math.pi / 2))


# --- move_base navigator ---------------------------------------------------------------------


class FakePlanner(GoalClient):
    def __init__(self):
        self.goals, self.cancels, self._state = [], 0, "idle"

    def send(self, x, y, yaw):
        self.goals.append((x, y, yaw))
        self._state = "active"

    def cancel(self):
        self.cancels += 1
        self._state = "idle"

    def state(self):
        return self._state


def test_goal_navigator_sends_waypoints_and_arrives_within_goal_tolerance():
    pm = load_map("grid")
    planner = FakePlanner()
    nav = GoalNavigator(planner, goal_tolerance=0.4, waypoint_tolerance=0.6)
    route = GraphRoute(pm.graph, pm.positions, 0, 2)
    nav.set_route(route, 0.0)
    assert planner.goals[-1][:2] == pytest.approx(tuple(pm.positions[1]))
    _, ev, v = nav.step(1.0, (*pm.positions[1], 0.0))
    assert (ev, v) == (Event.WAYPOINT, 1)
    assert planner.goals[-1][:2] == pytest.approx(tuple(pm.positions[2]))
    _, ev, _ = nav.step(2.0, (pm.positions[2][0] + 0.5, pm.positions[2][1], 0.0))
    assert ev == Event.NONE  # 0.5 m off: not a visit yet
    _, ev, v = nav.step(3.0, (pm.positions[2][0] + 0.3, pm.positions[2][1], 0.0))
    assert (ev, v) == (Event.ARRIVED, 2) and nav.route is None and planner.cancels == 1


def test_goal_navigator_fails_on_abort_and_without_progress():
    pm = load_map("grid")
    planner = FakePlanner()
    nav = GoalNavigator(planner, stuck_timeout_s=10.0)
    nav.set_route(GraphRoute(pm.graph, pm.positions, 0, 1), 0.0)
    planner._state = "failed"
    assert nav.step(1.0, (*pm.positions[0], 0.0))[1:] == (Event.FAILED, 1)
    nav.set_route(GraphRoute(pm.graph, pm.positions, 0, 1), 0.0)
    assert nav.step(5.0, (*pm.positions[0], 0.0))[1] == Event.NONE
    assert nav.step(16.0, (*pm.positions[0], 0.0))[1:] == (Event.FAILED, 1)


# --- node parameter cross-checks -------------------------------------------------------------


@pytest.mark.parametrize("values, sim, why", [
    ({"localization": "gps"}, False, "~localization must be one of tf, odom"),
    ({"navigation": "nav2"}, False, "~navigation must be builtin or move_base"),
    ({"initial_pose": [1.0, 2.0]}, False, "~initial_pose must be [x, y, yaw]"),
    ({"initial_pose": [1.0, 2.0, float("nan")]}, False, "~initial_pose must be [x, y, yaw]"),
    ({"clock_offset": 0.5}, True, "~clock_offset needs the wall clock"),
    ({"lockstep": True, "navigation": "move_base"}, False, "~lockstep needs ~navigation builtin"),
    ({"teammate_timeout": 0.0}, False, "~teammate_timeout must be > 0"),
    ({"robot_index": 2}, False, "~robot_index 2 not in 0..1"),
])
def test_agent_parameter_combinations_are_refused(values, sim, why):
    from tpuaf.params import AgentParams, NodeParamError, parse
    from tpuaf.runtimes.agent_setup import check_agent_params

    with pytest.raises(NodeParamError, match=re.escape(why)):  # by the parser or the node
        check_agent_params(parse(AgentParams, {"map": "lab", "robot_index": 0, "robots": 2,
                                               **values}, "agent"), sim)
