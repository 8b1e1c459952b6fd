"""The C++ core against closed forms, properties and networkx (issue: foundation)."""

from __future__ import annotations

import math

import networkx as nx
import numpy as np
import pytest
import tpuaf_core as core
from hypothesis import given, settings
from hypothesis import strategies as st

ONE = np.array([1.0])
R5 = np.array([5.0])


# --- perception (Eq. 1) ---------------------------------------------------------------------
@pytest.mark.parametrize("peak", [1.0, 0.3, 2.5])
def test_perception_closed_forms(peak):
    r = 5.0
    assert core.perception(0.0, peak, r) == pytest.approx(peak)
    assert core.perception(r, peak, r) == 0.0
    assert core.perception(r / 2, peak, r) == pytest.approx(0.5625 * peak)
    assert core.perception(r * 1.0001, peak, r) == 0.0


def test_perception_matrix_matches_scalar_model():
    rng = np.random.default_rng(3)
    targets = rng.uniform(-10, 10, (30, 2))
    robots = rng.uniform(-10, 10, (7, 2))
    peaks = rng.uniform(0.5, 2, 7)
    radii = rng.uniform(1, 8, 7)
    m = core.perception_matrix(targets, robots, peaks, radii)
    assert m.shape == (30, 7)
    for j in range(30):
        for i in range(7):
            s = float(np.linalg.norm(targets[j] - robots[i]))
            assert m[j, i] == pytest.approx(core.perception(s, peaks[i], radii[i]), abs=1e-12)
    np.testing.assert_allclose(core.total_perception(targets, robots, peaks, radii), m.sum(1))


def test_perception_rejects_bad_sensors():
    t = np.zeros((1, 2))
    with pytest.raises(ValueError, match="sensing radius"):
        core.perception_matrix(t, np.zeros((1, 2)), ONE, np.array([0.0]))
    with pytest.raises(ValueError, match="one peak and one radius per robot"):
        core.total_perception(t, np.zeros((2, 2)), ONE, R5)


# --- uncertainty field (Eq. 2-3) -------------------------------------------------------------
def field(x0, c=0.01, coefficients=(1.0, 0.6), position=(0.0, 0.0)):
    model = core.UncertaintyModel(list(coefficients))
    return core.UncertaintyField(np.array([position]), np.array([c]), np.array([x0]), model)


@pytest.mark.parametrize("a0,a1", [(1.0, 0.6), (0.5, 0.0), (0.0, 0.2), (2.0, 1.5)])
def test_uncovered_target_follows_analytic_solution(a0, a1):
    c, x0 = 0.01, 0.7
    f = field(x0, c, (a0, a1))
    for step in range(1, 6):
        f.advance_uncovered(20.0)
        t = 20.0 * step
        if a1 > 0:
            expected = (x0 + a0 / a1) * math.exp(a1 * c * t) - a0 / a1
        else:
            expected = x0 + a0 * c * t
        assert f.values[0] == pytest.approx(expected, rel=1e-12)


def test_decay_under_a_stationary_robot_then_stays_at_zero():
    c, x0, a0, a1 = 0.01, 5.0, 1.0, 0.6
    f = field(x0, c, (a0, a1))
    robot = np.array([[0.0, 0.0]])  # on the target: M = G = 1
    f.advance(0.5, robot, ONE, R5)
    k = c - 1.0
    expected = (x0 + a0 / a1) * math.exp(a1 * k * 0.5) - a0 / a1
    assert f.values[0] == pytest.approx(expected, rel=1e-12)
    f.advance(100.0, robot, ONE, R5)
    assert f.values[0] == 0.0
    f.advance_uncovered(0.0)
    assert f.values[0] == 0.0


def test_nonlinear_growth_matches_closed_form():
    # g(X) = X^2: dX/dt = C X^2 -> X = X0 / (1 - C X0 t)
    c, x0 = 0.01, 2.0
    f = field(x0, c, (0.0, 0.0, 1.0))
    assert not f.model.is_affine
    f.advance_uncovered(10.0)
    assert f.values[0] == pytest.approx(x0 / (1 - c * x0 * 10.0), rel=1e-9)


def test_values_are_capped_not_infinite():
    f = field(1.0, 1.0, (1.0, 5.0))
    f.advance_uncovered(1e6)
    assert math.isfinite(f.values[0]) and f.values[0] == f.model.max_value


