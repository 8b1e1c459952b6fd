"""Baseline strategies of BASELINES.md, each decision checked by hand on tiny graphs.

A small context object stands in for the runtime (the real engine runs them elsewhere).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from tpuaf.maps.model import PatrolMap
from tpuaf.policies import REGISTRY, ParameterError, Policy, Registry
from tpuaf.policies.bayesian import gbs_probability, gbs_table, intention_factor
from tpuaf.policies.reactive import hcr_scores
from tpuaf.team.messages import IdlenessEstimate, TaskBid, TaskRequest, Visit

BASELINES = ["rand", "cr", "hcr", "hpcc", "cgg", "msp", "gbs", "sebs", "cbls", "dtag", "dtap"]


def make_map(positions, edges, name="tiny") -> PatrolMap:
    pos = np.asarray(positions, dtype=float)
    n = len(pos)
    return PatrolMap(name, list(range(n)), pos, [tuple(e) for e in edges], np.ones(n), np.ones(n))


def star(lengths, name="star") -> PatrolMap:
    """Centre 0 and leaves 1..k at the given distances [m], spread on a circle."""
    pos = [(0.0, 0.0)]
    for k, c in enumerate(lengths):
        a = 2 * math.pi * k / len(lengths)
        pos.append((c * math.cos(a), c * math.sin(a)))
    return make_map(pos, [(0, k + 1) for k in range(len(lengths))], name)


def line(lengths, name="line") -> PatrolMap:
    x = np.concatenate([[0.0], np.cumsum(lengths)])
    return make_map([(v, 0.0) for v in x], [(i, i + 1) for i in range(len(lengths))], name)


class Ctx:
    """The RobotContext attributes a policy uses; records what it sends and wake-ups."""

    def __init__(self, patrol_map, vertex=0, robot=0, n_robots=1, now=0.0, seed=0, router=None):
        self.patrol_map = patrol_map
        self.robot, self.n_robots = robot, n_robots
        self.rng = np.random.default_rng(seed)
        self.now = now
        self.current_vertex = self.start_vertex = vertex
        p = patrol_map.positions[vertex]
        self.start_position = self.position = (float(p[0]), float(p[1]))
        self.average_speed = 1.0
        self.sent, self.wakes, self.goal_changes = [], [], []
        self.router = router

    def send(self, message):
        self.sent.append(message)
        if self.router is not None:
            self.router.send(self, message)

    def wake_at(self, time):
        self.wakes.append(time)

    def at(self, vertex, now):
        self.current_vertex, self.now = vertex, now
        return self


def create(name, ctx, **params) -> Policy:
    policy = REGISTRY.create(name, params)
    policy.start(ctx)
    return policy


# ---------------------------------------------------------------- registry


def test_registry_has_every_baseline_and_documents_parameters():
    names = REGISTRY.names()
    for name in BASELINES:
        assert name in names
        cls = REGISTRY.get(name)
        assert cls.description
        for key, p in cls.parameters.items():
            assert p.doc, f"{name}.{key} has no doc"


def test_registry_refuses_duplicates_and_unknown_parameters():
    reg = Registry()
    cls = REGISTRY.get("cr")
    reg.register(cls)
    with pytest.raises(ValueError, match="already registered"):
        reg.register(cls)
    with pytest.raises(
        ParameterError, match=r"unknown parameter\(s\) foo .*valid: edge_min, g1, g2"
    ):
        REGISTRY.create("gbs", {"foo": 1})
    with pytest.raises(ParameterError, match="valid: none"):
        REGISTRY.create("rand", {"x": 1})
    with pytest.raises(ParameterError, match="invalid value"):
        REGISTRY.create("gbs", {"g1": 1.5})


# ---------------------------------------------------------------- RAND, CR, HCR, HPCC


def test_rand_is_uniform_over_neighbours_and_reproducible_from_ctx_rng():
    m = star([1.0, 2.0, 3.0])

    def sequence(seed):
        ctx = Ctx(m, seed=seed)
        pol = create("rand", ctx)
        return [pol.decide(ctx.at(0, float(t))) for t in range(300)]

    a, b = sequence(7), sequence(7)
    assert a == b
    assert sequence(8) != a
    counts = np.bincount(a, minlength=4)
    assert counts[0] == 0 and all(counts[1:] > 60)
    ctx = Ctx(m, vertex=2)
    assert create("rand", ctx).decide(ctx) == 0  # a leaf has one option


def visit_sequence(policy, ctx, visits):
    """Drive `policy` through own visits [(vertex, time)], ignoring its choices."""
    out = None
    for v, t in visits:
        out = policy.decide(ctx.at(v, t))
    return out


def test_cr_picks_largest_local_idleness_and_ignores_others_visits():
    m = star([1.0, 1.0, 1.0])
    ctx = Ctx(m)
    pol = create("cr", ctx)
    # idleness at t=30: vertex 1: 20 s, 2: 10 s, 3: 30 s (never visited since t=0)
    choice = visit_sequence(pol, ctx, [(0, 0.0), (1, 10.0), (0, 15.0), (2, 20.0), (0, 30.0)])
    assert choice == 3
    pol.on_message(Visit(1, 3, 29.0, -1), ctx)  # local idleness: not used
    assert pol.decide(ctx.at(0, 30.0)) == 3


def test_hcr_scores_and_choice():
    s = hcr_scores(np.array([1.0, 4.0]), np.array([10.0, 30.0]))
    assert s == pytest.approx([0.75 + 10 / 30, 1.0])
    assert hcr_scores(np.array([2.0, 2.0]), np.zeros(2)) == pytest.approx([0.0, 0.0])
    m = star([1.0, 4.0])
    ctx = Ctx(m)
    pol = create("hcr", ctx)
    # I1 = 10, I2 = 30 at t = 30: scores 1.083 vs 1.0 -> the short edge
    assert visit_sequence(pol, ctx, [(0, 0.0), (2, 0.0), (0, 0.0), (1, 20.0), (0, 30.0)]) == 1
    # I1 = 5, I2 = 40: 0.75 + 0.125 < 1.0 -> the long edge
    ctx2 = Ctx(m)
    pol2 = create("hcr", ctx2)
    assert visit_sequence(pol2, ctx2, [(0, 0.0), (1, 35.0), (0, 40.0)]) == 2


def test_hpcc_goal_score_and_idleness_weighted_path():
    # unit square 0-1-3 and 0-2-3
    m = make_map([(0, 0), (1, 0), (0, 1), (1, 1)], [(0, 1), (1, 3), (0, 2), (2, 3)])
    ctx = Ctx(m)
    pol = create("hpcc", ctx)
    pol.decide(ctx.at(0, 0.0))
    pol.plan = []  # forget the first plan: the test drives the robot by hand
    # at t=100: I0 = 0, I1 = 40, I2 = 10, I3 = 100 -> scores v1 .5+.4, v2 .5+.1, v3 0+1 -> goal 3
    pol.table.visit(1, 60.0)
    pol.table.visit(2, 90.0)
    cands, score = pol.goal_scores(ctx.at(0, 100.0), pol.table.idleness(100.0))
    assert dict(zip(cands, score, strict=True)) == pytest.approx({1: 0.9, 2: 0.6, 3: 1.0})
    # path weights: via 1: (100-40)/100 = 0.6, via 2: 0.9 -> go through 1, then 3
    assert pol.decide(ctx.at(0, 100.0)) == 1
    assert pol.decide(ctx.at(1, 101.0)) == 3


# ---------------------------------------------------------------- CGG, MSP


def ring(n=6, name="ring") -> PatrolMap:
    pos = [(math.cos(2 * math.pi * k / n), math.sin(2 * math.pi * k / n)) for k in range(n)]
    return make_map(pos, [(k, (k + 1) % n) for k in range(n)], name)


def follow(policy, ctx, steps, t=0.0):
    out = []
    for _ in range(steps):
        v = policy.decide(ctx)
        assert v is not None and v != ctx.current_vertex
        out.append(v)
        t += 1.0
        ctx.at(v, t)
    return out


def test_cgg_follows_one_shared_walk_from_own_start():
    m = ring(6)
    a_ctx, b_ctx = Ctx(m, vertex=0, n_robots=2), Ctx(m, vertex=3, robot=1, n_robots=2)
    a, b = create("cgg", a_ctx), create("cgg", b_ctx)
    assert a.route == b.route and sorted(a.route) == list(range(6))
    seq_a = follow(a, a_ctx, 12)
    seq_b = follow(b, b_ctx, 12)
    assert sorted(seq_a[:6]) == list(range(6))
    # same cyclic order: b's sequence is a's shifted by 3 positions
    i = a.route.index(3)
    assert seq_b[:6] == [a.route[(i + 1 + k) % 6] for k in range(6)]
    # a failed goal is skipped
    ctx = Ctx(m, vertex=0)
    pol = create("cgg", ctx)
    first = pol.decide(ctx)
    pol.on_goal_failed(first, ctx)
    nxt = pol.decide(ctx)
    assert nxt not in (first, 0)


def test_msp_robot_stays_in_its_part_and_covers_it():
    m = line([1.0] * 7)  # 8 vertices on a line
    parts = []
    for r, start in enumerate([0, 7]):
        ctx = Ctx(m, vertex=start, robot=r, n_robots=2)
        pol = create("msp", ctx)
        seq = follow(pol, ctx, 20)
        parts.append(set(seq))
    assert parts[0].isdisjoint(parts[1])
    assert parts[0] | parts[1] == set(range(8))
    assert 0 in parts[0] and 7 in parts[1]


# ---------------------------------------------------------------- GBS, SEBS, CBLS


def test_gbs_table_interpolation_and_saturation():
    assert gbs_table("grid", 4) == (148.7, 0.075)
    assert gbs_table("grid", 3)[0] == pytest.approx((236.0 + 148.7) / 2)
    assert gbs_table("Cumberland", 16) == (846.7, 3.75)
    assert gbs_table("somewhere", 4) == (2000.0, 0.05)
    p = gbs_probability(np.array([0.0, 50.0, 100.0, 150.0]), 0.1, 100.0)
    assert p == pytest.approx([0.1, 0.1 * math.exp(math.log(10) / 2), 1.0, 1.0])


def test_gbs_picks_by_gain_with_edge_min_and_shares_visits():
    m = star([0.5, 2.0])
    # I1 = 10, I2 = 30 at t = 30. Without a floor: gains 20 vs 15 s/m -> vertex 1.
    ctx = Ctx(m, n_robots=2)
    pol = create("gbs", ctx, g2=100.0, edge_min=0.01)
    pol.on_message(Visit(1, 1, 20.0, -1), ctx)  # shared idleness: robot 1 visited vertex 1
    assert pol.decide(ctx.at(0, 30.0)) == 1
    assert ctx.sent[-1] == Visit(0, 0, 30.0, -1)
    # floor 1 m: gains 10 vs 15 -> vertex 2
    ctx = Ctx(m, n_robots=2)
    pol = create("gbs", ctx, g2=100.0, edge_min=1.0)
    pol.on_message(Visit(1, 1, 20.0, -1), ctx)
    assert pol.decide(ctx.at(0, 30.0)) == 2
    # both saturated (gain >= G2 gives P = 1): a tie, broken at random
    picks = set()
    for seed in range(20):
        ctx = Ctx(m, seed=seed)
        pol = create("gbs", ctx, g2=1.0, edge_min=0.01)
        picks.add(pol.decide(ctx.at(0, 30.0)))
    assert picks == {1, 2}


def test_gbs_uses_per_map_defaults():
    ctx = Ctx(star([1.0, 1.0], name="grid"), n_robots=8)
    pol = create("gbs", ctx)
    assert (pol.g2, pol.edge_min) == (137.2, 0.075)


def test_sebs_intention_penalty_changes_the_choice():
    assert intention_factor(0, 2) == 1.0
    assert intention_factor(1, 2) == pytest.approx(2 / 3)
    assert intention_factor(2, 3) == pytest.approx(2 / 7)
    m = star([1.0, 1.0])
    ctx = Ctx(m, n_robots=2)
    pol = create("sebs", ctx)
    pol.on_message(Visit(1, 1, 2.0, -1), ctx)  # I1 = 10, I2 = 12 at t = 12
    assert pol.decide(ctx.at(0, 12.0)) == 2
    assert ctx.sent[-1] == Visit(0, 0, 12.0, 2)  # SEBS announces its next vertex
    ctx = Ctx(m, n_robots=2)
    pol = create("sebs", ctx)
    pol.on_message(Visit(1, 1, 2.0, 2), ctx)  # ... and robot 1 now heads to 2
    assert pol.decide(ctx.at(0, 12.0)) == 1


def test_cbls_arc_weights_after_one_reward_and_punish_step():
    """The intended rule of BASELINES.md (a parameter)."""
    m = star([1.0, 1.0, 1.0])  # centre 0, leaves 1, 2, 3
    ctx = Ctx(m, n_robots=2)
    pol = create("cbls", ctx, reward_rule="intended")
    for v, t in [(1, 10.0), (1, 20.0), (2, 20.0)]:
        pol.on_message(Visit(1, v, t, -1), ctx)
    # t = 40: counts 2, 1, 0; closed means 10, 20, -; I = 20, 20, 40
    # A = (10*2 + 20)/3, (20 + 20)/2, 40/1 -> prior 2/11, 3/11, 6/11 (weights all 1)
    assert pol.current_average(40.0)[1:] == pytest.approx([40 / 3, 20.0, 40.0])
    assert pol.posterior(ctx.at(0, 40.0), [1, 2, 3]) == pytest.approx([2 / 11, 3 / 11, 6 / 11])
    assert pol.decide(ctx.at(0, 40.0)) == 3
    p = np.array([2, 3, 6]) / 11
    entropy = float(-(p * np.log(p)).sum() / math.log(3))
    assert pol.previous[2] == pytest.approx(entropy)
    # arrival at 3: visits per degree 2, 1, 1 -> reward the least visited, the tie (2, 3) to
    # the more idle (2: 21 s vs 3: 0 s); punish the most visited (1)
    pol.decide(ctx.at(3, 41.0))
    step = 1.0 - entropy
    assert pol.weight(0, 2) == pytest.approx(1.0 + step)
    assert pol.weight(0, 1) == pytest.approx(1.0 - step)
    assert pol.weight(0, 3) == 1.0
    # weights are clamped to [0.5, 2.0]
    for _ in range(100):
        pol.previous = (0, [1, 2, 3], 0.0)
        pol.learn(ctx.at(3, 41.0))
    assert pol.weight(0, 2) == 2.0 and pol.weight(0, 1) == 0.5


def test_cbls_reference_rule_is_the_default():
    """The reference's actual rule: its visits tie test is always true, so the most idle of the
    previous candidates is rewarded and the least idle punished, whatever the visit counts."""
    m = star([1.0, 1.0, 1.0])
    ctx = Ctx(m, n_robots=2)
    pol = create("cbls", ctx)
    assert pol.params["reward_rule"] == "reference"
    for v, t in [(1, 10.0), (1, 20.0), (2, 20.0)]:
        pol.on_message(Visit(1, v, t, -1), ctx)
    assert pol.decide(ctx.at(0, 40.0)) == 3
    entropy = pol.previous[2]
    # arrival at 3 at t = 41: idleness 21, 21, 0 -> reward 1 and 2 (the intended rule would
    # punish 1, the most visited), punish 3
    pol.decide(ctx.at(3, 41.0))
    step = 1.0 - entropy
    assert pol.weight(0, 1) == pytest.approx(1.0 + step)
    assert pol.weight(0, 2) == pytest.approx(1.0 + step)
    assert pol.weight(0, 3) == pytest.approx(1.0 - step)
    # all equally idle: every candidate is both the most and the least idle, and -1 wins
    pol.previous = (0, [1, 2], 0.0)
    pol.table.visit(1, 50.0)
    pol.table.visit(2, 50.0)
    before = pol.weight(0, 1), pol.weight(0, 2)
    pol.learn(ctx.at(3, 60.0))  # step 1 - H = 1
    assert (pol.weight(0, 1), pol.weight(0, 2)) == pytest.approx(
        (max(before[0] - 1, 0.5), max(before[1] - 1, 0.5)))


def test_cbls_avoids_vertices_intended_by_others():
    m = star([1.0, 1.0, 1.0])
    ctx = Ctx(m, n_robots=2)
    pol = create("cbls", ctx)
    pol.on_message(Visit(1, 1, 10.0, 3), ctx)  # robot 1 heads to 3, the most idle
    assert pol.decide(ctx.at(0, 40.0)) == 2
    assert ctx.sent[-1] == Visit(0, 0, 40.0, 2)


# ---------------------------------------------------------------- DTAG


def test_dtag_utility_estimate_sharing_and_replan():
    m = line([1.0, 2.0])  # 0 -(1 m)- 1 -(2 m)- 2, robot starts at 0
    ctx = Ctx(m, robot=1, n_robots=2)
    ctx.change_goal = lambda v: ctx.goal_changes.append(v)
    pol = create("dtag", ctx)
    # U1 = 100 - 10*1 - 5*1 = 85, U2 = 100 - 10*3 - 5*3 = 55
    assert pol.utility(ctx, 0)[1:] == pytest.approx([85.0, 55.0])
    assert pol.decide(ctx) == 1
    msg = ctx.sent[-1]
    assert isinstance(msg, IdlenessEstimate) and msg.next_vertex == 1
    assert msg.estimate == (0.0, 0.0, 100.0)  # current visited, next reserved
    # merge: E = min(E + elapsed, received + transit)
    ctx.now = 10.0
    pol.on_message(IdlenessEstimate(0, 8.0, (50.0, 500.0, 3.0), 0), ctx)
    assert pol.estimate.values == pytest.approx([10.0, 110.0, 5.0])
    assert ctx.goal_changes == []
    # the (lower-id) sender heads to my goal: re-plan without it, once per decision
    pol.on_message(IdlenessEstimate(0, 10.0, (50.0, 0.0, 50.0), 1), ctx)
    assert ctx.goal_changes == [2] and pol.next == 2
    assert ctx.sent[-1].next_vertex == 2
    pol.on_message(IdlenessEstimate(0, 10.0, (50.0, 0.0, 50.0), 2), ctx)
    assert ctx.goal_changes == [2]  # no second yield before the next decision
    # a higher-id robot never makes me yield (only one of a clashing pair yields)
    other = Ctx(m, robot=0, n_robots=2)
    other.change_goal = lambda v: other.goal_changes.append(v)
    pol0 = create("dtag", other)
    assert pol0.decide(other) == 1
    pol0.on_message(IdlenessEstimate(1, 0.0, (50.0, 0.0, 50.0), 1), other)
    assert other.goal_changes == []


# ---------------------------------------------------------------- DTAP


class Router:
    """Delivers every message to the other robots' policies at once, unless `lose` says so."""

    def __init__(self, lose=lambda sender, receiver, message: False):
        self.members: list[tuple[Ctx, Policy]] = []
        self.lose = lose

    def join(self, ctx, policy):
        self.members.append((ctx, policy))

    def send(self, sender, message):
        for ctx, pol in self.members:
            if ctx is not sender and not self.lose(sender, ctx, message):
                ctx.now = sender.now
                pol.on_message(message, ctx)


