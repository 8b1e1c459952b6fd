"""Bayesian baselines of BASELINES.md: GBS, SEBS and CBLS. Shared idleness via `Visit` messages."""

from __future__ import annotations

import math

import numpy as np

from tpuaf.policies.base import Parameter, Policy, register
from tpuaf.policies.common import IdlenessTable, neighbours, pick_max, wait_nowhere_to_go
from tpuaf.team.messages import Visit

# GBS per-map G2 [s/m] by team size and edge_min [m] (BASELINES.md, converted to metres).
GBS_TABLE_N = (1, 2, 4, 6, 8, 12)
GBS_TABLE: dict[str, tuple[tuple[float, ...], float]] = {
    "grid": ((273.9, 236.0, 148.7, 142.8, 137.2, 121.7), 0.075),
    "cumberland": ((2026.7, 1338.7, 1076.5, 1026.7, 846.7, 846.7), 3.75),
    "example": ((1466.7, 1203.3, 1062.0, 914.3, 840.7, 840.7), 3.0),
}
GBS_DEFAULT_G2 = 2000.0  # [s/m] any other map
GBS_DEFAULT_EDGE_MIN = 0.05  # [m] any other map


def gbs_table(map_name: str, n_robots: int) -> tuple[float, float]:
    """(G2 [s/m], edge_min [m]) for a map and team size. Between listed team sizes G2 is
    interpolated linearly in N; below 1 / above 12 the nearest listed N is taken."""
    row = GBS_TABLE.get(str(map_name).strip().lower())
    if row is None:
        return GBS_DEFAULT_G2, GBS_DEFAULT_EDGE_MIN
    g2s, edge_min = row
    return float(np.interp(float(n_robots), GBS_TABLE_N, g2s)), edge_min


def gbs_probability(gain: np.ndarray, g1: float, g2: float) -> np.ndarray:
    """P = G1 * exp(ln(1/G1) * gain / G2) for gain < G2, else 1 (gain in s/m)."""
    gain = np.asarray(gain, dtype=float)
    p = g1 * np.exp(math.log(1.0 / g1) * gain / g2)
    return np.where(gain >= g2, 1.0, p)


def _positive_or_none(x) -> bool:
    return x is None or (isinstance(x, int | float) and x > 0)


class _SharedIdleness(Policy):
    """last_visit from own arrivals and from other robots' Visit messages."""

    def start(self, ctx):
        self.table = IdlenessTable(ctx.patrol_map.graph.num_vertices, ctx.now)
        self.intentions: dict[int, int] = {}  # robot -> announced next vertex

    def _ensure(self, ctx):
        if not hasattr(self, "table"):
            self.start(ctx)

    def on_message(self, message, ctx):
        self._ensure(ctx)
        if isinstance(message, Visit) and message.robot != ctx.robot:
            self.table.visit(message.vertex, message.time)
            self.intentions[message.robot] = int(message.next_vertex)

    def on_teammate_lost(self, robot, ctx):
        getattr(self, "intentions", {}).pop(robot, None)

    def intended_by_others(self, ctx) -> list[int]:
        return [v for r, v in self.intentions.items() if r != ctx.robot and v >= 0]


@register
class GreedyBayesian(_SharedIdleness):
    """GBS: argmax over neighbours of P_n = G1 exp(ln(1/G1) gain/G2), gain = I_n / max(c_n, edge_min)."""

    name = "gbs"
    description = "Greedy Bayesian strategy: argmax P(gain), gain = shared idleness / edge length."
    parameters = {
        "g1": Parameter(
            0.1, "G1, probability at zero gain (0 < G1 < 1, unitless)", lambda x: 0 < x < 1
        ),
        "g2": Parameter(
            None,
            "G2 [s/m], gain at which P saturates to 1; None = per-map table by team size "
            "(BASELINES.md; 2000 s/m for maps not listed)",
            _positive_or_none,
        ),
        "edge_min": Parameter(
            None,
            "lower bound on the edge length in the gain [m]; None = per-map table "
            "(0.05 m for maps not listed)",
            _positive_or_none,
        ),
    }
    send_next = False  # GBS broadcasts only (robot, vertex reached)

    def start(self, ctx):
        super().start(ctx)
        g2, edge_min = self.defaults(ctx)
        self.g2 = float(self.params["g2"]) if self.params["g2"] is not None else g2
        self.edge_min = (
            float(self.params["edge_min"]) if self.params["edge_min"] is not None else edge_min
        )

    def defaults(self, ctx) -> tuple[float, float]:
        return gbs_table(ctx.patrol_map.name, ctx.n_robots)

    def probabilities(self, ctx, cands: list[int], idle: np.ndarray) -> np.ndarray:
        g, here = ctx.patrol_map.graph, ctx.current_vertex
        w = np.array([max(g.edge_length(here, n), self.edge_min) for n in cands])
        return gbs_probability(idle[cands] / w, self.params["g1"], self.g2)

    def decide(self, ctx):
        self._ensure(ctx)
        here, now = ctx.current_vertex, ctx.now
        self.table.visit(here, now)
        cands = neighbours(ctx)
        if not cands:
            wait_nowhere_to_go(ctx)
            return None
        if len(cands) == 1:
            nxt = cands[0]
        else:
            p = self.probabilities(ctx, cands, self.table.idleness(now))
            nxt = pick_max(cands, p, ctx.rng)
        ctx.send(Visit(ctx.robot, here, now, nxt if self.send_next else -1))
        return nxt


