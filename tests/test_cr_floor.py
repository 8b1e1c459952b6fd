"""CR floor (issue 13): no coordinated strategy has a worse I_max than CR, the uncoordinated
conscientious reactive rule, over 5 seeds on cumberland and DIAG_labs with 8 robots.

Runs are 20 min instead of 1 h to keep the suite fast (about 100 runs): the I_max of every
strategy here is set within its first laps (a lap of cumberland's tour takes 387 s for one
robot, 48 s for eight), and the 1 h medians of benchmarks/results/strategies.md give the same
verdicts. The median over the seeds is compared.

Reference-faithful rules that are genuinely worse than CR here are marked (strict xfail: the
mark fails as soon as they stop being worse). Why, with the measured medians, in
docs/STRATEGIES.md ("CR floor"):
- GBS divides idleness by the edge length (gain in s/m) and is greedy on that rate, so targets
  behind long edges starve (cumberland: its per-map G2 is never reached, the order is the rate);
- CBLS is worse with either reward rule (20 min medians, DIAG_labs / cumberland: reference
  123 / 420 s, intended 146 / 306 s, CR 66 / 218 s): its learned arc weights (clamped to
  [0.5, 2]) scale an idleness prior that is normalised over 2-4 candidates, so they override it;
- DTAG and DTAP on DIAG_labs: the origin / partition terms keep each robot near its start,
  and the rooms far from every start wait.
"""

from __future__ import annotations

import statistics

import pytest
from tpuaf.maps import load_map
from tpuaf.runtimes.config import RunConfig
from tpuaf.runtimes.graph import make_run

COORDINATED = ["gbs", "sebs", "cbls", "dtag", "dtap", "tpuaf", "tpuaf_plus", "cgg", "msp"]
SEEDS = range(1, 6)
DURATION_S = 1200.0


@pytest.fixture(scope="module")
def cr_floor(shared_maps):
    maps = {m: load_map(shared_maps / m) for m in ("cumberland", "DIAG_labs")}

    def i_max(map_name, strategy):
        values = []
        for seed in SEEDS:
            config = RunConfig(map=map_name, strategy=strategy, robots=8, duration_s=DURATION_S,
                               seed=seed)
            run = make_run(config, maps[map_name])
            values.append(run.run()["idleness_max_s"])
        return statistics.median(values)

    return i_max, {m: i_max(m, "cr") for m in maps}


WORSE_THAN_CR = {  # (strategy, map): the reference's rule is worse than CR (see above)
    ("gbs", "cumberland"), ("gbs", "DIAG_labs"), ("cbls", "cumberland"), ("cbls", "DIAG_labs"),
    ("dtag", "DIAG_labs"), ("dtap", "DIAG_labs"),
}


def _cases():
    for strategy in COORDINATED:
        for map_name in ("cumberland", "DIAG_labs"):
            marks = []
            if (strategy, map_name) in WORSE_THAN_CR:
                marks = [pytest.mark.xfail(strict=True, reason="reference rule worse than CR")]
            yield pytest.param(strategy, map_name, marks=marks, id=f"{strategy}-{map_name}")


@pytest.mark.parametrize(("strategy", "map_name"), list(_cases()))
def test_no_coordinated_strategy_worse_than_cr(cr_floor, map_name, strategy):
    i_max, floor = cr_floor
    assert i_max(map_name, strategy) <= floor[map_name], (
        f"{strategy} on {map_name}, N = 8: median I_max above CR's {floor[map_name]:.1f} s"
    )