def dtap_pair(router, received=None):
    """Line 0..7, edge 1-2 = 2 m, others 1 m. A (robot 0) at 1, B (robot 1) at 3."""
    m = line([1.0, 2.0, 1.0, 1.0, 1.0, 1.0, 1.0])
    a_ctx = Ctx(m, vertex=1, robot=0, n_robots=2, router=router)
    b_ctx = Ctx(m, vertex=3, robot=1, n_robots=2, router=router)
    a, b = create("dtap", a_ctx), create("dtap", b_ctx)
    router.join(a_ctx, a)
    router.join(b_ctx, b)
    if received is not None:  # a third robot's estimate, 16 s = 2|V| where not lowered
        for ctx, pol in ((a_ctx, a), (b_ctx, b)):
            pol.on_message(IdlenessEstimate(2, 0.0, tuple(received), -1), ctx)
    return a_ctx, a, b_ctx, b


def test_dtap_lower_bid_wins_after_a_wait_in_simulated_time():
    router = Router()
    a_ctx, a, b_ctx, b = dtap_pair(router, received=[15, 0, 16, 0, 0, 0, 0, 0])
    # A at 1: U(v) = E[v] - 2 * hops * 8: U(2) = 0 > U(0) = -1 -> auction 2; bid path(2, 1) = 2 m
    assert a.decide(a_ctx) is None
    assert a_ctx.wakes == [1.0]  # wait 1 + 0.1 * 0 tasks
    assert a_ctx.sent[-1] == TaskRequest(0, 2, 2.0, 0.0)
    # B bids path(2, 3) = 1 m < 2 m: B holds the vertex and replies
    assert b_ctx.sent[-1] == TaskBid(1, 2, 1.0, 0.0)
    assert b.tasks(b_ctx) == [2] and a.holder(2) == 1
    # early wake: still waiting
    assert a.decide(a_ctx.at(1, 0.5)) is None and a_ctx.wakes[-1] == 1.0
    # t = 1: A lost; E = 16,0,17,1,... : 17 < mean 4.75 + 2 std 6.8 -> auction the next best, 0
    assert a.decide(a_ctx.at(1, 1.0)) is None
    assert a_ctx.sent[-1] == TaskRequest(0, 0, 1.0, 1.0)
    assert a_ctx.wakes[-1] == pytest.approx(2.0)
    assert len(b_ctx.sent) == 1  # B's bid path(0, 3) = 4 m is higher: no reply
    # A wins at t = 2, heads there, announces it and opens the pipelined auction after it
    assert a.decide(a_ctx.at(1, 2.0)) == 0
    assert a.goal == 0 and a.auction.base == 0
    est = [s for s in a_ctx.sent if isinstance(s, IdlenessEstimate)]
    assert est[-1].next_vertex == 0 and est[-1].estimate[0] == 0.0
    assert isinstance(a_ctx.sent[-1], TaskRequest) and a_ctx.sent[-1].vertex != 0
    assert a.stats == {"won": 1, "taken_anyway": 0, "lost": 1, "fallback": 0}