@register
class StateExchangeBayesian(GreedyBayesian):
    """SEBS: GBS (G2 = 2000 s/m, edge_min = 0.05 m) with P_n scaled by 2^(N-c)/(2^N-1) when
    c > 0 other robots announced neighbour n as their next vertex."""

    name = "sebs"
    description = (
        "State exchange Bayesian strategy: GBS gain with G2 = 2000 s/m, P_n * 2^(N-c)/(2^N-1) "
        "for c other robots intending n; broadcasts (vertex reached, next vertex)."
    )
    parameters = {
        "g1": GreedyBayesian.parameters["g1"],
        "g2": Parameter(2000.0, "G2 [s/m], gain at which P saturates to 1", lambda x: x > 0),
        "edge_min": Parameter(
            0.05, "lower bound on the edge length in the gain [m]", lambda x: x > 0
        ),
    }
    send_next = True

    def defaults(self, ctx):
        return float(self.params["g2"]), float(self.params["edge_min"])

    def probabilities(self, ctx, cands, idle):
        p = super().probabilities(ctx, cands, idle)
        return p * np.array(
            [intention_factor(self.intended_by_others(ctx).count(n), ctx.n_robots) for n in cands]
        )


def intention_factor(c: int, n_robots: int) -> float:
    """SEBS penalty 2^(N-c)/(2^N-1) for c > 0 robots intending a vertex, 1 when c = 0."""
    if c <= 0:
        return 1.0
    return 2.0 ** (n_robots - c) / (2.0**n_robots - 1.0)


