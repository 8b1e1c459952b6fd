"""Reference tours (not online strategies): the cyclic tour and the k-partition tour (SPEC sec. 5).

- cyclic: one short closed walk through all vertices (a TSP tour on the metric closure of the
  graph, nearest neighbour + 2-opt + Or-opt, expanded into a vertex walk); N robots evenly
  spaced along it. Worst idleness = L / (N v) when some vertex is passed once per lap.
- partition: the graph split into connected parts, each toured (inside its own induced
  subgraph) by its robot(s). Worst idleness = max over parts of L_p / (m_p v).

Both are computed deterministically (no run seed), so every robot of a team gets the same tours.
Idleness figures are analytic, steady state, at speed v [m/s]:
- worst [s]: the longest interval between two visits of any vertex;
- average "time" [s]: mean over vertices of the time average of (t - last visit);
- average "visit" [s]: mean over vertices of the mean interval between consecutive visits.
Visits of one vertex at the same instant (two robots) count once.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import tpuaf_core

_EPS = 1e-9


# ---------------------------------------------------------------- TSP on a distance matrix


def _order_length(dist: np.ndarray, order: list[int]) -> float:
    if len(order) < 2:
        return 0.0
    idx = np.asarray(order)
    return float(dist[idx, np.roll(idx, -1)].sum())


def _nearest_neighbour(dist: np.ndarray, start: int) -> list[int]:
    n = dist.shape[0]
    unvisited = np.ones(n, dtype=bool)
    unvisited[start] = False
    order = [start]
    for _ in range(n - 1):
        row = np.where(unvisited, dist[order[-1]], np.inf)
        nxt = int(np.argmin(row))
        order.append(nxt)
        unvisited[nxt] = False
    return order


def _two_opt(dist: np.ndarray, order: list[int]) -> bool:
    """Best-improvement 2-opt passes until none improves; True when something changed."""
    n = len(order)
    changed = False
    if n < 4:
        return False
    while True:
        idx = np.asarray(order)
        best_delta, best = -_EPS, None
        for i in range(n - 2):
            a, b = idx[i], idx[i + 1]
            js = np.arange(i + 2, n if i > 0 else n - 1)
            if js.size == 0:
                continue
            c, d = idx[js], idx[(js + 1) % n]
            delta = dist[a, c] + dist[b, d] - dist[a, b] - dist[c, d]
            k = int(np.argmin(delta))
            if delta[k] < best_delta:
                best_delta, best = float(delta[k]), (i, int(js[k]))
        if best is None:
            return changed
        i, j = best
        order[i + 1 : j + 1] = order[i + 1 : j + 1][::-1]
        changed = True


def _or_opt(dist: np.ndarray, order: list[int]) -> bool:
    """Move a segment of 1-3 vertices (maybe reversed) elsewhere; first improvement."""
    n = len(order)
    changed = False
    improved = True
    while improved:
        improved = False
        for seg_len in (1, 2, 3):
            if n < seg_len + 3:
                continue
            for i in range(n):
                rot = order[i:] + order[:i]
                seg, rest = rot[:seg_len], rot[seg_len:]
                prev, nxt = rest[-1], rest[0]
                gain = dist[prev, seg[0]] + dist[seg[-1], nxt] - dist[prev, nxt]
                r = np.asarray(rest)
                a, b = r[:-1], r[1:]
                fwd = dist[a, seg[0]] + dist[seg[-1], b] - dist[a, b]
                rev = dist[a, seg[-1]] + dist[seg[0], b] - dist[a, b]
                kf, kr = int(np.argmin(fwd)), int(np.argmin(rev))
                if min(fwd[kf], rev[kr]) < gain - _EPS:
                    if fwd[kf] <= rev[kr]:
                        k, ins = kf, seg
                    else:
                        k, ins = kr, seg[::-1]
                    order[:] = rest[: k + 1] + ins + rest[k + 1 :]
                    improved = changed = True
                    break
            if improved:
                break
    return changed


def _local_search(dist: np.ndarray, order: list[int]) -> list[int]:
    order = list(order)
    while True:
        a = _two_opt(dist, order)
        b = _or_opt(dist, order)
        if not (a or b):
            return order


def _double_bridge(order: list[int], rng: np.random.Generator) -> list[int]:
    n = len(order)
    i, j, k = sorted(rng.choice(np.arange(1, n), size=3, replace=False))
    return order[:i] + order[j:k] + order[i:j] + order[k:]


def tsp_order(dist: np.ndarray, starts: int = 12, kicks: int = 30) -> list[int]:
    """A short cyclic order of all rows of the symmetric metric `dist` (indices 0..k-1).

    Nearest neighbour from up to `starts` start vertices, each improved by 2-opt + Or-opt,
    then `kicks` double-bridge perturbations of the best (iterated local search, fixed seed).
    """
    dist = np.asarray(dist, dtype=float)
    n = dist.shape[0]
    if n <= 3:
        return list(range(n))
    best, best_len = None, np.inf
    for s in np.linspace(0, n - 1, min(starts, n)).astype(int):
        cand = _local_search(dist, _nearest_neighbour(dist, int(s)))
        length = _order_length(dist, cand)
        if length < best_len - _EPS:
            best, best_len = cand, length
    if n >= 8:
        rng = np.random.default_rng(12345)  # fixed: tours must be identical for every robot
        for _ in range(kicks):
            cand = _local_search(dist, _double_bridge(best, rng))
            length = _order_length(dist, cand)
            if length < best_len - _EPS:
                best, best_len = cand, length
    return best


# ---------------------------------------------------------------- walks and their idleness


def _adjacency(graph: Any) -> dict[int, dict[int, float]]:
    adj: dict[int, dict[int, float]] = {v: {} for v in range(graph.num_vertices)}
    for u, v, length in graph.edges:
        if u == v:
            continue
        old = adj[u].get(v, np.inf)
        adj[u][v] = adj[v][u] = min(old, float(length))
    return adj


def _arcs(adj: dict[int, dict[int, float]]) -> tuple[list[int], list[int], list[float]]:
    """Directed arcs (tails, heads, lengths [m]) of an adjacency, for tpuaf_core.dijkstra."""
    tails, heads, weights = [], [], []
    for u, nbrs in adj.items():
        for w, c in nbrs.items():
            tails.append(u)
            heads.append(w)
            weights.append(c)
    return tails, heads, weights


def _dijkstra(arcs, n: int, source: int, allowed: set[int]) -> tuple[dict, dict]:
    """Shortest paths from `source` inside `allowed` (the core's search): reached vertices'
    distances [m] and parents."""
    mask = [v in allowed for v in range(n)]
    dist, parent, _ = tpuaf_core.dijkstra(n, *arcs, [source], -_EPS, mask)
    reached = {v: d for v, d in enumerate(dist) if d < np.inf}
    return reached, {v: p for v, p in enumerate(parent) if p >= 0}


def closed_walk(
    graph: Any, vertices: list[int], adj=None, starts: int = 12, kicks: int = 30
) -> tuple[list[int], float]:
    """Shortest closed walk found through `vertices`, moving only inside them (their induced
    subgraph, which must be connected). Returns (walk without the repeated first vertex, length m)."""
    vertices = sorted(set(int(v) for v in vertices))
    if len(vertices) == 1:
        return vertices, 0.0
    adj = adj if adj is not None else _adjacency(graph)
    allowed = set(vertices)
    k = len(vertices)
    dist = np.zeros((k, k))
    prevs = []
    arcs = _arcs(adj)
    for a, va in enumerate(vertices):
        d, prev = _dijkstra(arcs, graph.num_vertices, va, allowed)
        if len(d) < k:
            raise ValueError(f"vertex set {vertices} is not connected")
        dist[a] = [d[vb] for vb in vertices]
        prevs.append(prev)
    order = tsp_order(dist, starts, kicks)
    walk: list[int] = []
    for i, a in enumerate(order):
        b = order[(i + 1) % k]
        # path vertices[a] -> vertices[b] from the predecessor tree of vertices[a]
        target, src, prev = vertices[b], vertices[a], prevs[a]
        seg = [target]
        while seg[-1] != src:
            seg.append(prev[seg[-1]])
        walk.extend(reversed(seg[1:]))  # src .. before target
    return walk, _order_length(dist, order)


def walk_length(graph: Any, walk: list[int]) -> float:
    """Length [m] of the closed walk (edges between consecutive entries, and last -> first)."""
    if len(walk) < 2:
        return 0.0
    return float(
        sum(graph.edge_length(walk[i], walk[(i + 1) % len(walk)]) for i in range(len(walk)))
    )


def walk_idleness(
    graph: Any, walk: list[int], n_robots: int, speed: float
) -> dict[str, float | dict[int, float]]:
    """Steady-state idleness [s] of the walk's vertices with `n_robots` evenly spaced at `speed`."""
    length = walk_length(graph, walk)
    if length <= 0.0 or n_robots < 1:
        zeros = {int(v): 0.0 for v in walk}
        return {"worst": 0.0, "avg_time": 0.0, "avg_visit": 0.0, "per_vertex_worst": zeros}
    spacing = length / n_robots  # [m] between robots
    period = spacing / speed  # [s] the visit pattern repeats with this period
    arc: dict[int, list[float]] = {}
    s = 0.0
    for i, v in enumerate(walk):
        arc.setdefault(int(v), []).append(s % spacing)
        s += graph.edge_length(walk[i], walk[(i + 1) % len(walk)])
    worst, avg_time, avg_visit, per_vertex = 0.0, [], [], {}
    for v, positions in arc.items():
        times = np.unique(np.round(np.asarray(positions) / speed, 9))
        gaps = np.diff(np.append(times, times[0] + period))
        per_vertex[v] = float(gaps.max())
        worst = max(worst, per_vertex[v])
        avg_time.append(float((gaps**2).sum() / (2.0 * period)))
        avg_visit.append(float(period / len(times)))
    return {
        "worst": worst,
        "avg_time": float(np.mean(avg_time)),
        "avg_visit": float(np.mean(avg_visit)),
        "per_vertex_worst": per_vertex,
    }


# ---------------------------------------------------------------- tours


@dataclass
class Tour:
    """A closed walk (vertex indices, first vertex not repeated) and its length [m]."""

    walk: list[int]
    length: float


@dataclass
class Partition:
    """Connected parts, each with its closed walk, and how many robots tour each part."""

    parts: list[list[int]]
    tours: list[Tour]
    robots_per_part: list[int] = field(default_factory=list)

    def part_of(self, vertex: int) -> int:
        for p, part in enumerate(self.parts):
            if vertex in part:
                return p
        raise KeyError(vertex)


_CACHE: OrderedDict[tuple, Any] = OrderedDict()


def _cached(key: tuple, patrol_map: Any, compute):
    full = (id(patrol_map),) + key
    hit = _CACHE.get(full)
    if hit is not None and hit[0] is patrol_map:
        _CACHE.move_to_end(full)
        return hit[1]
    value = compute()
    _CACHE[full] = (patrol_map, value)  # holding the map keeps its id unique
    while len(_CACHE) > 32:
        _CACHE.popitem(last=False)
    return value


def cyclic_tour(patrol_map: Any) -> Tour:
    """Shortest closed walk found through all vertices (cached per map object)."""

    def compute() -> Tour:
        graph = patrol_map.graph
        walk, length = closed_walk(graph, list(range(graph.num_vertices)))
        return Tour(walk, length)

    return _cached(("cyclic",), patrol_map, compute)


def _voronoi(adj, seeds: list[int], n: int) -> list[int]:
    """Multi-source search (the core's): each vertex to its nearest seed (parts come out
    connected); nearly equal paths compete, the settling order (distance, seed) decides."""
    _, _, owner = tpuaf_core.dijkstra(n, *_arcs(adj), list(seeds), _EPS)
    return list(owner)


def _connected(adj, vertices: set[int]) -> bool:
    if not vertices:
        return False
    start = next(iter(vertices))
    seen, stack = {start}, [start]
    while stack:
        u = stack.pop()
        for w in adj[u]:
            if w in vertices and w not in seen:
                seen.add(w)
                stack.append(w)
    return len(seen) == len(vertices)


def robots_per_part(lengths: list[float], n_robots: int) -> list[int]:
    """One robot per part, extra robots to the part with the largest L_p / m_p."""
    m = [1] * len(lengths)
    for _ in range(n_robots - len(lengths)):
        worst = int(np.argmax([length / k for length, k in zip(lengths, m, strict=True)]))
        m[worst] += 1
    return m


def _balanced_partition(graph: Any, k: int, max_moves: int) -> list[list[int]]:
    n = graph.num_vertices
    adj = _adjacency(graph)
    dist = np.asarray(graph.distances)
    tour_cache: dict[frozenset, float] = {}

    def cost(part: set[int]) -> float:
        key = frozenset(part)
        if key not in tour_cache:
            tour_cache[key] = closed_walk(graph, sorted(part), adj, starts=3, kicks=4)[1]
        return tour_cache[key]

    best_parts, best_cost = None, np.inf
    first_seeds = sorted({int(np.argmax(dist.sum(axis=1))), int(np.argmin(dist.sum(axis=1))), 0})
    for first in first_seeds:
        seeds = [first]
        while len(seeds) < k:  # farthest-point seeding
            seeds.append(int(np.argmax(dist[seeds].min(axis=0))))
        owner = _voronoi(adj, seeds, n)
        parts = [{v for v in range(n) if owner[v] == p} for p in range(k)]
        costs = [cost(p) for p in parts]
        for _ in range(max_moves):
            p = int(np.argmax(costs))
            best_move, best_max = None, costs[p] - 1e-6
            for u in sorted(parts[p]):
                if len(parts[p]) == 1 or not _connected(adj, parts[p] - {u}):
                    continue
                for q in sorted({owner[w] for w in adj[u]} - {p}):
                    new_p, new_q = cost(parts[p] - {u}), cost(parts[q] | {u})
                    new_max = max(new_p, new_q)
                    if new_max < best_max:
                        best_move, best_max = (u, q, new_p, new_q), new_max
            if best_move is None:
                break
            u, q, new_p, new_q = best_move
            parts[p].discard(u)
            parts[q].add(u)
            owner[u] = q
            costs[p], costs[q] = new_p, new_q
        if max(costs) < best_cost - _EPS:
            best_parts, best_cost = [sorted(part) for part in parts], max(costs)
    return best_parts


def partition_tours(patrol_map: Any, n_robots: int, max_moves: int = 400) -> Partition:
    """min(N, |V|) connected parts balanced by tour length; each part's closed walk (cached)."""
    if n_robots < 1:
        raise ValueError(f"n_robots must be >= 1, got {n_robots}")

    def compute() -> Partition:
        graph = patrol_map.graph
        k = min(n_robots, graph.num_vertices)
        adj = _adjacency(graph)
        parts = _balanced_partition(graph, k, max_moves)
        tours = [Tour(*closed_walk(graph, part, adj)) for part in parts]
        return Partition(parts, tours, robots_per_part([t.length for t in tours], n_robots))

    return _cached(("partition", n_robots, max_moves), patrol_map, compute)


def assign_parts(
    partition: Partition, start_vertices: list[int], distances: np.ndarray
) -> list[int]:
    """Part index per robot: minimum total distance from the robots' start vertices to their
    parts, each part getting its `robots_per_part` robots (Hungarian assignment)."""
    from scipy.optimize import linear_sum_assignment

    slots = [p for p, m in enumerate(partition.robots_per_part) for _ in range(m)]
    dist = np.asarray(distances)
    cost = np.array([[dist[s, partition.parts[p]].min() for p in slots] for s in start_vertices])
    rows, cols = linear_sum_assignment(cost)
    out = [0] * len(start_vertices)
    for r, c in zip(rows, cols, strict=True):
        out[r] = slots[c]
    return out


def reference_tours(patrol_map: Any, n_robots: int, speed: float) -> dict[str, Any]:
    """Both reference tours at `speed` [m/s] with `n_robots`, and which has the lower worst idleness.

    Vertices are reported as the map's vertex ids.
    """
    if speed <= 0:
        raise ValueError(f"speed must be > 0 m/s, got {speed}")
    graph = patrol_map.graph
    ids = [int(v) for v in patrol_map.vertex_ids]
    cyc = cyclic_tour(patrol_map)
    c_idl = walk_idleness(graph, cyc.walk, n_robots, speed)
    part = partition_tours(patrol_map, n_robots)
    per_part = [
        walk_idleness(graph, t.walk, m, speed)
        for t, m in zip(part.tours, part.robots_per_part, strict=True)
    ]
    n = graph.num_vertices
    p_time = sum(pi["avg_time"] * len(p) for pi, p in zip(per_part, part.parts, strict=True)) / n
    p_visit = sum(pi["avg_visit"] * len(p) for pi, p in zip(per_part, part.parts, strict=True)) / n
    cyclic = {
        "walk": [ids[v] for v in cyc.walk],
        "length_m": cyc.length,
        "worst_idleness_s": c_idl["worst"],
        "avg_idleness_time_s": c_idl["avg_time"],
        "avg_idleness_visit_s": c_idl["avg_visit"],
    }
    partition = {
        "parts": [[ids[v] for v in p] for p in part.parts],
        "walks": [[ids[v] for v in t.walk] for t in part.tours],
        "lengths_m": [t.length for t in part.tours],
        "robots_per_part": list(part.robots_per_part),
        "worst_idleness_s": max(pi["worst"] for pi in per_part),
        "avg_idleness_time_s": p_time,
        "avg_idleness_visit_s": p_visit,
    }
    better = (
        "partition"
        if partition["worst_idleness_s"] < cyclic["worst_idleness_s"] - 1e-9
        else "cyclic"
    )
    return {
        "map": patrol_map.name,
        "n_robots": n_robots,
        "speed_mps": speed,
        "cyclic": cyclic,
        "partition": partition,
        "better": better,
        "best_worst_idleness_s": min(cyclic["worst_idleness_s"], partition["worst_idleness_s"]),
    }
