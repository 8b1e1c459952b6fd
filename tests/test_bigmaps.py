"""Big maps (issue 34 item 6): shortest paths on demand give exactly what the all-pairs
matrix gives; a few-thousand-vertex map loads, is summarised and runs without any n x n matrix
(benchmarks/bench_bigmaps.py measures time and memory up to 20,000 vertices)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
import tpuaf_core as core
from hypothesis import given, settings
from hypothesis import strategies as st
from tpuaf.maps import load_map, map_summary, start_vertices
from tpuaf.maps.analysis import fiedler_value

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_bigmaps.py"


def _bench():
    spec = importlib.util.spec_from_file_location("bench_bigmaps", BENCH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@st.composite
def graphs(draw):
    """A connected graph on a small lattice with lengths from a few values: many equal-length
    paths, so the searches' tie-breaking is exercised."""
    side = draw(st.integers(2, 7))
    n = side * side
    pos = np.array([(c, r) for r in range(side) for c in range(side)], dtype=float)
    lattice = [(r * side + c, r * side + c + 1) for r in range(side) for c in range(side - 1)]
    lattice += [(r * side + c, (r + 1) * side + c) for r in range(side - 1) for c in range(side)]
    tree = [(v - 1, v) if v % side else (v - side, v) for v in range(1, n)]  # spans every vertex
    extra = draw(st.lists(st.sampled_from(lattice), max_size=len(lattice), unique=True))
    edges = sorted(set(tree) | set(extra))
    lengths = draw(st.lists(st.sampled_from([1.0, 1.5, 2.0, 0.1 + 0.2]), min_size=len(edges),
                            max_size=len(edges)))
    return pos, [(u, v, w) for (u, v), w in zip(edges, lengths, strict=True)]


@settings(max_examples=60, deadline=None)
@given(graphs())
def test_on_demand_paths_equal_the_all_pairs_ones(graph):
    pos, edges = graph
    dense = core.PatrolGraph(pos, edges)
    matrix = np.asarray(dense.distances)  # the all-pairs matrix, every row searched in full
    hops = np.asarray(dense.hop_matrix)
    n = len(pos)
    for s in range(n):
        dense.distances_from(s)  # every row cached: paths follow whole rows
    fresh = core.PatrolGraph(pos, edges)  # searches stopped at the goal
    assert fresh.cached_rows == 1 and not fresh.has_dense_matrices
    for u in range(n):
        assert np.array_equal(core.PatrolGraph(pos, edges).distances_from(u), matrix[u])
        for v in range(n):
            assert fresh.distance(u, v) == matrix[u, v]  # exactly, not approximately
            assert fresh.path(u, v) == dense.path(u, v)
            assert fresh.hops(u, v) == hops[u, v]
    assert fresh.cached_rows == 1 and not fresh.has_dense_matrices


def test_row_cache_is_bounded_and_rows_stay_exact():
    side = 50  # 2,500 vertices: more than the rows kept (64 MB / (12 B x 2,500) = 2,236)
    pos = np.array([(c, r) for r in range(side) for c in range(side)], dtype=float)
    edges = [(r * side + c, r * side + c + 1) for r in range(side) for c in range(side - 1)]
    edges += [(r * side + c, (r + 1) * side + c) for r in range(side - 1) for c in range(side)]
    g = core.PatrolGraph(pos, edges)
    first = g.distances_from(7)
    for s in range(side * side):
        g.distances_from(s)
    assert g.cached_rows == (64 << 20) // (side * side * 12) < side * side
    assert np.array_equal(g.distances_from(7), first)  # evicted, searched again: the same
    assert g.distance(0, side * side - 1) == 2 * (side - 1)
    assert not g.has_dense_matrices


def test_sparse_fiedler_value_equals_the_dense_one(shared_maps):
    for pm in (load_map("grid"), load_map(shared_maps / "cumberland")):
        assert fiedler_value(pm, dense_max=1) == pytest.approx(fiedler_value(pm), abs=1e-10)


