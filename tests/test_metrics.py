"""Metrics of SPEC section 6: hand-computed visit logs and trajectories."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
import tpuaf_core
from tpuaf.maps import MapSettings, PatrolMap, load_map
from tpuaf.measure.metrics import RunRecorder, acceleration_ratio, complete_cycles, idleness_stats


def line_map(d_if: float = 2.0) -> PatrolMap:
    settings = MapSettings(interference_distance=d_if)
    return PatrolMap(
        name="line3",
        vertex_ids=[10, 11, 12],
        positions=np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0]]),
        edges=[(0, 1, math.nan), (1, 2, math.nan)],
        importance=np.full(3, 0.01),
        initial_uncertainty=np.ones(3),
        settings=settings,
    )


# (time, robot, vertex index)
LOG = [(0, 0, 0), (2, 1, 2), (5, 0, 1), (10, 0, 0), (14, 1, 2), (15, 0, 1), (22, 1, 0)]
# interval idleness by hand: v0 10, 12; v2 12; v1 10 (in visit order: 10, 12, 10, 12)


def test_shared_helpers_and_recorder_on_hand_log():
    """The one implementation (RunRecorder) on a hand-computed log; the pure helpers it shares
    with the reports."""
    rec = RunRecorder(line_map(), 2, ground_truth=False)
    for t, r, v in LOG:
        rec.record_visit(r, v, t)
    assert sorted(rec.interval_samples) == [10.0, 10.0, 12.0, 12.0]
    stats = idleness_stats(rec.interval_samples)
    assert stats == {"avg": 11.0, "std": 1.0, "min": 10.0, "max": 12.0, "count": 4}
    assert rec.visit_counts == [3, 2, 2]
    assert complete_cycles(rec.visit_counts) == 1
    assert complete_cycles([3, 0, 2]) == 0
    # Worst: v2 waits 12 s (2 -> 14); v1 first visit at 5 counts from 0; end 25: v2 11 s.
    assert rec.worst_idleness(25) == 12.0
    assert rec.worst_idleness(40) == 40 - 14
    assert math.isnan(idleness_stats([])["avg"])


def test_recovery_on_a_hand_log():
    """Death of robot 1 at t = 6 on the 3-vertex line: every vertex is visited again by 15
    (v1 at 15 is the last); worst idleness after: v2 waits 2 -> 14 (12 s); robot 1 had
    announced v0 (at 2, after its last visit at 2), which robot 0 visits at 10."""
    rec = RunRecorder(line_map(), 2, ground_truth=False)
    log = [(0, 0, 0), (2, 1, 2), (5, 0, 1), (10, 0, 0), (14, 0, 2), (15, 0, 1)]
    for t, r, v in log:
        rec.record_visit(r, v, t)
    rec.record_announcement(1, 0, 2.0)
    rec.record_announcement(1, 1, 1.0)  # before its last visit: spent
    rec.record_robot_death(1, 6.0)
    (r,) = rec.summary(20.0)["recovery"]
    assert r["robot"] == 1 and r["survivors"] == 1
    assert r["recovery_time_s"] == 15.0 - 6.0
    assert r["worst_idleness_after_s"] == 12.0
    assert r["intentions"] == [10] and r["intentions_honoured"] == 1
    assert r["intention_delays_s"] == [4.0]
    assert r["ideal_worst_idleness_survivors_s"] == pytest.approx(40.0)  # 20 m there and back
    assert r["window_end_s"] == 20.0


def test_recovery_over_the_reachable_vertices_on_a_hand_log():
    """Robot 1 dies at 6 s on the line and v2 cannot be reached after (a body next to it:
    `closed`): the plain worst idleness after the death counts v2 (2 -> 30 s), the reachable
    one only v0 and v1 (v1: 15 -> 30 s), against max(floor at detection, ideal 40 s)."""
    rec = RunRecorder(line_map(), 2, ground_truth=False, teammate_timeout_s=1.0)
    for t, r, v in [(0, 0, 0), (2, 1, 2), (5, 0, 1), (10, 0, 0), (15, 0, 1), (20, 0, 0)]:
        rec.record_visit(r, v, t)
    rec.record_robot_death(1, 6.0)
    (plain,) = rec.recovery(30.0)
    assert plain["worst_idleness_after_s"] == 28.0 and "worst_idleness_ratio_reachable" not in plain
    (r,) = rec.recovery(30.0, closed=[2])
    assert r["worst_idleness_after_s"] == 28.0  # the plain figures stay
    assert r["worst_idleness_after_reachable_s"] == 15.0
    assert r["worst_idleness_ratio_reachable"] == pytest.approx(15.0 / 40.0)
    assert r["worst_idleness_ratio_to_detection_reference"] == pytest.approx(28.0 / 40.0)


@pytest.mark.parametrize("body_m", [0.165, None])
def test_a_dead_robots_body_on_a_vertex_is_left_out_of_the_reachable_recovery(body_m):
    """Robot 1 dies at 6 s standing 5 cm from v2: with bodies (physics, fleets) no robot's
    centre can come within the visit radius (0.15 m) of v2 while keeping the controller's
    safety margin (0.08 m) from it, since 2 x 0.165 + 0.08 - 0.15 = 0.26 m > 5 cm, so the
    reachable recovery leaves v2 out; point robots (the graph runtime) keep it."""
    rec = RunRecorder(line_map(), 2, ground_truth=False, teammate_timeout_s=1.0,
                      body_radius_m=body_m)
    rec.record_positions(0.0, np.array([[0.0, 0.0], [20.0, 0.0]]))
    for t, r, v in [(0, 0, 0), (2, 1, 2), (5, 0, 1), (10, 0, 0), (15, 0, 1), (20, 0, 0)]:
        rec.record_visit(r, v, t)
    rec.record_positions(6.0, np.array([[6.0, 0.0], [19.95, 0.0]]))
    rec.record_robot_death(1, 6.0)
    rec.record_positions(7.0, np.array([[7.0, 0.0], [np.nan, np.nan]]))  # dead: absent
    s = rec.summary(30.0)
    (r,) = s["recovery"]
    assert r["worst_idleness_after_s"] == 28.0  # v2, never visited again, in the plain figure
    if body_m is None:
        assert "vertices_under_bodies" not in s and "worst_idleness_after_reachable_s" not in r
    else:
        assert s["vertices_under_bodies"] == [12]
        assert r["worst_idleness_after_reachable_s"] == 15.0  # v1's gap 15 -> 30 s
    # in a 2 m wide corridor a body 0.3 m off v2 lets a robot by: its centre reaches 0.11 m
    # from v2 beyond the body, keeping 2 radii + the safety margin (0.41 m) from its centre
    wide = replace(line_map(), corridor_width=2.0)
    assert body_cut_off(wide, 19.7) == set()
    # 0.19 m off (DIAG_labs N = 12, recovery_physics.md): no spot within the visit radius of
    # v2 is 0.41 m from the body's centre
    assert body_cut_off(wide, 19.81) == {2}
    # in the map's own 1.01 m corridor no robot gets by a body, however far from v2 (the old
    # rule, distance to the vertex alone, called v2 reachable at 0.3 m)
    assert body_cut_off(line_map(), 19.7) == {2}
    assert body_cut_off(line_map(), 15.0) == {2}
    assert body_cut_off(wide, 15.0) == set()


def body_cut_off(patrol_map: PatrolMap, body_x: float) -> set[int]:
    """The vertices a dead robot at (body_x, 0) [m] cuts off from a survivor at (6, 0)."""
    rec = RunRecorder(patrol_map, 2, ground_truth=False, teammate_timeout_s=1.0,
                      body_radius_m=0.165)
    rec.record_positions(6.0, np.array([[6.0, 0.0], [body_x, 0.0]]))
    rec.record_robot_death(1, 6.0)
    return rec.bodies_closed()


def test_death_floor_on_a_square_hand_log():
    """Two robots 20 m apart on a 10 m square (1 m/s); robot 1 dies at 25 s, 5 m past v0.
    The survivor is then mid-way v2-v3 (its visits bound it exactly: 15, 15, 5, 5 m from
    v0..v3); v1 was last visited at 10 s: it cannot be visited before 25 + 15 s, so no
    strategy keeps its idleness under 30 s (the floor). The survivor's lap (40 s) is the
    ideal, and it achieves it: ratio 1.0 to max(floor, ideal)."""
    side = 10.0
    pos = np.array([(0, 0), (side, 0), (side, side), (0, side)], dtype=float)
    edges = [(0, 1, side), (1, 2, side), (2, 3, side), (3, 0, side)]
    pm = PatrolMap("square", [0, 1, 2, 3], pos, edges, np.ones(4), np.ones(4), MapSettings())
    rec = RunRecorder(pm, 2, ground_truth=False)
    log = [(0, 0, 0), (0, 1, 2), (10, 0, 1), (10, 1, 3), (20, 0, 2), (20, 1, 0)]
    log += [(30 + 10 * k, 0, (3 + k) % 4) for k in range(8)]  # the survivor goes on alone
    for t, r, v in log:
        rec.record_visit(r, v, t)
    rec.record_robot_death(1, 25.0)
    from tpuaf.measure.metrics import death_floor

    assert death_floor(pm, 1.0, 0.0, rec.vertex_times, rec.visits, 25.0, 100.0, [0]) == pytest.approx(30.0)
    assert death_floor(pm, 1.0, 0.0, rec.vertex_times, rec.visits, 25.0, 32.0, [0]) == pytest.approx(22.0)  # capped: v1 at 32 s
    assert math.isnan(death_floor(pm, 1.0, 0.0, rec.vertex_times, rec.visits, 25.0, 100.0, []))
    (r,) = rec.summary(100.0)["recovery"]
    assert r["floor_worst_idleness_after_s"] == pytest.approx(30.0)
    assert r["ideal_worst_idleness_survivors_s"] == pytest.approx(40.0)
    assert r["worst_idleness_after_s"] == pytest.approx(40.0)
    assert r["worst_idleness_ratio_to_reference"] == pytest.approx(1.0)
    # Had the survivor stopped at v2 instead (no visit after 20 s): it may be anywhere within
    # 5 m of v2 at the death, so v1 (idle 15 s, 5 m away) gives the floor 20 s; vertices then
    # wait to the end (90 s).
    rec2 = RunRecorder(pm, 2, ground_truth=False)
    for t, r_, v in log[:6]:
        rec2.record_visit(r_, v, t)
    rec2.record_robot_death(1, 25.0)
    (r2,) = rec2.summary(100.0)["recovery"]
    assert r2["floor_worst_idleness_after_s"] == pytest.approx(20.0)
    assert r2["worst_idleness_ratio_to_reference"] == pytest.approx(90.0 / 40.0)
    assert r2["detection_floor_worst_idleness_after_s"] is None  # no timeout given (NaN -> null)


def test_floor_at_detection_on_the_square_hand_log():
    """The square log above, survivors with a 10 s teammate timeout: they can know of the
    death at 35 s. The survivor is then 5 m past v3 towards v0 (visits at 30 s and 40 s), so at
    least 5, 15, 15, 5 m from v0..v3; v1, last visited at 10 s, cannot be visited before
    35 + 15 s: the floor at detection is 40 s (against 30 s at the death). The survivor's 40 s
    lap meets it: ratio 1.0."""
    side = 10.0
    pos = np.array([(0, 0), (side, 0), (side, side), (0, side)], dtype=float)
    edges = [(0, 1, side), (1, 2, side), (2, 3, side), (3, 0, side)]
    pm = PatrolMap("square", [0, 1, 2, 3], pos, edges, np.ones(4), np.ones(4), MapSettings())
    rec = RunRecorder(pm, 2, ground_truth=False, teammate_timeout_s=10.0)
    log = [(0, 0, 0), (0, 1, 2), (10, 0, 1), (10, 1, 3), (20, 0, 2), (20, 1, 0)]
    log += [(30 + 10 * k, 0, (3 + k) % 4) for k in range(8)]
    for t, r, v in log:
        rec.record_visit(r, v, t)
    rec.record_robot_death(1, 25.0)
    (r,) = rec.summary(100.0)["recovery"]
    assert r["floor_worst_idleness_after_s"] == pytest.approx(30.0)
    assert r["detection_floor_worst_idleness_after_s"] == pytest.approx(40.0)
    assert r["worst_idleness_ratio_to_detection_reference"] == pytest.approx(1.0)
    # A window that ends before the timeout runs out (the survivor dies too, at 33 s): the
    # detection is the window's end, where each vertex is capped: v1, idle since 10 s, gives 23 s.
    rec.record_robot_death(0, 33.0)
    first = rec.summary(100.0)["recovery"][0]
    assert first["window_end_s"] == 33.0
    assert first["detection_floor_worst_idleness_after_s"] == pytest.approx(33.0 - 10.0)


def test_acceleration_ratio():
    assert acceleration_ratio(100.0, 20.0, 4) == pytest.approx(1.25)
    assert acceleration_ratio(100.0, 25.0, 4) == pytest.approx(1.0)
    assert math.isnan(acceleration_ratio(100.0, 0.0, 4))


def _expected_ins(t: float) -> float:
    last = [0.0, 0.0, 0.0]
    for vt, _, v in LOG:
        if vt <= t:
            last[v] = vt
    return t - sum(last) / 3


def test_recorder_matches_hand_log():
    rec = RunRecorder(line_map(), 2, ground_truth=False)
    for t, r, v in LOG:
        rec.record_visit(r, v, t)
    s = rec.summary(25.0)
    assert s["idleness_avg_s"] == 11.0
    assert s["idleness_std_s"] == 1.0
    assert s["idleness_min_s"] == 10.0
    assert s["idleness_max_s"] == 12.0
    assert s["idleness_samples"] == 4
    assert s["worst_idleness_s"] == 12.0
    assert s["complete_cycles"] == 1
    assert s["visits"] == 7 and s["counted_visits"] == 4
    assert s["visits_per_vertex"] == {"10": 3, "11": 2, "12": 2}
    assert s["duration_s"] == 25.0
    # 1 Hz rows at t = 1..25; by hand: I_ins(1) = 1, I_ins(2) = (2 + 2 + 0) / 3.
    times = [row["time_s"] for row in rec.timeseries]
    assert times == [float(k) for k in range(1, 26)]
    ins = [row["idleness_ins_s"] for row in rec.timeseries]
    assert ins[0] == pytest.approx(1.0)
    assert ins[1] == pytest.approx(4.0 / 3.0)
    assert ins[14] == pytest.approx((5 + 0 + 1) / 3)  # t = 15: last = 10, 15, 14
    assert ins == pytest.approx([_expected_ins(t) for t in times])
    assert s["idleness_ins_mean_s"] == pytest.approx(np.mean([_expected_ins(t) for t in times]))
    assert [row["visits"] for row in rec.timeseries][:6] == [1, 2, 2, 2, 3, 3]
    assert s["uncertainty_mean"] is None  # no ground truth
    json.dumps(s)


def test_rows_see_only_visits_up_to_their_time():
    rec = RunRecorder(line_map(), 1)
    far = np.array([[1000.0, 1000.0]])
    rec.record_positions(0.0, far)
    rec.record_visit(0, 1, 2.5)  # visit reported before the positions reach 2.5 s
    rec.record_positions(3.0, far)
    rows = rec.timeseries
    assert [r["time_s"] for r in rows] == [1.0, 2.0, 3.0]
    assert [r["visits"] for r in rows] == [0, 0, 1]
    assert rows[1]["idleness_ins_s"] == pytest.approx(2.0)
    assert rows[2]["idleness_ins_s"] == pytest.approx((3 + 0.5 + 3) / 3)


def test_ground_truth_uncovered_growth_matches_model():
    pm = line_map()
    rec = RunRecorder(pm, 1)
    rec.record_positions(0.0, np.array([[500.0, 500.0]]))
    rec.record_positions(10.0, np.array([[600.0, 500.0]]))
    model = tpuaf_core.UncertaintyModel([1.0, 0.6])
    for row in rec.timeseries:
        assert row["uncertainty_mean"] == pytest.approx(model.evolve(1.0, 0.01, row["time_s"]))
    s = rec.summary(10.0)
    assert s["uncertainty_final_mean"] == pytest.approx(model.evolve(1.0, 0.01, 10.0))


def test_ground_truth_pass_through_reduces_uncertainty():
    pm = line_map()
    rec = RunRecorder(pm, 1)
    # A robot drives along the line at 1 m/s through all three targets.
    for k in range(0, 201):
        rec.record_positions(k * 0.1, np.array([[k * 0.1, 0.0]]))
    x = np.array([row["uncertainty_mean"] for row in rec.timeseries])
    assert x[-1] < 0.5  # the targets passed lost most of their uncertainty
    assert np.all(np.isfinite(x)) and np.all(x >= 0)


def _crossing(rec: RunRecorder, t_start: float, t_end: float, steps: int) -> None:
    """Robot 0 from x=0 to 20, robot 1 from x=20 to 0 over [t_start, t_end]."""
    for k in range(steps + 1):
        t = t_start + (t_end - t_start) * k / steps
        f = k / steps
        rec.record_positions(t, np.array([[20 * f, 0.0], [20 - 20 * f, 0.0]]))


def test_interference_crossing_counted_once_at_exact_time():
    # Gap 20 - 2t <= 2 m from t = 9 s; one interval only: the closed form still finds it.
    rec = RunRecorder(line_map(), 2, ground_truth=False)
    _crossing(rec, 0.0, 20.0, 1)
    assert rec.interferences == [(pytest.approx(9.0), 0, 1)]
    rec2 = RunRecorder(line_map(), 2, ground_truth=False)
    _crossing(rec2, 0.0, 20.0, 40)
    assert rec2.interferences == [(pytest.approx(9.0), 0, 1)]
    s = rec2.summary(60.0)
    assert s["interferences"] == 1
    assert s["interference_rate_per_min"] == pytest.approx(1.0)


def test_interference_pair_staying_close_counts_once():
    rec = RunRecorder(line_map(), 2, ground_truth=False)
    rec.record_positions(0.0, np.array([[0.0, 0.0], [10.0, 0.0]]))
    for k in range(1, 601):  # approach, then stay 1 m apart for a minute
        rec.record_positions(k * 0.1 + 0.0, np.array([[0.0, 0.0], [max(1.0, 10 - k * 0.1), 0.0]]))
    assert len(rec.interferences) == 1
    assert rec.interferences[0][0] == pytest.approx(8.0)


def _approach_leave(rec: RunRecorder, times: list[tuple[float, float]]) -> None:
    """Robots 5 m apart; close (1 m) during each (t_in, t_out), apart otherwise; 0.5 s calls."""
    t = 0.0
    while t <= 60.0:
        close = any(a <= t <= b for a, b in times)
        rec.record_positions(t, np.array([[0.0, 0.0], [1.0 if close else 5.0, 0.0]]))
        t += 0.5


def test_interference_refractory_and_reapproach():
    rec = RunRecorder(line_map(), 2, ground_truth=False)
    # Close from ~5 s to 6 s, again at ~9 s (within 10 s: merged), again at ~30 s (counted).
    _approach_leave(rec, [(5.0, 6.0), (9.0, 10.0), (30.0, 31.0)])
    times = [t for t, _, _ in rec.interferences]
    assert len(times) == 2
    assert times[0] == pytest.approx(4.875)  # linear from 5 m at 4.5 s to 1 m at 5.0 s
    assert times[1] == pytest.approx(29.875)


def test_interference_needs_separation_and_ignores_start_and_dead_robots():
    rec = RunRecorder(line_map(), 3, ground_truth=False)
    # Robots 0 and 1 start 1 m apart (not counted) and stay close 30 s: still not counted.
    for k in range(61):
        rec.record_positions(k * 0.5, np.array([[0.0, 0.0], [1.0, 0.0], [50.0, 0.0]]))
    assert rec.interferences == []
    # Robot 2 dies, then its row is NaN: never counted, even when "close".
    rec.record_robot_death(2, 30.0)
    rec.record_positions(31.0, np.array([[0.0, 0.0], [5.0, 0.0], [0.5, 0.0]]))
    rec.record_positions(32.0, np.array([[0.0, 0.0], [5.0, 0.0], [np.nan, np.nan]]))
    assert rec.interferences == []
    # Now 0 and 1 have separated: a new approach counts (30 s after the start).
    rec.record_positions(33.0, np.array([[0.0, 0.0], [1.0, 0.0], [np.nan, np.nan]]))
    assert [(a, b) for _, a, b in rec.interferences] == [(0, 1)]
    s = rec.summary(40.0)
    assert s["deaths"] == 1 and s["dead_robots"] == [2]


def test_record_positions_rejects_time_going_back_and_bad_shape():
    rec = RunRecorder(line_map(), 2)
    rec.record_positions(1.0, np.zeros((2, 2)))
    with pytest.raises(ValueError):
        rec.record_positions(0.5, np.zeros((2, 2)))
    with pytest.raises(ValueError):
        rec.record_positions(2.0, np.zeros((3, 2)))


def test_summary_on_builtin_map_is_json_serialisable():
    pm = load_map("grid")
    rec = RunRecorder(pm, 4)
    rng = np.random.default_rng(1)
    pos = pm.positions[:4].copy()
    for k in range(1, 301):
        pos = pos + rng.normal(scale=0.2, size=pos.shape)
        rec.record_positions(k * 0.2, pos)
        if k % 25 == 0:
            rec.record_visit(k % 4, k % 25, k * 0.2)
    s = rec.summary(60.0)
    text = json.dumps(s)
    assert "NaN" not in text
    assert s["duration_s"] == 60.0 and len(rec.timeseries) == 60
    assert s["uncertainty_mean"] > 0


def test_out_of_order_visits_give_the_same_summary():
    in_order = RunRecorder(line_map(), 2, ground_truth=False)
    for t, r, v in LOG:
        in_order.record_visit(r, v, t)
    shuffled = RunRecorder(line_map(), 2, ground_truth=False)
    # delayed reports: (10, v0) after (14, v2) and (15, v1); (5, v1) after (10, v0)
    for i in [0, 1, 4, 5, 3, 2, 6]:
        t, r, v = LOG[i]
        shuffled.record_visit(r, v, t)
    a, b = in_order.summary(25.0), shuffled.summary(25.0)
    for key in ("idleness_avg_s", "idleness_std_s", "idleness_min_s", "idleness_max_s",
                "idleness_samples", "worst_idleness_s", "complete_cycles", "counted_visits"):
        assert a[key] == b[key], key
    assert sorted(shuffled.interval_samples) == [10.0, 10.0, 12.0, 12.0]


def test_fleet_monitor_applies_the_visit_rule_to_ground_truth():
    """One definition of a visit: the monitor applies the agents' VisitRule to the ground-truth
    poses against the goals of their GOAL events (START: the first visit); a robot standing on
    its goal vertex makes no visit (its DWELL is counted apart); REACHED reports are not
    needed. With visit_source="reports" (bags without events) the REACHED reports count."""
    from tpuaf.measure.monitor import FleetMonitor
    from tpuaf.topics import DWELL, GOAL, HEARTBEAT, REACHED, START

    pm = line_map()

    def feed(mon):
        mon.on_event(0, REACHED, 2, -1.0)  # before the run: no visit
        mon.on_event(0, START, 0, -0.5)  # before the run start: the first visit, at the start
        mon.on_event(1, START, 2, 0.0)
        for k in range(0, 41):
            t = float(k)
            if k == 2:
                mon.on_event(0, GOAL, 1, t, 0)  # drives to vertex 1 (x = 10 m) by t = 10 s
                mon.on_event(1, GOAL, 2, t, 2)  # robot 1 stands on its vertex 2 all along
            if k == 3:
                mon.on_event(1, DWELL, 2, t)
            if k == 12:
                mon.on_event(0, REACHED, 1, 11.5)  # stamped by the agent
            mon.on_event(0, HEARTBEAT, -1, t)
            mon.on_event(1, HEARTBEAT, -1, t)
            mon.on_pose(0, t, min(t, 10.0), 0.0)
            mon.on_pose(1, t, 20.0 + 0.01 * (k % 2), 0.0)  # wobbles on vertex 2
        return mon.summary()

    mon = FleetMonitor(pm, 2, 30.0, lag_s=1.0)
    s = feed(mon)
    assert [(t, r, v) for t, r, v in mon.recorder.visits] == [(0.0, 0, 0), (0.0, 1, 2),
                                                              (10.0, 0, 1)]
    assert s["visits"] == 3 and s["deaths"] == 0 and mon.live()["visits"] == 3
    assert s["dwells"] == 1 and s["dwell_time_s"] == 1.0 and s["visits_patrolling_sim"] == 4
    mon = FleetMonitor(pm, 2, 30.0, lag_s=1.0, visit_source="reports")
    feed(mon)
    assert [(t, r, v) for t, r, v in mon.recorder.visits][2:] == [(11.5, 0, 1)]


def test_fleet_monitor_dates_a_death_at_the_last_event_and_keeps_intentions():
    from tpuaf.measure.monitor import FleetMonitor
    from tpuaf.topics import GOAL, HEARTBEAT, REACHED, START

    pm = line_map()
    mon = FleetMonitor(pm, 2, 60.0, lag_s=1.0, death_timeout_s=5.0)
    mon.on_event(0, START, 0, 0.0)
    mon.on_event(1, START, 2, 0.0)
    mon.on_announcement(1, 1, 0.0)  # robot 1 heads to vertex 1 ...
    mon.on_event(0, GOAL, 1, 0.0, 0)  # robot 0 takes over vertex 1, there at 30 s
    for k in range(0, 61):
        t = float(k)
        mon.on_event(0, HEARTBEAT, -1, t)
        if t <= 20:
            mon.on_event(1, HEARTBEAT, -1, t)  # ... and falls silent after 20 s
        if k == 30:
            mon.on_event(0, REACHED, 1, t)
        mon.on_pose(0, t, min(t / 3.0, 10.0), 0.0)
        mon.on_pose(1, t, 20.0, 0.0)
    s = mon.summary()
    assert s["dead_robots"] == [1] and 25.0 < mon.deaths[0][0] <= 27.0  # detected after 5 s
    (r,) = s["recovery"]
    assert r["time_s"] == 20.0  # dated at its last heartbeat
    assert r["intentions"] == [11] and r["intentions_honoured"] == 1
    assert r["intention_delays_s"] == [10.0]
