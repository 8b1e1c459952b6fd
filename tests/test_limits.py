"""The team memory estimate (cli/limits.py) covers what the measured runs hold
(benchmarks/results/limits.md): all-pairs distances once (dtag, msp, hpcc) or per robot
(dtap), and no N^3 term for tpuaf_plus."""

from __future__ import annotations

import pytest
from tpuaf.cli import limits
from tpuaf.errors import CliError

MIB = 2**20


def test_all_pairs_distances_count_once_or_per_robot():
    v = 10_000
    for strategy in ("dtag", "msp", "hpcc"):  # one V x V float64 matrix: 8 B V^2 at least
        assert limits.team_bytes(strategy, 10, v) >= limits.BASE_BYTES + 8 * v * v
        assert limits.team_bytes(strategy, 10, v) < limits.team_bytes(strategy, 10, 2 * v) / 3
    assert limits.team_bytes("gbs", 10, v) < 200 * MIB  # gbs holds no such matrix
    per_robot = limits.team_bytes("dtap", 31, 2500) - limits.team_bytes("dtap", 30, 2500)
    assert per_robot >= 8 * 2500**2  # dtap: a copy per robot


def test_dtap_beyond_the_machine_is_refused(monkeypatch):
    monkeypatch.setattr(limits, "available_bytes", lambda: 8 << 30)
    with pytest.raises(CliError, match=r"dtap with 300 robots .* at most (\d+) robots fit"):
        limits.check_team("dtap", 300, 2500)  # measured: 14 GiB
    limits.check_team("dtap", 10, 2500)  # measured: 0.6 GiB


def test_tpuaf_plus_grows_as_n_squared():
    ratio = limits.team_bytes("tpuaf_plus", 2000, 25) / limits.team_bytes("tpuaf_plus", 1000, 25)
    assert ratio < 4.0
    assert limits.team_bytes("tpuaf_plus", 1000, 2500) < 2 << 30  # measured: 0.4 GiB