def test_predict_does_not_change_state():
    f = field(1.0)
    before = f.values.copy()
    assert f.predict(30.0)[0] == pytest.approx(f.model.evolve(1.0, 0.01, 30.0))
    assert f.predict_one(0, 30.0) == pytest.approx(f.predict(30.0)[0])
    np.testing.assert_array_equal(f.values, before)
    with pytest.raises(IndexError, match="unknown target 3"):
        f.predict_one(3, 1.0)
    with pytest.raises(ValueError, match="horizon"):
        f.predict(-1.0)


def test_default_model_meets_spec_a_and_b():
    """SPEC 3(a): visible monotonic growth over one patrol period; 3(b): one pass at nominal
    speed (1 m/s) straight through the target removes at least 90 % of X."""
    model = core.UncertaintyModel()
    c = 0.01
    period_s = 148.2  # one robot touring grid
    grown = [model.evolve(1.0, c, t) for t in np.linspace(0, period_s, 50)]
    assert all(b > a for a, b in zip(grown, grown[1:], strict=False))
    assert grown[-1] > 2.0 * grown[0]
    for x0 in (0.5, 1.0, 10.0, 1e3, 1e6):
        f = core.UncertaintyField(np.zeros((1, 2)), np.array([c]), np.array([x0]), model)
        f.advance_linear(10.0, np.array([[-5.0, 0.0]]), np.array([[5.0, 0.0]]), ONE, R5, 0.05)
        assert f.values[0] <= 0.1 * x0


def test_advance_linear_matches_fine_stationary_steps():
    rng = np.random.default_rng(0)
    targets = rng.uniform(0, 10, (20, 2))
    start, end = rng.uniform(0, 10, (3, 2)), rng.uniform(0, 10, (3, 2))
    peaks, radii = np.ones(3), np.full(3, 4.0)
    a = core.UncertaintyField(targets, np.full(20, 0.01), np.full(20, 2.0))
    b = core.UncertaintyField(targets, np.full(20, 0.01), np.full(20, 2.0))
    a.advance_linear(8.0, start, end, peaks, radii, 0.25)
    n = 4000
    for k in range(n):
        b.advance(8.0 / n, start + (k + 0.5) / n * (end - start), peaks, radii)
    np.testing.assert_allclose(a.values, b.values, rtol=1e-3, atol=5e-4)


@settings(max_examples=200, deadline=None)
@given(
    x0=st.floats(0, 1e4),
    c=st.floats(0, 2),
    coefficients=st.lists(st.floats(0, 3), min_size=1, max_size=4),
    steps=st.lists(st.tuples(st.floats(0, 50), st.floats(-20, 20), st.floats(-20, 20)), max_size=8),
)
def test_property_never_negative_or_nan(x0, c, coefficients, steps):
    f = core.UncertaintyField(
        np.zeros((1, 2)), np.array([c]), np.array([x0]), core.UncertaintyModel(coefficients)
    )
    for dt, x, y in steps:
        f.advance(dt, np.array([[x, y]]), ONE, R5)
        v = f.values[0]
        assert v >= 0 and math.isfinite(v)


@settings(max_examples=200, deadline=None)
@given(
    x0=st.floats(0, 100),
    c=st.floats(1e-4, 1),
    coefficients=st.lists(st.floats(0, 2), min_size=1, max_size=3).filter(lambda a: a[0] > 0),
    dts=st.lists(st.floats(0.01, 20), min_size=1, max_size=10),
)
def test_property_monotonic_growth_without_coverage(x0, c, coefficients, dts):
    f = core.UncertaintyField(
        np.zeros((1, 2)), np.array([c]), np.array([x0]), core.UncertaintyModel(coefficients)
    )
    previous = x0
    for dt in dts:
        f.advance_uncovered(dt)
        assert f.values[0] >= previous
        previous = f.values[0]


def test_field_rejects_bad_inputs():
    with pytest.raises(ValueError, match="a_1 must be finite and >= 0"):
        core.UncertaintyModel([1.0, -0.5])
    with pytest.raises(ValueError, match="target 0: importance C"):
        core.UncertaintyField(np.zeros((1, 2)), np.array([-1.0]), np.array([0.0]))
    with pytest.raises(ValueError, match="initial X0"):
        core.UncertaintyField(np.zeros((1, 2)), np.array([0.0]), np.array([np.nan]))
    f = field(1.0)
    with pytest.raises(ValueError, match="finite and >= 0"):
        f.values = np.array([-1.0])