@register
class ConcurrentBayesianLearning(_SharedIdleness):
    """CBLS: idleness prior with one-step lookahead times learned arc weights (reward/punish)."""

    name = "cbls"
    description = (
        "Concurrent Bayesian learning strategy: prior 0.75 A(i) + 0.25 max A(j), posterior = prior x "
        "learned arc weight, weights rewarded/punished by (1-H) after each move."
    )
    parameters = {
        "w_self": Parameter(
            0.75,
            "prior weight of the candidate's own mean idleness A(i) (unitless)",
            lambda x: 0 <= x <= 1,
        ),
        "w_lookahead": Parameter(
            0.25,
            "prior weight of max A(j) over the candidate's neighbours (unitless)",
            lambda x: 0 <= x <= 1,
        ),
        "weight_min": Parameter(0.5, "lower clamp of an arc weight (unitless)", lambda x: x > 0),
        "weight_max": Parameter(2.0, "upper clamp of an arc weight (unitless)", lambda x: x > 0),
        "weight_init": Parameter(1.0, "initial arc weight (unitless)", lambda x: x > 0),
        "reward_rule": Parameter(
            "reference",
            "'reference': the reference code's actual rule (its visits tie test is always "
            "true: reward the most idle previous candidates, punish the least idle, -1 wins "
            "where both apply); 'intended': reward the fewest visits per degree, punish the "
            "most (ties by idleness), as BASELINES.md states the intent",
            lambda x: x in ("reference", "intended"),
        ),
    }
    parameter_relations = (
        (lambda p: p["weight_min"] <= p["weight_init"] <= p["weight_max"],
         "weight_min <= weight_init <= weight_max"),
    )

    def start(self, ctx):
        super().start(ctx)
        n = ctx.patrol_map.graph.num_vertices
        self.weights: dict[tuple[int, int], float] = {}  # directed arc -> weight
        self.count = np.zeros(n, dtype=int)  # known visits (own and others')
        self.avg = np.zeros(n)  # closed running mean of interval idleness [s]
        self.previous: tuple[int, list[int], float] | None = None  # (from, candidates, H)

    def _visit(self, vertex: int, time: float) -> None:
        if not 0 <= vertex < self.count.size or time < self.table.last_visit[vertex]:
            return  # an out-of-date report
        sample = time - self.table.last_visit[vertex]
        self.count[vertex] += 1
        self.avg[vertex] += (sample - self.avg[vertex]) / self.count[vertex]
        self.table.visit(vertex, time)

    def on_message(self, message, ctx):
        self._ensure(ctx)
        if isinstance(message, Visit) and message.robot != ctx.robot:
            self._visit(int(message.vertex), float(message.time))
            self.intentions[message.robot] = int(message.next_vertex)

    def current_average(self, now: float) -> np.ndarray:
        """A(v): running mean including the current (open) interval, as the reference does."""
        idle = self.table.idleness(now)
        return (self.avg * self.count + idle) / (self.count + 1)

    def weight(self, u: int, v: int) -> float:
        return self.weights.get((u, v), float(self.params["weight_init"]))

    def learn(self, ctx) -> None:
        """Reward the least visited (per degree) of the previous candidates, punish the most."""
        if self.previous is None:
            return
        origin, cands, entropy = self.previous
        self.previous = None
        if len(cands) < 2:
            return
        idle = self.table.idleness(ctx.now)
        per_degree = np.array([self.count[c] / max(len(neighbours(ctx, c)), 1) for c in cands])
        ic = idle[cands]
        tol = 1e-9

        def extreme(values: np.ndarray, fewest: bool) -> list[int]:
            target = values.min() if fewest else values.max()
            tied = np.flatnonzero(np.abs(values - target) <= tol)
            sub = ic[tied]  # ties by idleness: reward the most idle, punish the least idle
            pick = sub.max() if fewest else sub.min()
            return [cands[i] for i in tied[np.abs(sub - pick) <= tol]]

        if self.params["reward_rule"] == "reference":
            # the visit counts always tie in the reference: only the idleness tie-break acts
            top, low = ic.max(), ic.min()
            reward = [c for c, x in zip(cands, ic, strict=True) if x >= top - tol]
            punish = [c for c, x in zip(cands, ic, strict=True) if x <= low + tol]
            reward = [c for c in reward if c not in punish]  # -1 wins where both apply
        else:
            reward, punish = extreme(per_degree, True), extreme(per_degree, False)
            if set(reward) == set(punish):
                return  # nothing distinguishes the candidates
        step = 1.0 - entropy
        lo, hi = float(self.params["weight_min"]), float(self.params["weight_max"])
        for sign, group in ((1.0, reward), (-1.0, punish)):
            for c in group:
                self.weights[(origin, c)] = float(
                    np.clip(self.weight(origin, c) + sign * step, lo, hi)
                )

    def posterior(self, ctx, cands: list[int]) -> np.ndarray:
        here = ctx.current_vertex
        a = self.current_average(ctx.now)
        intended = set(self.intended_by_others(ctx))
        prior = []
        for i in cands:
            nb = neighbours(ctx, i)
            free = [j for j in nb if j not in intended]
            if len(nb) <= 1 or not free:
                prior.append(a[i])
            else:
                prior.append(
                    self.params["w_self"] * a[i]
                    + self.params["w_lookahead"] * max(a[j] for j in free)
                )
        prior = np.asarray(prior, dtype=float)
        prior = prior / prior.sum() if prior.sum() > 0 else np.full(len(cands), 1.0 / len(cands))
        w = np.array([self.weight(here, c) for c in cands])
        post = prior * (w / w.sum())
        return post / post.sum() if post.sum() > 0 else np.full(len(cands), 1.0 / len(cands))

    def decide(self, ctx):
        self._ensure(ctx)
        here, now = ctx.current_vertex, ctx.now
        self._visit(here, now)
        self.learn(ctx)
        nbrs = neighbours(ctx)
        if not nbrs:
            wait_nowhere_to_go(ctx)
            return None
        intended = set(self.intended_by_others(ctx))
        cands = [n for n in nbrs if n not in intended] or nbrs
        if len(cands) == 1:
            nxt, entropy = cands[0], 0.0
        else:
            post = self.posterior(ctx, cands)
            # argmax, ties to the shortest edge, then at random
            g = ctx.patrol_map.graph
            top = np.flatnonzero(post >= post.max() - 1e-12)
            tied = [cands[i] for i in top]
            lengths = np.array([g.edge_length(here, c) for c in tied])
            nxt = pick_max(tied, -lengths, ctx.rng)
            nz = post[post > 0]
            entropy = float(-(nz * np.log(nz)).sum() / math.log(len(cands)))
        self.previous = (here, cands, entropy)
        ctx.send(Visit(ctx.robot, here, now, nxt))
        return nxt
