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
