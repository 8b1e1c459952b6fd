"""DTAP of BASELINES.md: dynamic task assignment with sequential single-item auctions.

Flow (all waits in the runtime's clock: `decide` returns None and calls `ctx.wake_at`):

- On reaching its goal g the robot resolves the auction it opened, when it left for g, for the
  vertex to visit after g (pipelining). Won -> that vertex is the next goal, and the auction for
  the vertex after it opens at once. Lost -> the next-best vertex is auctioned and the robot waits
  at g for replies. With no auction open (first decision, after a failed goal) it auctions and waits.
- An auction for a vertex after `base`: the best-utility vertex not yet tried, U = E[v] -
  hop_weight * hops(base, v) * |V|; broadcast TaskRequest(v, my bid); wait
  min(wait_max, wait_base + wait_per_task * |my tasks|) s. Still lowest bid -> mine. Else taken
  anyway if v is adjacent to base, E[v] > mean(E) + threshold_std * std(E) and nobody bid 0 on v.
  Else the next-best vertex. When every vertex was tried: the best-utility neighbour of base.
- Replies are awaited only until the deadline, so lost messages never block a robot.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tpuaf.maps.tours import travel_hops
from tpuaf.policies.base import Parameter, Policy, register
from tpuaf.policies.common import neighbours, pick_max, wait_nowhere_to_go
from tpuaf.policies.dtag import SharedEstimate
from tpuaf.team.messages import IdlenessEstimate, TaskBid, TaskRequest


def _pos(x) -> bool:
    return isinstance(x, int | float) and x > 0


def _nonneg(x) -> bool:
    return isinstance(x, int | float) and x >= 0


@dataclass
class Auction:
    vertex: int  # the vertex auctioned
    base: int  # the vertex it would follow (where the robot is or is heading)
    bid: float  # my bid [m]
    deadline: float  # [s]
    tried: set[int] = field(default_factory=set)
    zero_bid: bool = False  # another robot bid 0 on `vertex`


@register
class DynamicTaskAssignmentPartition(Policy):
    """DTAP: SSI auctions over a shared idleness estimate (see module docstring)."""

    name = "dtap"
    description = (
        "Dynamic task assignment with partitioning: sequential single-item auctions (lower bid "
        "wins) for the vertex after the next, over a shared idleness estimate."
    )
    parameters = {
        "initial_estimate": Parameter(
            None,
            "initial idleness estimate E[v] [s]; None = 2 |V|",
            lambda x: x is None or _nonneg(x),
        ),
        "hop_weight": Parameter(2.0, "utility cost per hop, times |V| [s/hop per vertex]", _nonneg),
        "wait_base": Parameter(1.0, "auction wait with no tasks [s]", _nonneg),
        "wait_per_task": Parameter(0.1, "extra auction wait per task held [s]", _nonneg),
        "wait_max": Parameter(3.0, "longest auction wait [s]", _nonneg),
        "threshold_std": Parameter(
            2.0,
            "take a lost adjacent vertex anyway when E > mean(E) + this * std(E) (unitless)",
            _nonneg,
        ),
        "bid_timeout": Parameter(
            120.0, "a recorded bid expires after this [s] (the reference never expires them)", _pos
        ),
    }

    # ------------------------------------------------------------------ state
    def start(self, ctx):
        g = ctx.patrol_map.graph
        n = g.num_vertices
        init = self.params["initial_estimate"]
        self.estimate = SharedEstimate(n, 2.0 * n if init is None else init, ctx.now)
        # views of the graph's one matrix of each (no copy per robot: 8 n^2 bytes each)
        self.hops = travel_hops(ctx.patrol_map)  # directed on one-way lanes
        self.dist = g.distances
        self.bids: dict[int, dict[int, tuple[float, float]]] = {}  # v -> robot -> (bid m, time s)
        self.goal: int | None = None  # the vertex the robot is heading to ("next")
        self.auction: Auction | None = None
        self.me = int(ctx.robot)
        self._holder: dict[int, int] = {}  # vertex -> robot with the lowest bid
        self._mine: set[int] = set()  # my tasks
        self._expired_at = float(ctx.now)
        self._center_cache: tuple[tuple[int, ...], int] = ((), -1)
        self.stats = {"won": 0, "taken_anyway": 0, "lost": 0, "fallback": 0}

    def _ensure(self, ctx):
        if not hasattr(self, "estimate"):
            self.start(ctx)

    def _refresh(self, vertex: int) -> None:
        entries = self.bids.get(vertex)
        if not entries:
            self.bids.pop(vertex, None)
            self._holder.pop(vertex, None)
            self._mine.discard(vertex)
            return
        h = min(entries, key=lambda r: (entries[r][0], r))
        self._holder[vertex] = h
        if h == self.me:
            self._mine.add(vertex)
        else:
            self._mine.discard(vertex)

    def _expire(self, now: float) -> None:
        """Drop bids older than bid_timeout (checked at most every 5 simulated seconds)."""
        if now - self._expired_at < 5.0:
            return
        self._expired_at = now
        limit = float(self.params["bid_timeout"])
        for v in list(self.bids):
            entries = self.bids[v]
            if any(now - t > limit for _, t in entries.values()):
                self.bids[v] = {r: bt for r, bt in entries.items() if now - bt[1] <= limit}
                self._refresh(v)

    def holder(self, vertex: int) -> int | None:
        """Robot with the lowest recorded bid on `vertex` (ties to the lower id), or None."""
        return self._holder.get(vertex)

    def tasks(self, ctx) -> list[int]:
        """Vertices whose lowest recorded (unexpired) bid is mine."""
        self._expire(ctx.now)
        return sorted(self._mine)

    def _record(self, vertex: int, bid: float, robot: int, now: float) -> bool:
        """Record `robot`'s bid on `vertex`; True when it holds the lowest bid."""
        self.bids.setdefault(vertex, {})[int(robot)] = (float(bid), float(now))
        self._refresh(vertex)
        return self.holder(vertex) == robot

    def _forget(self, vertex: int) -> None:
        self.bids.pop(vertex, None)
        self._refresh(vertex)

    def next_next(self, ctx) -> int | None:
        """The vertex after my goal once its auction is over and mine."""
        a = self.auction
        if a is not None and ctx.now >= a.deadline and self.holder(a.vertex) == ctx.robot:
            return a.vertex
        return None

    # ------------------------------------------------------------------ bids and utility
    def bid(self, ctx, vertex: int, here: int) -> float:
        """0 for my next or next-next vertex, else path(v, center) * (1 + |tasks|) [m]; center
        minimises the summed path length to my tasks (`here` when I hold none)."""
        if vertex == self.goal or vertex == self.next_next(ctx):
            return 0.0
        tasks = tuple(t for t in self.tasks(ctx) if t != vertex)
        center = self._center(tasks) if tasks else here
        return float(self.dist[vertex, center] * (1 + len(tasks)))

    def _center(self, tasks: tuple[int, ...]) -> int:
        """The task vertex minimising the summed path length to all tasks (cached)."""
        if self._center_cache[0] != tasks:
            sums = self.dist[np.ix_(tasks, tasks)].sum(axis=1)
            self._center_cache = (tasks, tasks[int(np.argmin(sums))])
        return self._center_cache[1]

    def utility(self, base: int) -> np.ndarray:
        n = self.hops.shape[0]
        return self.estimate.values - self.params["hop_weight"] * self.hops[base] * n

    def wait_time(self, ctx) -> float:
        p = self.params
        return min(p["wait_max"], p["wait_base"] + p["wait_per_task"] * len(self.tasks(ctx)))

    # ------------------------------------------------------------------ auctions
    def _open(self, ctx, base: int, tried: set[int]) -> Auction | None:
        """Auction the best-utility vertex after `base` not yet tried; None when all were."""
        u = self.utility(base)
        cands = [v for v in range(u.size) if v != base and v not in tried]
        if not cands:
            return None
        v = pick_max(cands, u[cands], ctx.rng)
        my_bid = self.bid(ctx, v, base)
        deadline = ctx.now + self.wait_time(ctx)
        self._record(v, my_bid, ctx.robot, ctx.now)
        auction = self.auction = Auction(v, base, my_bid, deadline, set(tried) | {v})
        ctx.send(TaskRequest(ctx.robot, v, my_bid, ctx.now))  # replies may arrive at once
        return auction

    def _resolve(self, ctx, auction: Auction) -> int | None:
        """The auction's vertex when won or taken anyway, else None."""
        v = auction.vertex
        if self.holder(v) in (None, ctx.robot):
            self._record(v, auction.bid, ctx.robot, ctx.now)
            self.stats["won"] += 1
            return v
        e = self.estimate.values
        if (
            v in neighbours(ctx, auction.base)
            and e[v] > e.mean() + self.params["threshold_std"] * e.std()
            and not auction.zero_bid
        ):
            self.stats["taken_anyway"] += 1
            return v
        self.stats["lost"] += 1
        return None

    def _go(self, ctx, here: int, goal: int) -> int:
        """Head to `goal`, announce the estimate, and open the pipelined auction after it."""
        self.goal = goal
        ctx.send(self.estimate.message(ctx.robot, ctx.now, goal))
        self.auction = self._open(ctx, goal, set())
        return goal

    def decide(self, ctx):
        self._ensure(ctx)
        here, now = ctx.current_vertex, ctx.now
        self.estimate.advance(now)
        self.estimate.values[here] = 0.0
        if self.holder(here) == ctx.robot:
            self._forget(here)  # task done
        if self.goal == here:
            self.goal = None
        if self.hops.shape[0] < 2:
            wait_nowhere_to_go(ctx)
            return None
        a = self.auction
        if a is None or a.base != here:
            a = self.auction = self._open(ctx, here, set())
        while True:
            if now < a.deadline:
                ctx.wake_at(a.deadline)
                return None
            winner = self._resolve(ctx, a)
            if winner is not None:
                return self._go(ctx, here, winner)
            nxt = self._open(ctx, here, a.tried)
            if nxt is None:  # every vertex tried: the best-utility neighbour
                self.stats["fallback"] += 1
                nbrs = neighbours(ctx, here)
                u = self.utility(here)
                return self._go(ctx, here, pick_max(nbrs, u[nbrs], ctx.rng))
            a = self.auction = nxt

    def on_goal_failed(self, vertex, ctx):
        self._ensure(ctx)
        self.auction = None
        self.goal = None

    # ------------------------------------------------------------------ messages
    def on_message(self, message, ctx):
        self._ensure(ctx)
        if getattr(message, "robot", ctx.robot) == ctx.robot:
            return
        now = ctx.now
        if isinstance(message, IdlenessEstimate):
            self.estimate.merge(message.estimate, message.time, now)
        elif isinstance(message, TaskRequest | TaskBid):
            v = int(message.vertex)
            if not 0 <= v < self.hops.shape[0]:
                return
            if message.bid <= 0 and self.auction is not None and self.auction.vertex == v:
                self.auction.zero_bid = True
            self._record(v, float(message.bid), message.robot, now)
            if isinstance(message, TaskRequest):
                here = self.goal if self.goal is not None else ctx.current_vertex
                mine = self.bid(ctx, v, here)
                if self._record(v, mine, ctx.robot, now):
                    ctx.send(TaskBid(ctx.robot, v, mine, now))