def test_dtap_takes_a_lost_adjacent_vertex_with_outlying_estimate_unless_someone_bid_zero():
    router = Router()
    a_ctx, a, b_ctx, b = dtap_pair(router, received=[0, 0, 16, 0, 0, 0, 0, 0])
    assert a.decide(a_ctx) is None and a.holder(2) == 1
    # t = 1: E = 1,0,17,1,1,1,1,1: 17 > mean 2.9 + 2 * std 5.3 and 2 is adjacent to 1
    assert a.decide(a_ctx.at(1, 1.0)) == 2
    assert a.stats["taken_anyway"] == 1
    # same, but B is heading to 2 and bids 0
    router = Router()
    a_ctx, a, b_ctx, b = dtap_pair(router, received=[0, 0, 16, 0, 0, 0, 0, 0])
    b.goal = 2
    assert a.decide(a_ctx) is None
    assert b_ctx.sent[-1] == TaskBid(1, 2, 0.0, 0.0)
    assert a.auction.zero_bid
    assert a.decide(a_ctx.at(1, 1.0)) is None  # lost, not taken: next auction


def test_dtap_never_blocks_when_messages_are_lost():
    router = Router(lose=lambda s, r, m: True)
    a_ctx, a, b_ctx, b = dtap_pair(router, received=[0, 0, 16, 16, 16, 16, 16, 16])
    assert a.decide(a_ctx) is None and a_ctx.wakes == [1.0]
    assert b_ctx.sent == [] and a.holder(2) == 0
    assert a.decide(a_ctx.at(1, 1.0)) == 2  # no competing bid arrived: the timeout decides


