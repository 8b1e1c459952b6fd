"""The team memory estimate (cli/limits.py) covers what the measured runs hold
(benchmarks/results/limits.md, limits_dtap.md): all-pairs matrices once, shared by the robots
(dtag, msp, hpcc, dtap), and no N^3 term for tpuaf_plus."""

from __future__ import annotations

from tpuaf.cli import limits

MIB = 2**20


def test_all_pairs_distances_count_once_or_per_robot():
    v = 10_000
    for strategy in ("dtag", "msp", "hpcc"):  # one V x V float64 matrix: 8 B V^2 at least
        assert limits.team_bytes(strategy, 10, v) >= limits.BASE_BYTES + 8 * v * v
        assert limits.team_bytes(strategy, 10, v) < limits.team_bytes(strategy, 10, 2 * v) / 3
    assert limits.team_bytes("gbs", 10, v) < 200 * MIB  # gbs holds no such matrix
    # dtap: distances and hop counts, one matrix of each for the whole team
    assert limits.team_bytes("dtap", 10, 2500) >= limits.BASE_BYTES + 12 * 2500**2
    per_robot = limits.team_bytes("dtap", 31, 2500) - limits.team_bytes("dtap", 30, 2500)
    assert per_robot < 2500**2  # no copy per robot


def test_dtap_robots_share_the_graphs_matrices():
    """The per-robot copy (14 GiB at N = 300, V = 2,500 before) is gone: every robot's dtap
    reads the graph's own matrices."""
    from types import SimpleNamespace

    from tpuaf.maps import load_map
    from tpuaf.policies import REGISTRY

    pm = load_map("grid")
    policies = [REGISTRY.create("dtap", {}) for _ in range(2)]
    for robot, policy in enumerate(policies):
        policy.start(SimpleNamespace(patrol_map=pm, now=0.0, robot=robot))
    a, b = policies
    assert a.dist.base is not None and a.hops.base is not None  # views, not copies
    assert (a.dist.__array_interface__["data"][0] == b.dist.__array_interface__["data"][0])
    assert (a.hops.__array_interface__["data"][0] == b.hops.__array_interface__["data"][0])


def test_tpuaf_plus_grows_as_n_squared():
    ratio = limits.team_bytes("tpuaf_plus", 2000, 25) / limits.team_bytes("tpuaf_plus", 1000, 25)
    assert ratio < 4.0
    assert limits.team_bytes("tpuaf_plus", 1000, 2500) < 2 << 30  # measured: 0.4 GiB