def test_a_big_map_loads_and_runs_without_an_all_pairs_matrix(tmp_path):
    from tpuaf.cli.maps import edge_check
    from tpuaf.runtimes.config import RunConfig
    from tpuaf.runtimes.graph import GraphRun

    folder = _bench().write_building(tmp_path / "big", 3000)
    pm = load_map(folder)
    assert pm.num_vertices == 3025
    starts = start_vertices(pm, 30)
    assert len(set(starts)) == 30
    summary = map_summary(pm)
    assert 0 < summary["fiedler_value"] < 0.01  # the sparse solver (3,025 > 1,000 vertices)
    check = edge_check(pm)  # the grid has > 4e6 cells: planned window by window
    assert pm.occupancy_grid().occupied.size > 4_000_000
    assert check["edges"] == pm.graph.num_edges and not check["blocked"]
    run = GraphRun(RunConfig(map=str(folder), strategy="tpuaf", robots=30, duration_s=120.0), pm)
    result = run.run()
    assert result["visits"] > 30
    g = pm.graph
    assert not g.has_dense_matrices  # no n x n matrix anywhere on this path
    assert g.cached_rows <= 30 + 1  # a row per start vertex at most


def _building(tmp_path, n):
    return load_map(_bench().write_building(tmp_path / f"b{n}", n))


def test_distances_from_a_set_are_the_least_row_entries(tmp_path):
    g = _building(tmp_path, 400).graph
    sources = [3, 150, 151, 399]
    want = np.min([g.distances_from(s) for s in sources], axis=0)
    assert np.allclose(g.distances_from_set(sources), want, rtol=0, atol=1e-9)
    assert np.array_equal(g.distances_from_set([7]), g.distances_from(7))