# --- patrol graph ----------------------------------------------------------------------------
def random_connected_graph(rng, n):
    positions = rng.uniform(0, 50, (n, 2))
    edges = {(int(rng.integers(0, i)), i) for i in range(1, n)}  # a random spanning tree
    for _ in range(n):
        u, v = rng.integers(0, n, 2)
        if u != v:
            edges.add((int(min(u, v)), int(max(u, v))))
    lengths = {e: float(rng.uniform(0.5, 20)) for e in edges}
    return positions, [(u, v, lengths[(u, v)]) for u, v in sorted(edges)]


@pytest.mark.parametrize("seed", range(8))
def test_shortest_paths_match_networkx(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 40))
    positions, edges = random_connected_graph(rng, n)
    g = core.PatrolGraph(positions, edges)
    ref = nx.Graph()
    ref.add_weighted_edges_from(edges)
    lengths = dict(nx.all_pairs_dijkstra_path_length(ref))
    hop_counts = dict(nx.all_pairs_shortest_path_length(ref))
    for u in range(n):
        for v in range(n):
            assert g.distance(u, v) == pytest.approx(lengths[u][v])
            assert g.hops(u, v) == hop_counts[u][v]
            path = g.path(u, v)
            assert path[0] == u and path[-1] == v
            walked = sum(g.edge_length(a, b) for a, b in zip(path, path[1:], strict=False))
            assert walked == pytest.approx(lengths[u][v])
    assert g.mean_edge_length == pytest.approx(np.mean([e[2] for e in edges]))
    assert g.total_edge_length == pytest.approx(sum(e[2] for e in edges))


def test_edge_length_defaults_to_euclidean_and_parallel_edges_keep_shortest():
    positions = np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 0.0]])
    g = core.PatrolGraph(positions, [(0, 1), (1, 2, 9.0), (2, 1, 4.5), (0, 2, None)])
    assert g.edge_length(0, 1) == pytest.approx(5.0)
    assert g.edge_length(1, 2) == pytest.approx(4.5)
    assert g.edge_length(0, 2) == pytest.approx(3.0)
    assert g.num_edges == 3
    assert sorted(g.neighbours(1)) == [0, 2]


def test_graph_errors_name_the_culprit():
    p = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    ids = [10, 20, 30]
    with pytest.raises(
        ValueError, match="disconnected: vertex 30 cannot be reached from vertex 10"
    ):
        core.PatrolGraph(p, [(0, 1)], ids)
    with pytest.raises(IndexError, match=r"edge \(0, 5\) names an unknown vertex"):
        core.PatrolGraph(p, [(0, 1), (0, 5)], ids)
    with pytest.raises(ValueError, match="self-loop at vertex 20"):
        core.PatrolGraph(p, [(0, 1), (1, 1), (1, 2)], ids)
    with pytest.raises(ValueError, match="edge 10-20 has non-positive length"):
        core.PatrolGraph(p, [(0, 1, 0.0), (1, 2)], ids)
    with pytest.raises(ValueError, match="edge 20-30 has non-positive length"):
        core.PatrolGraph(p, [(0, 1), (1, 2, -3.0)], ids)
    g = core.PatrolGraph(p, [(0, 1), (1, 2)], ids)
    with pytest.raises(IndexError, match="unknown vertex index 3"):
        g.path(0, 3)
    with pytest.raises(ValueError, match="no edge between vertex 10 and vertex 30"):
        g.edge_length(0, 2)
    with pytest.raises(ValueError, match="no vertices"):
        core.PatrolGraph(np.zeros((0, 2)), [])


# --- TPUAF utility (Eq. 6-14) ----------------------------------------------------------------
def line_graph():
    # 0 -- 1 -- 2 with lengths 2 and 6 m: mean edge 4 m
    return core.PatrolGraph(np.array([[0.0, 0.0], [2.0, 0.0], [8.0, 0.0]]), [(0, 1), (1, 2)])


def test_utility_eq13_by_hand():
    g = line_graph()
    model = core.UncertaintyModel()
    c = np.full(3, 0.01)
    inf = np.full(3, np.inf)
    r = core.tpuaf_utilities(
        g,
        c,
        model,
        now_s=100.0,
        current_vertex=1,
        candidates=[0, 2],
        speed_mps=2.0,
        last_visit_s=np.array([40.0, 100.0, 90.0]),
        estimate=np.array([3.0, 0.0, 1.0]),
        announced_arrival_s=inf,
        announced_travel_s=np.zeros(3),
    )
    # d = max(c, 4): 4 and 6 m; dt = 2 and 3 s; t_end = 102, 103; I = 62, 13.
    np.testing.assert_allclose(r.travel_time_s, [2.0, 3.0])
    np.testing.assert_allclose(r.arrival_s, [102.0, 103.0])
    np.testing.assert_allclose(r.idleness_s, [62.0, 13.0])
    x_hat = [model.evolve(3.0, 0.01, 2.0), model.evolve(1.0, 0.01, 3.0)]
    np.testing.assert_allclose(r.predicted, x_hat)
    np.testing.assert_allclose(r.utility, [x_hat[0] * 62 / 2, x_hat[1] * 13 / 3])


