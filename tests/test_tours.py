"""Reference tours: cyclic TSP walk and k-partition, checked against patrol_bounds.csv."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest
from tpuaf.maps import tours
from tpuaf.maps.model import PatrolMap

SHARED = Path(__file__).resolve().parents[1].parent / "shared"
BOUNDS = SHARED / "reference" / "patrol_bounds.csv"
PS_MAPS = SHARED / "maps" / "patrolling_sim"


def grid_map(n=5, spacing=5.7) -> PatrolMap:
    pos, edges = [], []
    for r in range(n):
        for c in range(n):
            pos.append((c * spacing, r * spacing))
            i = r * n + c
            if c + 1 < n:
                edges.append((i, i + 1, spacing))
            if r + 1 < n:
                edges.append((i, i + n, spacing))
    k = n * n
    return PatrolMap("grid", list(range(k)), np.array(pos), edges, np.ones(k), np.ones(k))


def bounds(map_name: str) -> dict[int, dict[str, float]]:
    if not BOUNDS.is_file():
        pytest.skip(f"{BOUNDS} not found")
    with BOUNDS.open() as f:
        return {
            int(row["N"]): {k: float(v) for k, v in row.items() if k not in ("map", "N")}
            for row in csv.DictReader(f)
            if row["map"] == map_name
        }


def load(name: str) -> PatrolMap:
    if name == "grid":
        return grid_map()
    try:
        from tpuaf.maps import load_map
    except ImportError:
        pytest.skip("tpuaf.maps.load_map not available")
    if not (PS_MAPS / name).is_dir():
        pytest.skip(f"{PS_MAPS / name} not found")
    return load_map(PS_MAPS / name)


def is_closed_walk(graph, walk) -> bool:
    return all(graph.has_edge(walk[i], walk[(i + 1) % len(walk)]) for i in range(len(walk)))


def test_tsp_order_finds_the_optimum_of_points_on_a_circle():
    a = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    rng = np.random.default_rng(3)
    perm = rng.permutation(12)
    pts = np.c_[np.cos(a), np.sin(a)][perm]
    dist = np.hypot(*(pts[:, None, :] - pts[None, :, :]).transpose(2, 0, 1))
    order = tours.tsp_order(dist)
    assert sorted(order) == list(range(12))
    assert tours._order_length(dist, order) == pytest.approx(12 * 2 * math.sin(math.pi / 12))


@pytest.mark.parametrize("name", ["grid", "cumberland", "example", "DIAG_labs"])
def test_cyclic_tour_length_matches_patrol_bounds(name):
    ref = bounds(name)
    if not ref:
        pytest.skip(f"{name} not in patrol_bounds.csv")
    m = load(name)
    tour = tours.cyclic_tour(m)
    assert set(tour.walk) == set(range(m.num_vertices))
    assert is_closed_walk(m.graph, tour.walk)
    assert tour.length == pytest.approx(tours.walk_length(m.graph, tour.walk))
    tsp = ref[1]["tsp_length_m"]
    assert tour.length <= tsp * 1.03, f"{name}: {tour.length:.2f} m vs {tsp} m"
    assert tour.length >= tsp * 0.99  # not shorter than the best known: a sanity check
    for n, row in ref.items():
        idl = tours.walk_idleness(m.graph, tour.walk, n, 1.0)
        assert idl["worst"] == pytest.approx(tour.length / n, rel=1e-6)
        assert idl["worst"] <= row["cyclic_worst_idleness_s"] * 1.03
        # the averages depend on which vertices the walk repeats: close to the table
        assert idl["avg_visit"] == pytest.approx(row["cyclic_avg_idleness_visit_s"], rel=0.05)
        assert idl["avg_time"] == pytest.approx(row["cyclic_avg_idleness_time_s"], rel=0.05)


def test_walk_idleness_by_hand():
    # triangle walk 0-1-2 (3 m) with a repeated vertex: 0-1-0-2 on a path 1-0-2 (1 m edges)
    m = PatrolMap(
        "p",
        [0, 1, 2],
        np.array([(0, 0), (1, 0), (-1, 0)], float),
        [(0, 1, 1.0), (0, 2, 1.0)],
        np.ones(3),
        np.ones(3),
    )
    idl = tours.walk_idleness(m.graph, [0, 1, 0, 2], 1, 1.0)  # length 4 m, 1 m/s
    # vertex 0 visited at 0 and 2 (gaps 2, 2); 1 and 2 once per 4 s
    assert idl["worst"] == pytest.approx(4.0)
    assert idl["avg_visit"] == pytest.approx((2 + 4 + 4) / 3)
    assert idl["avg_time"] == pytest.approx((1 + 2 + 2) / 3)  # gaps^2 / (2 period)
    two = tours.walk_idleness(m.graph, [0, 1, 0, 2], 2, 0.5)  # period 4 m / 2 / 0.5 m/s = 4 s
    assert two["worst"] == pytest.approx(4.0)
    assert two["avg_visit"] == pytest.approx((4 + 4 + 4) / 3)  # 0's two visits coincide

    import tpuaf_core  # the plan search's C++ worst idleness: the same numbers

    assert tpuaf_core.walk_worst_idleness(m.graph, [0, 1, 0, 2], 1, 1.0) == idl["worst"]
    assert tpuaf_core.walk_worst_idleness(m.graph, [0, 1, 0, 2], 2, 0.5) == two["worst"]
    assert tpuaf_core.walk_worst_idleness(m.graph, [0], 3, 1.0) == 0.0


@pytest.mark.parametrize("name", ["grid", "DIAG_labs", "cumberland"])
def test_cpp_walk_worst_idleness_equals_walk_idleness(name):
    """tpuaf_core.walk_worst_idleness (TPUAF+'s plan choice) equals walk_idleness's worst to
    the last digit, on the cyclic tour and the parts' walks, for 1 to 12 robots."""
    import tpuaf_core

    pm = load(name)
    speed = float(pm.settings.nominal_speed)
    walks = [tours.cyclic_tour(pm).walk] + [t.walk for t in tours.partition_tours(pm, 3).tours]
    for walk in walks:
        for n in (1, 2, 3, 5, 8, 12):
            expected = tours.walk_idleness(pm.graph, list(walk), n, speed)["worst"]
            assert tpuaf_core.walk_worst_idleness(pm.graph, list(walk), n, speed) == expected

@pytest.mark.parametrize("n_robots", [2, 3, 4])
def test_partition_parts_are_connected_disjoint_and_toured(n_robots):
    m = grid_map()
    part = tours.partition_tours(m, n_robots)
    assert len(part.parts) == n_robots
    flat = sorted(v for p in part.parts for v in p)
    assert flat == list(range(m.num_vertices))
    adj = tours._adjacency(m.graph)
    for p, t in zip(part.parts, part.tours, strict=True):
        assert tours._connected(adj, set(p))
        assert set(t.walk) == set(p)  # the tour stays inside its part
        if len(t.walk) > 1:
            assert is_closed_walk(m.graph, t.walk)
    assert sum(part.robots_per_part) == n_robots


def test_partition_with_more_robots_than_vertices():
    m = grid_map(2, 1.0)  # 4 vertices
    part = tours.partition_tours(m, 6)
    assert len(part.parts) == 4 and sum(part.robots_per_part) == 6
    assign = tours.assign_parts(part, [0, 1, 2, 3, 0, 1], m.graph.distances)
    assert sorted(np.bincount(assign, minlength=4).tolist()) == sorted(part.robots_per_part)


def test_reference_tours_reports_both_and_the_better():
    m = grid_map()
    ref = tours.reference_tours(m, 4, 1.0)
    assert ref["cyclic"]["length_m"] == pytest.approx(148.2, rel=0.01)
    assert ref["cyclic"]["worst_idleness_s"] == pytest.approx(148.2 / 4, rel=0.01)
    part = ref["partition"]
    assert part["worst_idleness_s"] == pytest.approx(max(part["lengths_m"]))
    assert ref["better"] == "cyclic"  # 37 s beats any 4-part split of the 5x5 grid
    assert ref["best_worst_idleness_s"] == min(
        ref["cyclic"]["worst_idleness_s"], part["worst_idleness_s"]
    )
    slow = tours.reference_tours(m, 4, 0.5)
    assert slow["cyclic"]["worst_idleness_s"] == pytest.approx(
        2 * ref["cyclic"]["worst_idleness_s"]
    )
    with pytest.raises(ValueError, match="speed"):
        tours.reference_tours(m, 4, 0.0)


def test_closed_walk_refuses_a_disconnected_vertex_set():
    m = grid_map(3, 1.0)  # 0 1 2 / 3 4 5 / 6 7 8: the corners 0 and 2 are not adjacent
    with pytest.raises(ValueError, match="not connected"):
        tours.closed_walk(m.graph, [0, 2])
    walk, length = tours.closed_walk(m.graph, [0, 1, 2])
    assert length == pytest.approx(4.0) and set(walk) == {0, 1, 2}


def test_plans_are_identical_on_a_fresh_map_object():
    a, b = grid_map(7, 1.0), grid_map(7, 1.0)  # two objects: no shared in-memory cache
    assert tours.cyclic_tour(a).walk == tours.cyclic_tour(b).walk
    pa, pb = tours.partition_tours(a, 5), tours.partition_tours(b, 5)
    assert pa.parts == pb.parts and [t.walk for t in pa.tours] == [t.walk for t in pb.tours]


def test_disk_cache_is_keyed_by_the_map_content(tmp_path, monkeypatch):
    monkeypatch.setenv(tours.CACHE_ENV, str(tmp_path))
    m = grid_map(6, 1.0)
    first = tours.partition_tours(m, 3)
    files = sorted(tmp_path.glob("plan-*.json"))
    assert len(files) == 1
    again = tours.partition_tours(grid_map(6, 1.0), 3)  # read back from disk
    assert again.parts == first.parts and again.robots_per_part == first.robots_per_part
    tours.partition_tours(grid_map(6, 1.5), 3)  # other edge lengths: another key
    assert len(list(tmp_path.glob("plan-*.json"))) == 2
    files[0].write_text("{not json")  # a damaged file is searched again, not trusted
    assert tours.partition_tours(grid_map(6, 1.0), 3).parts == first.parts


def test_first_coverage_bound_by_hand():
    # path 0-1-2-3 of 10 m edges at 1 m/s
    pos = np.array([(0, 0), (10, 0), (20, 0), (30, 0)], float)
    m = PatrolMap("p", [0, 1, 2, 3], pos, [(0, 1, 10.0), (1, 2, 10.0), (2, 3, 10.0)],
                  np.ones(4), np.ones(4))
    assert tours.first_coverage_bound(m, [0], 1.0) == pytest.approx(30.0)
    # from both ends: the forest 0-1-2 (+3) is 20 m for 2 robots; farthest vertex 10 m
    assert tours.first_coverage_bound(m, [0, 3], 1.0) == pytest.approx(10.0)
    assert tours.first_coverage_bound(m, [1, 1], 2.0) == pytest.approx(10.0)  # 20 m at 2 m/s
