"""One-way lanes: a traffic orientation of the lanes that lie on cycles (ROS-free; docs/LANES.md).

A lane (navigation/lanes.py) is a chain of edges one robot wide. Driven one way, two robots in it
never meet head-on: they only follow each other. A lane can be made one-way when it lies on a
cycle of the graph (its edges are no bridges: Robbins' theorem gives a strongly connected
orientation of a 2-edge-connected graph); a lane that is a bridge (a dead end, a corridor to a
part of the map reached no other way) stays two-way and keeps its lock (team/lane_locks.py).

Among the orientations whose directed graph is strongly connected (every vertex can drive to
every other), `orient_lanes` picks the one of the least summed directed shortest-path length
over all ordered vertex pairs [m]: every orientation when there are at most `EXHAUSTIVE_LANES`
orientable lanes, else a depth-first orientation (strongly connected by Robbins' construction)
improved by single-lane flips, at most `MAX_FLIP_ROUNDS` rounds.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import shortest_path

EXHAUSTIVE_LANES = 12  # try all 2^k orientations up to this many orientable lanes
MAX_FLIP_ROUNDS = 20  # rounds of single-lane flips (each tries every lane once) beyond that


@dataclass(frozen=True)
class Orientation:
    """The traffic orientation: each one-way lane's vertices in driving order, the arcs (u, v)
    they give, the lanes that stay two-way with locks, and the summed directed distance [m]."""

    chains: dict[int, tuple[int, ...]]  # lane index -> its vertices in the driving order
    locked: frozenset[int]  # lanes that are bridges: two-way, entered holding the lock
    total_m: float  # [m] sum of directed shortest paths over ordered vertex pairs
    two_way_total_m: float  # [m] the same with every edge both ways (the cost of one-way)

    @property
    def arcs(self) -> list[tuple[int, int]]:
        """The one-way arcs (u, v) by vertex index: u -> v only."""
        return [arc for chain in self.chains.values() for arc in zip(chain[:-1], chain[1:],
                                                                     strict=True)]

    def describe(self, ids) -> list[str]:
        """One line per lane, vertices by their map ids."""
        out = [f"lane {k}: one-way " + " -> ".join(str(ids[v]) for v in chain)
               for k, chain in sorted(self.chains.items())]
        out += [f"lane {k}: two-way, locked (a bridge: no cycle through it)"
                for k in sorted(self.locked)]
        if self.two_way_total_m > 0:
            out.append(f"directed travel over all vertex pairs: {self.total_m:.1f} m, "
                       f"{self.total_m / self.two_way_total_m:.2f}x two-way")
        return out


def bridges(n_vertices: int, edges) -> set[tuple[int, int]]:
    """The bridges (u < v) of an undirected graph: edges on no cycle (Tarjan's low-link, with
    an explicit stack)."""
    adj: list[list[tuple[int, int]]] = [[] for _ in range(n_vertices)]
    for k, (u, v) in enumerate(edges):
        adj[u].append((v, k))
        adj[v].append((u, k))
    order = [-1] * n_vertices
    low = [0] * n_vertices
    out: set[tuple[int, int]] = set()
    counter = 0
    for root in range(n_vertices):
        if order[root] >= 0:
            continue
        order[root] = low[root] = counter
        counter += 1
        stack = [(root, -1, iter(adj[root]))]
        while stack:
            v, via, it = stack[-1]
            step = next(it, None)
            if step is None:
                stack.pop()
                if stack:
                    parent = stack[-1][0]
                    low[parent] = min(low[parent], low[v])
                    if low[v] > order[parent]:
                        out.add((min(parent, v), max(parent, v)))
                continue
            w, k = step
            if k == via:
                continue
            if order[w] < 0:
                order[w] = low[w] = counter
                counter += 1
                stack.append((w, k, iter(adj[w])))
            else:
                low[v] = min(low[v], order[w])
    return out


def lane_chain(lane) -> tuple[int, ...]:
    """A lane's vertices in order along its edges, from a waiting spot (or anywhere on a ring)."""
    adj: dict[int, list[int]] = {}
    for u, v in lane.edges:
        adj.setdefault(u, []).append(v)
        adj.setdefault(v, []).append(u)
    start = lane.spots[0] if lane.spots else lane.edges[0][0]
    chain, prev = [start], None
    while True:
        nxt = [w for w in adj[chain[-1]] if w != prev]
        if not nxt or (len(chain) > 1 and chain[-1] in lane.spots):
            break
        prev = chain[-1]
        chain.append(nxt[0])
        if chain[-1] == start:  # a ring
            break
    return tuple(chain)


def _distances(n: int, lengths: dict[tuple[int, int], float],
               arcs: dict[tuple[int, int], bool]) -> np.ndarray:
    """Directed all-pairs shortest paths [m]: every edge both ways unless `arcs` says (u, v)
    is one-way (True: u -> v only; keys u < v)."""
    rows, cols, data = [], [], []
    for (u, v), length in lengths.items():
        direction = arcs.get((u, v))
        if direction is None or direction:
            rows.append(u), cols.append(v), data.append(length)
        if direction is None or not direction:
            rows.append(v), cols.append(u), data.append(length)
    matrix = csr_matrix((data, (rows, cols)), shape=(n, n))
    return shortest_path(matrix, method="D", directed=True)