def test_utility_announced_visit_counts_as_last_visit():
    g = line_graph()
    model = core.UncertaintyModel()
    announced = np.array([101.0, np.inf, np.inf])  # another robot reaches vertex 0 at t = 101
    r = core.tpuaf_utilities(
        g,
        np.full(3, 0.01),
        model,
        100.0,
        1,
        [0],
        2.0,
        np.array([40.0, 100.0, 90.0]),
        np.array([3.0, 0.0, 1.0]),
        announced,
        np.array([1.0, 0.0, 0.0]),
    )
    assert r.idleness_s[0] == pytest.approx(1.0)  # |102 - 101|
    assert r.predicted[0] == pytest.approx(model.evolve(0.0, 0.01, 1.0))


def test_utility_eq14_by_hand():
    g = line_graph()
    model = core.UncertaintyModel()
    announced = np.array([np.inf, np.inf, 150.0])  # announced later than our arrival
    r = core.tpuaf_utilities(
        g,
        np.full(3, 0.01),
        model,
        100.0,
        1,
        [2],
        2.0,
        np.array([40.0, 100.0, 90.0]),
        np.array([3.0, 0.5, 1.0]),
        announced,
        np.array([0.0, 0.0, 7.0]),
        form=core.UtilityForm.EQ14,
    )
    x_j = model.evolve(1.0, 0.01, 3.0)
    x_i = model.evolve(0.5, 0.01, 3.0)
    assert r.utility[0] == pytest.approx(abs(x_j + (13.0 / 3.0 - 7.0 / 3.0) * x_i))


def test_utility_any_vertex_variant_uses_path_length():
    g = line_graph()
    r = core.tpuaf_utilities(
        g,
        np.full(3, 0.01),
        core.UncertaintyModel(),
        0.0,
        0,
        [2],
        1.0,
        np.zeros(3),
        np.ones(3),
        np.full(3, np.inf),
        np.zeros(3),
        use_path_length=True,
    )
    assert r.travel_time_s[0] == pytest.approx(8.0)


def test_utility_errors():
    g = line_graph()
    args = dict(
        graph=g,
        importance=np.full(3, 0.01),
        model=core.UncertaintyModel(),
        now_s=0.0,
        current_vertex=0,
        candidates=[1],
        speed_mps=1.0,
        last_visit_s=np.zeros(3),
        estimate=np.ones(3),
        announced_arrival_s=np.full(3, np.inf),
        announced_travel_s=np.zeros(3),
    )
    with pytest.raises(ValueError, match="speed must be > 0"):
        core.tpuaf_utilities(**{**args, "speed_mps": 0.0})
    with pytest.raises(ValueError, match="no edge between vertex 0 and vertex 2"):
        core.tpuaf_utilities(**{**args, "candidates": [2]})
    with pytest.raises(ValueError, match="estimate needs one value per vertex"):
        core.tpuaf_utilities(**{**args, "estimate": np.ones(2)})
    with pytest.raises(IndexError, match="unknown vertex index 9"):
        core.tpuaf_utilities(**{**args, "current_vertex": 9})


# --- the one shortest-path search (tpuaf_core.dijkstra) -------------------------------------------


def test_dijkstra_is_the_graph_s_own_search():
    pos = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    g = core.PatrolGraph(pos, [(0, 1, 1.0), (1, 2, 1.0), (2, 3, 1.0), (3, 0, 1.0), (0, 2, 5.0)])
    tails, heads, weights = [], [], []
    for u, v, length in g.edges:
        tails += [u, v]
        heads += [v, u]
        weights += [length, length]
    dist, parent, source = core.dijkstra(4, tails, heads, weights, [0])
    assert dist == pytest.approx(list(g.distances[0]))
    assert parent[0] == -1 and source == [0, 0, 0, 0]
    # The graph's path 0 -> 2 follows the same parents.
    assert g.path(0, 2) == [0, parent[2], 2]


def test_dijkstra_refuses_negative_weights_and_unknown_vertices():
    with pytest.raises(ValueError, match="weights must be >= 0"):
        core.dijkstra(2, [0], [1], [-1.0], [0])
    with pytest.raises(IndexError):
        core.dijkstra(2, [5], [1], [1.0], [0])