def test_dtap_bids_expire():
    router = Router()
    a_ctx, a, b_ctx, b = dtap_pair(router, received=[0, 0, 16, 16, 16, 16, 16, 16])
    a.decide(a_ctx)
    assert b.tasks(b_ctx) == [2]
    b_ctx.now = 200.0
    assert b.tasks(b_ctx) == []


# ---------------------------------------------------------------- robustness


def lollipop() -> PatrolMap:
    """A triangle 0-1-2 with a tail 2-3-4 (4 is a leaf) and a pendant leaf 5 on 0."""
    pos = [(0, 0), (2, 0), (1, 1.5), (1, 3), (1, 4.5), (-1.5, 0)]
    return make_map(pos, [(0, 1), (1, 2), (2, 0), (2, 3), (3, 4), (0, 5)], "lollipop")


@pytest.mark.parametrize("name", BASELINES)
@pytest.mark.parametrize("n_robots", [1, 3])
def test_every_baseline_keeps_moving_on_leaves_and_small_graphs(name, n_robots):
    for m in (lollipop(), line([1.5])):
        router = Router()
        ctxs, pols, t_free = [], [], []
        for r in range(n_robots):
            ctx = Ctx(
                m, vertex=r % m.num_vertices, robot=r, n_robots=n_robots, seed=r, router=router
            )
            pol = create(name, ctx)
            router.join(ctx, pol)
            ctxs.append(ctx)
            pols.append(pol)
            t_free.append(0.0)
        visited = set()
        for _ in range(60 * n_robots):
            r = int(np.argmin(t_free))
            ctx, pol = ctxs[r], pols[r]
            ctx.now = t_free[r]
            before = len(ctx.wakes)
            goal = pol.decide(ctx)
            if goal is None:
                assert len(ctx.wakes) > before and ctx.wakes[-1] > ctx.now
                t_free[r] = ctx.wakes[-1]
                continue
            assert 0 <= goal < m.num_vertices and goal != ctx.current_vertex
            t_free[r] += m.graph.distance(ctx.current_vertex, goal)
            ctx.current_vertex = goal
            visited.add(goal)
        if name != "rand":
            assert visited == set(range(m.num_vertices)), name


def test_cbls_refuses_crossed_weight_clamps():
    """weight_min > weight_max (or an initial weight outside them) is one ParameterError naming
    the relation, not a run with clamps that cannot hold."""
    with pytest.raises(ParameterError, match="weight_min <= weight_init <= weight_max"):
        REGISTRY.create("cbls", {"weight_min": 3.0, "weight_max": 1.0})
    with pytest.raises(ParameterError, match="weight_init = 5"):
        REGISTRY.create("cbls", {"weight_init": 5.0})
    assert REGISTRY.create("cbls", {"weight_min": 1.0, "weight_max": 1.0}).params["weight_max"] == 1.0