def test_sparse_tour_is_a_closed_walk_through_every_vertex_and_near_the_dense_one(tmp_path):
    g = _building(tmp_path, 1100).graph  # 1,089 vertices: > DENSE_TOUR_MAX, sparse by default
    n = g.num_vertices
    assert n > core.DENSE_TOUR_MAX
    walk, length = core.closed_walk(g, list(range(n)), 1, n // 2, 12345)  # tours._effort's
    assert set(walk) == set(range(n))
    assert all(g.has_edge(walk[i], walk[(i + 1) % len(walk)]) for i in range(len(walk)))
    assert length == pytest.approx(sum(g.edge_length(walk[i], walk[(i + 1) % len(walk)])
                                       for i in range(len(walk))), rel=1e-12)
    assert not g.has_dense_matrices
    _, dense = core.closed_walk(g, list(range(n)), 12, 10 * n, 12345, "dense")
    assert dense <= length < 1.05 * dense  # measured: +2 % (docs/MAPS.md "Big maps")
    again, _ = core.closed_walk(g, list(range(n)), 1, n // 2, 12345)
    assert again == walk  # deterministic: every robot plans the same


def test_sparse_and_dense_metrics_search_alike_on_a_small_set():
    pos = np.array([(c, r) for r in range(6) for c in range(6)], dtype=float)
    edges = [(r * 6 + c, r * 6 + c + 1) for r in range(6) for c in range(5)]
    edges += [(r * 6 + c, (r + 1) * 6 + c) for r in range(5) for c in range(6)]
    g = core.PatrolGraph(pos, [(u, v, 1.0 + 0.1 * ((u * 7 + v) % 3)) for u, v in edges])
    part = [v for v in range(36) if v % 6 < 4]  # a connected 6 x 4 block
    dense = core.closed_walk(g, part, 12, 240, 12345, "dense")
    sparse = core.closed_walk(g, part, 12, 240, 12345, "sparse")
    assert sparse[1] == pytest.approx(dense[1], rel=0.02)
    assert set(sparse[0]) == set(part)
    with pytest.raises(ValueError, match="do not induce a connected subgraph"):
        core.closed_walk(g, [0, 2, 4, 13], 1, 0, 12345, "sparse")
    with pytest.raises(ValueError, match="metric"):
        core.closed_walk(g, part, 1, 0, 12345, "other")


def test_a_big_map_plans_tpuaf_plus_without_an_all_pairs_matrix(tmp_path):
    from tpuaf.policies import tpuaf_plus
    from tpuaf.runtimes.config import RunConfig
    from tpuaf.runtimes.graph import GraphRun

    folder = _bench().write_building(tmp_path / "plus", 3000)
    pm = load_map(folder)
    g = pm.graph
    plan = tpuaf_plus.make_plan(pm, tuple(range(30)), tuple(start_vertices(pm, 30)), "auto")
    assert {v for r in plan.routes for v in r.walk} == set(range(g.num_vertices))
    assert not g.has_dense_matrices  # the cycle, the partition, the schedule: rows only
    survivors = tpuaf_plus.make_plan(pm, tuple(range(1, 30)), tuple(start_vertices(pm, 30)),
                                     "partition", "replan")  # parts from set searches
    assert set(survivors.route_of) == set(range(1, 30))
    run = GraphRun(RunConfig(map=str(folder), strategy="tpuaf_plus", robots=30,
                             duration_s=120.0), pm)
    assert run.run()["visits"] > 30
    assert not g.has_dense_matrices


@pytest.mark.parametrize("k", [5, 20])
def test_a_big_building_splits_into_parts_of_about_equal_walks(tmp_path, k):
    """Above DENSE_TOUR_MAX vertices the parts grow together to equal tree lengths; nearest-seed
    parts left the longest walk 1.26x the mean here at k = 5 (2.29x at 10,000 vertices), and
    the vertex moves cannot even them out."""
    from tpuaf.maps import tours

    pm = _building(tmp_path, 2000)  # 2,025 vertices
    g = pm.graph
    assert g.num_vertices > core.DENSE_TOUR_MAX
    part = tours.partition_tours(pm, k)
    assert sorted(v for p in part.parts for v in p) == list(range(g.num_vertices))
    adj = tours._adjacency(g)
    assert all(tours._connected(adj, set(p)) for p in part.parts)
    lengths = [t.length for t in part.tours]
    assert all(set(t.walk) == set(p) for t, p in zip(part.tours, part.parts, strict=True))
    assert max(lengths) <= 1.3 * float(np.mean(lengths))  # measured: 1.02 (k = 5), 1.26 (20)
    assert not g.has_dense_matrices



def test_a_graph_file_as_written_reads_line_by_line_as_yaml_reads_it(tmp_path):
    from tpuaf.errors import MapError
    from tpuaf.maps import mapfile
    from tpuaf_core import yamlfile

    folder = _bench().write_building(tmp_path / "plain", 400)
    path = folder / "graph.yaml"
    text = path.read_text()
    text = text.replace("  - {id: 3, x:", "  - {id: 3, importance: 2, initial_uncertainty: 0.5, x:")
    first_edge = text.split("edges:\n")[1].split("\n")[0]  # "  - [u, v]"
    edge = f"{first_edge[:-1]}, 2.5]\n"
    text = text.replace(f"{first_edge}\n", edge)
    path.write_text(text)
    plain = mapfile._plain_graph(path)
    assert plain is not None
    full = yamlfile.read_yaml_fast(path, MapError)
    assert plain == full
    kinds = [[type(x) for x in v.values()] for v in plain["vertices"]]
    assert kinds == [[type(x) for x in v.values()] for v in full["vertices"]]
    assert [[type(x) for x in e] for e in plain["edges"]] == \
        [[type(x) for x in e] for e in full["edges"]]
    assert load_map(folder).importance[3] == 2.0
    for other in (f"{edge[:-1]}  # m\n", "  - [01, 2]\n", "  - [1, 2, 5e-2]\n"):
        path.write_text(text.replace(edge, other))  # YAML decides these
        assert mapfile._plain_graph(path) is None
    path.write_text(text.replace("  - {id: 3,", "  - {id: 3, id: 4,"))  # a repeated key
    assert mapfile._plain_graph(path) is None