def _cost(n, lengths, chains, flips) -> float:
    arcs: dict[tuple[int, int], bool] = {}
    for chain, flip in zip(chains, flips, strict=True):
        seq = chain[::-1] if flip else chain
        for a, b in zip(seq[:-1], seq[1:], strict=True):
            arcs[(min(a, b), max(a, b))] = a < b
    d = _distances(n, lengths, arcs)
    return float(d.sum()) if np.isfinite(d).all() else math.inf


def _dfs_flips(n, lengths, chains) -> list[bool]:
    """Robbins' construction: orient tree edges away from the root of a depth-first search and
    the others back up; each lane takes the direction of its first edge."""
    adj: list[list[int]] = [[] for _ in range(n)]
    for u, v in lengths:
        adj[u].append(v)
        adj[v].append(u)
    depth = [-1] * n
    depth[0] = 0
    stack = [(0, iter(sorted(adj[0])))]
    down: dict[tuple[int, int], bool] = {}  # (u, v) driven u -> v
    while stack:
        v, it = stack[-1]
        w = next(it, None)
        if w is None:
            stack.pop()
        elif depth[w] < 0:
            depth[w] = depth[v] + 1
            down[(v, w)] = True
            stack.append((w, iter(sorted(adj[w]))))
        elif depth[w] < depth[v] - 1 and (w, v) not in down:
            down[(v, w)] = True  # a back edge, up to an ancestor
    return [(chain[0], chain[1]) not in down for chain in chains]


def _orientable(lane_map, patrol_map) -> tuple[int, dict, list, frozenset[int]]:
    """(vertices, {edge (u < v): length [m]}, the lanes off the bridges, the others' indices)."""
    n = patrol_map.num_vertices
    graph = patrol_map.graph
    lengths = {(min(int(u), int(v)), max(int(u), int(v))): graph.edge_length(int(u), int(v))
               for u, v, _ in patrol_map.edges}
    cut = bridges(n, list(lengths))
    lanes = [lane for lane in lane_map.lanes if lane.edges]  # a blocked lane may have none
    orientable = [lane for lane in lanes if not any(e in cut for e in lane.edges)]
    locked = frozenset(lane.index for lane in lanes if lane not in orientable)
    return n, lengths, orientable, locked


def orient_lanes(lane_map, patrol_map, keep: Orientation | None = None) -> Orientation:
    """The orientation of `lane_map`'s lanes on `patrol_map` (see the module docstring).
    `keep`: an orientation in force (robots drive it now): when driving each of its one-way
    lanes that is still orientable its way, and choosing only the others, gives a strongly
    connected plan, the best such orientation is taken, so that no lane a robot may be in
    changes its direction."""
    n, lengths, orientable, locked = _orientable(lane_map, patrol_map)
    chains = [lane_chain(lane) for lane in orientable]
    two_way = float(_distances(n, lengths, {}).sum())
    kept = _kept_flips(n, lengths, orientable, chains, keep) if keep is not None else None
    if kept is not None:
        best, cost = kept
        return _orientation(orientable, chains, best, locked, cost, two_way)
    if not chains:
        return Orientation({}, locked, two_way, two_way)
    if len(chains) <= EXHAUSTIVE_LANES:
        best = min(itertools.product((False, True), repeat=len(chains)),
                   key=lambda flips: _cost(n, lengths, chains, flips))
        best, cost = list(best), _cost(n, lengths, chains, best)
    else:
        best = _dfs_flips(n, lengths, chains)
        cost = _cost(n, lengths, chains, best)
        for _ in range(MAX_FLIP_ROUNDS):
            improved = False
            for k in range(len(chains)):
                best[k] = not best[k]
                trial = _cost(n, lengths, chains, best)
                if trial < cost - 1e-9:
                    cost, improved = trial, True
                else:
                    best[k] = not best[k]
            if not improved:
                break
    if not math.isfinite(cost):  # cannot happen on lanes off the bridges (Robbins); be safe
        return Orientation({}, frozenset(lane.index for lane in lane_map.lanes), two_way, two_way)
    return _orientation(orientable, chains, best, locked, cost, two_way)


def _orientation(orientable, chains, flips, locked, cost, two_way) -> Orientation:
    """The Orientation of the orientable lanes' chains, each reversed where `flips` says."""
    ordered = {lane.index: (chain[::-1] if flip else chain)
               for lane, chain, flip in zip(orientable, chains, flips, strict=True)}
    return Orientation(ordered, locked, cost, two_way)


def _kept_flips(n, lengths, orientable, chains, keep: Orientation):
    """(flips, cost) of the best orientation driving `keep`'s one-way lanes its way where they
    are still orientable, None when that is not strongly connected (or too many lanes are
    free to try them all)."""
    fixed = {}  # position in chains -> flip that drives it as `keep` does
    for k, (lane, chain) in enumerate(zip(orientable, chains, strict=True)):
        old = keep.chains.get(lane.index)
        if old is not None and set(old) == set(chain):
            fixed[k] = tuple(old) != tuple(chain)
    free = [k for k in range(len(chains)) if k not in fixed]
    if not chains or len(free) > EXHAUSTIVE_LANES:
        return None
    best, cost = None, math.inf
    for choice in itertools.product((False, True), repeat=len(free)):
        flips = [fixed.get(k, False) for k in range(len(chains))]
        for k, flip in zip(free, choice, strict=True):
            flips[k] = flip
        trial = _cost(n, lengths, chains, flips)
        if trial < cost:
            best, cost = flips, trial
    return (best, cost) if best is not None and math.isfinite(cost) else None
