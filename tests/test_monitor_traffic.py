"""Issue 33 item 6: hostile team traffic cannot silently corrupt the monitor (FleetMonitor and
its TrafficGuard, the agents' TeamInbox rate limit, one run start per run)."""

from __future__ import annotations

import pytest
from tpuaf.measure.monitor import FleetMonitor
from tpuaf.measure.traffic import TrafficGuard
from tpuaf.team import messages as m
from tpuaf.team.epoch import ADOPTED, CROSS_WINDOW_S, EARLIER, KEPT, RunEpoch
from tpuaf.team.inbox import TeamInbox
from tpuaf.topics import GOAL, HEARTBEAT, REACHED, START, VERTEX_CLOSED

from tests.test_metrics import line_map

NAMES = ["robot_0", "robot_1", "robot_2"]
AGENT = "/robot_{}/patrol_agent"
DT = 0.1  # [s] pose period


def shuttle(t: float, r: int) -> float:
    """x [m] of robot r at t [s]: to and fro over the 20 m line at 1 m/s, phase 10 r m."""
    s = (t + 10.0 * r) % 40.0
    return s if s <= 20.0 else 40.0 - s


def fleet_run(rogue=None, duplicate=False, names=NAMES, duration_s=80.0):
    """3 robots shuttling on line3; each robot's agent sends 1 Hz heartbeats and a GOAL to the
    vertex ahead. `rogue(t, mon)` is called every pose step (0.1 s) to inject traffic.
    Returns the monitor."""
    mon = FleetMonitor(line_map(), 3, duration_s, lag_s=1.0, death_timeout_s=5.0,
                       robot_names=names)
    goal = [None] * 3
    for k in range(int((duration_s + 3) / DT)):
        t = round(k * DT, 6)
        for r in range(3):
            sends = []
            if k == 0:
                sends.append((START, round(shuttle(0.0, r) / 10.0)))
            if k % 10 == 0:
                sends.append((HEARTBEAT, -1))
            x = shuttle(t, r)
            if (t + 10.0 * r) % 40.0 < 20.0:  # moving right: the next vertex on the right
                nxt = min(2, int(x // 10.0) + 1)
            else:
                nxt = max(0, int(-(-x // 10.0)) - 1)
            if nxt != goal[r]:
                goal[r] = nxt
                sends.append((GOAL, nxt))
            for kind, v in sends:
                for _ in range(2 if duplicate else 1):
                    mon.on_event(r, kind, v, t, -1, AGENT.format(r))
        if rogue is not None:
            rogue(t, mon)
        for r in range(3):
            mon.on_pose(r, t, shuttle(t, r), 0.0)
    assert mon.finished
    return mon


@pytest.fixture(scope="module")
def clean():
    return fleet_run().summary()


def test_a_clean_run_refuses_nothing(clean):
    assert clean["visits"] > 20 and clean["deaths"] == 0
    assert clean["rejected"]["total"] == 0 and clean["suspect_traffic"] is False


def flood(robot, sender, kinds=(GOAL, REACHED, HEARTBEAT), rate_hz=50.0, skew_s=0.0):
    """A rogue publishing as `robot` at rate_hz: every kind, every vertex, in turn."""
    sent = []

    def rogue(t, mon):
        for j in range(int(rate_hz * DT)):
            kind = kinds[(len(sent) + j) % len(kinds)]
            mon.on_event(robot, kind, (len(sent) + j) % 3, t + skew_s, -1, sender)
        sent.extend([t] * int(rate_hz * DT))
    return rogue, sent


def test_a_flood_as_robot_1_from_another_node_changes_nothing_and_is_counted(clean):
    rogue, sent = flood(1, "/rogue")
    s = fleet_run(rogue).summary()
    assert s["visits"] == clean["visits"] and s["deaths"] == 0
    assert s["idleness_max_s"] == clean["idleness_max_s"]
    assert s["rejected"]["by_reason"] == {"sender": len(sent)}
    assert s["rejected"]["by_robot"] == [{"robot": 1, "sender": len(sent)}]
    assert s["suspect_traffic"] is True


def test_a_node_of_robot_2_cannot_speak_for_robot_0(clean):
    # the old failure: a flood as robot 2 made robot 0 dead
    rogue, sent = flood(0, "/robot_2/rogue", kinds=(HEARTBEAT, GOAL))
    s = fleet_run(rogue).summary()
    assert s["deaths"] == 0 and s["visits"] == clean["visits"]
    assert s["rejected"]["by_reason"] == {"sender": len(sent)}


def test_without_caller_ids_a_flood_is_rate_limited():
    # a bag without caller ids: the flood shares robot 1's name; beyond 20/s it is refused
    rogue, sent = flood(1, None, kinds=(GOAL,))
    mon = fleet_run(rogue, names=None)
    s = mon.summary()
    assert s["deaths"] == 0
    refused = s["rejected"]["by_reason"]  # 5 GOALs of 3 vertices a stamp: duplicates too
    assert 0.5 * len(sent) < refused["rate"] + refused["duplicate"] < len(sent)
    assert s["suspect_traffic"] is True
    assert mon.live()["rejected"] == s["rejected"]["total"]
    assert mon.live()["rejected_reasons"] == list(s["rejected"]["by_reason"])


def test_off_clock_stamps_are_refused(clean):
    rogue, sent = flood(1, "/robot_1/patrol_agent", kinds=(HEARTBEAT,), rate_hz=10.0,
                        skew_s=100.0)
    s = fleet_run(rogue).summary()
    # the first ones come before any pose (no clock yet): accepted, harmless heartbeats
    assert s["rejected"]["by_reason"]["clock"] >= len(sent) - 1
    assert s["visits"] == clean["visits"] and s["deaths"] == 0


def test_every_event_twice_is_counted_once(clean):
    mon = fleet_run(duplicate=True)
    s = mon.summary()
    assert s["visits"] == clean["visits"] and s["idleness_avg_s"] == clean["idleness_avg_s"]
    assert s["rejected"]["by_reason"] == {"duplicate": mon.traffic.accepted}


def test_a_reported_visit_far_from_the_robot_is_implausible():
    mon = FleetMonitor(line_map(), 1, 20.0, lag_s=1.0, visit_source="reports")
    mon.on_event(0, START, 0, 0.0)
    for k in range(230):
        t = k * 0.1
        if k in (50, 100):  # at 5 s: vertex 2 is 15 m away; at 10 s vertex 1 is where it is
            mon.on_event(0, REACHED, 2 if k == 50 else 1, t)
        mon.on_pose(0, t, min(t, 10.0), 0.0)
    s = mon.summary()
    assert s["visits"] == 2 and s["rejected"]["by_reason"] == {"implausible": 1}


def test_guard_refuses_unknown_robots_vertices_and_counts_by_robot():
    g = TrafficGuard(2, 3, ["a0", "a1"])
    assert g.check(5, HEARTBEAT, -1, -1, 1.0, 1.0) == "unknown_robot"
    assert g.check(0, GOAL, 7, -1, 1.0, 1.0) == "vertex"
    assert g.check(0, VERTEX_CLOSED, -1, -1, 1.0, 1.0) == "vertex"  # a closure names a vertex
    assert g.check(0, GOAL, 1, -1, float("nan"), 1.0) == "clock"
    assert g.check(0, GOAL, 1, -1, 1.0, 1.0) is None
    assert g.counts == {(-1, "unknown_robot"): 1, (0, "vertex"): 2, (0, "clock"): 1}
    rows = g.summary()["rejected"]["by_robot"]
    assert rows == [{"robot": -1, "unknown_robot": 1}, {"robot": 0, "clock": 1, "vertex": 2}]


def test_one_run_start_a_far_earlier_one_is_ignored_and_counted():
    epoch = RunEpoch()
    assert epoch.offer(100.0) == ADOPTED
    assert epoch.offer(100.0 - CROSS_WINDOW_S / 2) == EARLIER  # crossing announcements
    assert epoch.offer(10.0, "/rogue") == KEPT and epoch.epoch_s == 100.0 - CROSS_WINDOW_S / 2
    assert epoch.ignored == 1


def test_the_agents_inbox_rate_limits_a_sender():
    inbox = TeamInbox(3, 3, me=0)
    taken = [inbox.accept(m.Visit(1, 1, 5.0), 5.0)[0] is not None for _ in range(100)]
    assert sum(taken) == inbox.config.burst and inbox.rejected == 100 - inbox.config.burst
    # robot 2 has its own budget; robot 1's refills with time
    assert inbox.accept(m.Visit(2, 1, 5.0), 5.0)[0] is not None
    assert inbox.accept(m.Visit(1, 1, 6.0), 6.0)[0] is not None


def test_events_trailing_the_poses_are_waited_for_with_hold(clean, monkeypatch):
    """Issue 33 item 7: in a fast lock-step run the monitor's event callbacks trail its poses;
    with hold_s (the live node's) a pose group waits for every robot's heartbeat at or after it,
    so the figures equal those of the bag's replay in stamp order."""
    import tests.test_monitor_traffic as me

    calls = []

    class Tap(FleetMonitor):
        def on_event(self, *args):
            calls.append((args[3], "on_event", args))
            return True

        def on_pose(self, *args):
            calls.append((args[1], "on_pose", args))

        @property
        def finished(self):
            return True

        @finished.setter
        def finished(self, value):
            pass

    monkeypatch.setattr(me, "FleetMonitor", Tap)
    fleet_run()
    monkeypatch.undo()
    delay = 8.0  # [s] every event arrives 8 s of the clock after the poses stamped with it
    arrivals = sorted(((t + delay if kind == "on_event" else t), k, kind, args)
                      for k, (t, kind, args) in enumerate(calls))
    for hold, same in ((0.0, False), (10.0, True)):
        mon = FleetMonitor(line_map(), 3, 80.0, lag_s=1.0, death_timeout_s=5.0,
                           robot_names=NAMES, hold_s=hold)
        for _, _, kind, args in arrivals:
            getattr(mon, kind)(*args)
        mon.drain()  # the stream ended (MonitorFeed.close)
        s = mon.summary()
        right = s["visits"] == clean["visits"] and not s.get("outages")
        assert right is same, (hold, s["visits"], s.get("outages"))


@pytest.mark.parametrize("hold", [0.0, 10.0])
def test_a_visit_stamped_before_the_end_and_delivered_late_is_counted_with_hold(hold):
    """The live monitor's end waits (hold_s) for a heartbeat past the end from every robot ever
    heard, dead ones too: a REACHED stamped 0.5 s before the end that a loaded machine delivers
    after 5 s more of poses still counts; without the hold it is lost."""
    mon = FleetMonitor(line_map(), 1, 20.0, lag_s=1.0, death_timeout_s=5.0,
                       visit_source="reports", robot_names=NAMES[:1], hold_s=hold)
    mon.on_event(0, START, 0, 0.0, -1, AGENT.format(0))
    late = None
    for k in range(int(26.0 / DT)):
        t = round(k * DT, 6)
        if k % 10 == 0 and t <= 19.0:  # heartbeats stop 1 s before the end: dead at the end
            mon.on_event(0, HEARTBEAT, -1, t, -1, AGENT.format(0))
        if t == 19.5:
            late = (0, REACHED, 1, t, 0, AGENT.format(0))  # sent now, delivered at 25 s
        if t == 25.0:
            mon.on_event(*late)
        mon.on_pose(0, t, 10.0 if t >= 19.5 else t / 2.0, 0.0)
    mon.drain()
    assert mon.finished
    assert mon.summary()["visits"] == (2 if hold else 1)  # START and the late REACHED
