"""Issue 33 item 8: `tpuaf analyze` on a bag alone is right: duplicated messages count once, a
bag without /fleet/start starts at the agents' first report (and says so), and team messages
recorded out of bag-time order make no phantom death."""

from __future__ import annotations

import pytest
from tpuaf.measure.bag import analyze

from .test_bag import GRID, T0, plain_bag

CASES = [("tf", True), ("tf", False), ("none", False), ("odom", True)]


@pytest.mark.parametrize("poses, events", CASES)
def test_every_message_twice_counts_once(tmp_path, poses, events):
    plain_bag(tmp_path, "one.bag", poses=poses, events=events)
    plain_bag(tmp_path, "two.bag", poses=poses, events=events, duplicate=True)
    one = analyze(tmp_path / "one.bag", GRID).summary
    two = analyze(tmp_path / "two.bag", GRID).summary
    assert one["visits"] > 10
    for key in ("visits", "idleness_avg_s", "idleness_max_s", "deaths"):
        assert two[key] == one[key], key
    assert one["rejected"]["total"] == 0 and not one["suspect_traffic"]
    assert two["rejected"]["by_reason"]["duplicate"] >= one["visits"]
    assert two["suspect_traffic"] is True


def test_a_bag_without_a_start_starts_at_the_first_report(tmp_path):
    # recorded a minute before the run: heartbeats and poses of robots standing still
    spec = plain_bag(tmp_path, "start.bag", poses="tf", events=True, lead_s=60.0)
    plain_bag(tmp_path, "bare.bag", poses="tf", events=True, lead_s=60.0, starts=())
    with_start = analyze(tmp_path / "start.bag", GRID)
    bare = analyze(tmp_path / "bare.bag", GRID)
    assert with_start.start_s == pytest.approx(T0, abs=1e-6)
    assert bare.start_s == pytest.approx(T0 + 0.25, abs=1e-6)  # the first START event
    assert bare.summary["visits"] == with_start.summary["visits"] == len(spec.visits)
    assert bare.summary["deaths"] == 0
    (note,) = [n for n in bare.notes if "no run start" in n]
    assert "+60.2 s from the bag's beginning" in note
    assert not [n for n in with_start.notes if "no run start" in n]


@pytest.mark.parametrize("poses", ["tf", "none"])
def test_messages_recorded_out_of_order_make_no_phantom_death(tmp_path, poses):
    plain_bag(tmp_path, "ordered.bag", poses=poses, events=True)
    plain_bag(tmp_path, "late.bag", poses=poses, events=True, record_delay={1: 70.0})
    ordered = analyze(tmp_path / "ordered.bag", GRID).summary
    late = analyze(tmp_path / "late.bag", GRID).summary
    assert late["deaths"] == ordered["deaths"] == 0 and not late.get("outages")
    assert late["visits"] == ordered["visits"]
