"""Reference tours (not online strategies): the cyclic tour and the k-partition tour (SPEC sec. 5).

- cyclic: one short closed walk through all vertices (a TSP tour on the metric closure of the
  graph, nearest neighbour + 2-opt + Or-opt with kicks, expanded into a vertex walk); N robots evenly
  spaced along it. Worst idleness = L / (N v) when some vertex is passed once per lap.
- partition: the graph split into connected parts, each toured (inside its own induced
  subgraph) by its robot(s). Worst idleness = max over parts of L_p / (m_p v).

The searches run in the C++ core (tpuaf_core/tours.hpp). Both are computed deterministically
(a fixed search seed, no run seed), so every robot of a team gets the same tours; they are
cached per map object, and on disk in $TPUAF_PLAN_CACHE when it names a folder.
Idleness figures are analytic, steady state, at speed v [m/s]:
- worst [s]: the longest interval between two visits of any vertex;
- average "time" [s]: mean over vertices of the time average of (t - last visit);
- average "visit" [s]: mean over vertices of the mean interval between consecutive visits.
Visits of one vertex at the same instant (two robots) count once.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import sys
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import tpuaf_core

from tpuaf.files import atomic_write_text

_EPS = 1e-9


# ---------------------------------------------------------------- search (the C++ core)

# Search effort. The cyclic tour gets many kicks (it is computed once per map); part walks
# scored inside the partition search get few (thousands are scored); final part walks as many
# as the cycle's per vertex. All use the fixed seed: every robot computes the same plan.
SEED = 12345
PART_SCORE = (3, 4)  # (nearest-neighbour starts, kicks) while searching partitions
LARGE_PART = 40  # vertices per part: above, the search scores parts by their spanning tree


DENSE_TOUR_MAX = tpuaf_core.DENSE_TOUR_MAX  # vertices: larger sets toured on lengths on demand
LARGE_KICKS = 0.5  # kicks per vertex of a walk through more than DENSE_TOUR_MAX vertices


def _effort(n_vertices: int) -> tuple[int, int]:
    """(nearest-neighbour starts, kicks) of a walk through `n_vertices`: by size only, so every
    robot agrees. Up to DENSE_TOUR_MAX vertices 12 starts and 10 kicks per vertex; beyond, the
    sparse search (docs/MAPS.md "Big maps"): one start and LARGE_KICKS kicks per vertex."""
    if n_vertices <= DENSE_TOUR_MAX:
        return 12, max(30, 10 * n_vertices)
    return 1, int(LARGE_KICKS * n_vertices)


def _order_length(dist: np.ndarray, order: list[int]) -> float:
    if len(order) < 2:
        return 0.0
    idx = np.asarray(order)
    return float(dist[idx, np.roll(idx, -1)].sum())


def tsp_order(dist: np.ndarray, starts: int = 12, kicks: int = 30) -> list[int]:
    """A short cyclic order of all rows of the symmetric metric `dist` (indices 0..k-1):
    nearest neighbour from up to `starts` start rows, 2-opt + Or-opt on neighbour lists, then
    `kicks` local double-bridge kicks of the best (iterated local search, fixed seed; C++ core)."""
    dist = np.asarray(dist, dtype=float)
    return list(tpuaf_core.tsp_order(dist, starts, kicks, SEED))


class _Progress:
    """Progress of a long plan search on a terminal: one updated stderr line after 2 s."""

    def __init__(self, what: str):
        self.what = what
        self.t0 = time.monotonic()
        self.last = self.t0
        self.shown = False

    def __call__(self, stage: str, done: int, total: int) -> None:
        now = time.monotonic()
        if now - self.t0 < 2.0 or now - self.last < 0.5 or not sys.stderr.isatty():
            return
        self.last, self.shown = now, True
        pct = 100.0 * done / max(total, 1)
        sys.stderr.write(f"\rplanning {self.what}: {stage} {pct:3.0f} % "
                         f"({now - self.t0:.0f} s)")
        sys.stderr.flush()

    def close(self) -> None:
        if self.shown:
            sys.stderr.write("\n")


# ---------------------------------------------------------------- walks and their idleness


def _adjacency(graph: Any) -> dict[int, dict[int, float]]:
    adj: dict[int, dict[int, float]] = {v: {} for v in range(graph.num_vertices)}
    for u, v, length in graph.edges:
        if u == v:
            continue
        old = adj[u].get(v, np.inf)
        adj[u][v] = adj[v][u] = min(old, float(length))
    return adj


def _part_effort(n_graph: int, n_part: int) -> tuple[int, int]:
    """(starts, kicks) of a part's final walk: `_effort`'s, but on graphs of more than
    DENSE_TOUR_MAX vertices 3 starts and 2 kicks per vertex (the longest of 100 part walks of
    a 10,000-vertex building within 0.2 % of 12 starts and 10 kicks per vertex, a third of
    the time)."""
    if n_graph <= DENSE_TOUR_MAX or n_part > DENSE_TOUR_MAX:
        return _effort(n_part)
    return 3, max(30, 2 * n_part)


def closed_walk(
    graph: Any, vertices: list[int], adj=None, starts: int | None = None,
    kicks: int | None = None
) -> tuple[list[int], float]:
    """Shortest closed walk found through `vertices`, moving only inside them (their induced
    subgraph, which must be connected). Returns (walk without the repeated first vertex, length m).
    One vertex: standing on it makes no visit, so its walk drives out to its nearest neighbour
    and back (the one walk that leaves its set).
    Starts and kicks default to `_effort`'s. `adj` is accepted for compatibility (the core reads
    the graph itself)."""
    vertices = sorted(set(int(v) for v in vertices))
    default_starts, default_kicks = _effort(len(vertices))
    starts = default_starts if starts is None else starts
    kicks = default_kicks if kicks is None else kicks
    try:
        walk, length = tpuaf_core.closed_walk(graph, vertices, starts, kicks, SEED)
    except ValueError as e:
        raise ValueError(f"vertex set {vertices} is not connected ({e})") from None
    return list(walk), float(length)


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
CACHE_ENV = "TPUAF_PLAN_CACHE"  # a folder: plans are also kept there, keyed by the map's content
_SEARCH_VERSION = "cpp-4"  # part of the disk key: a changed search never reads old plans


def _content_key(graph: Any, key: tuple) -> str:
    """Hash of what a plan depends on: the graph's vertices and edge lengths, the search."""
    h = hashlib.sha256()
    h.update(f"{_SEARCH_VERSION} {graph.num_vertices} {key!r}".encode())
    for u, v, length in graph.edges:
        h.update(f"{u} {v} {float(length)!r};".encode())
    if graph.one_way:  # one-way arcs change every path (a two-way graph's key is unchanged)
        h.update(f"one-way {list(graph.one_way)!r}".encode())
    return h.hexdigest()[:32]


def _disk_cached(graph: Any, key: tuple, compute, encode, decode):
    folder = os.environ.get(CACHE_ENV)
    if not folder:
        return compute()
    path = Path(folder) / f"plan-{_content_key(graph, key)}.json"
    try:
        return decode(json.loads(path.read_text()))
    except (OSError, ValueError, KeyError, TypeError):
        pass  # missing or unreadable: compute it again
    value = compute()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, json.dumps(encode(value)))
    except OSError:
        pass  # a read-only cache folder only costs the search
    return value


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


def travel_hops(patrol_map: Any) -> np.ndarray:
    """All-pairs hop counts along the arcs a robot may drive (n x n): the graph's own (two-way)
    hop matrix, or on a map with one-way lanes the directed ones, where a vertex one edge away
    can be a loop away (graph.neighbours follows the arcs). Cached per map object: one matrix
    for the whole team."""
    graph = patrol_map.graph
    if not patrol_map.one_way:
        return graph.hop_matrix
    return _cached(("travel_hops",), patrol_map, lambda: _directed_hops(graph))


def _directed_hops(graph: Any) -> np.ndarray:
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import shortest_path

    n = graph.num_vertices
    rows, cols = [], []
    for v in range(n):
        for w in graph.neighbours(v):
            if int(w) != v:
                rows.append(v)
                cols.append(int(w))
    arcs = csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    return shortest_path(arcs, directed=True, unweighted=True).astype(np.int32)


def cyclic_tour(patrol_map: Any) -> Tour:
    """Shortest closed walk found through all vertices (cached per map object, and on disk
    when $TPUAF_PLAN_CACHE names a folder)."""

    def compute() -> Tour:
        graph = patrol_map.graph
        return _disk_cached(
            graph, ("cyclic",),
            lambda: Tour(*closed_walk(graph, list(range(graph.num_vertices)))),
            lambda t: {"walk": t.walk, "length": t.length},
            lambda d: Tour([int(v) for v in d["walk"]], float(d["length"])))

    return _cached(("cyclic",), patrol_map, compute)


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
    return list(tpuaf_core.robots_per_part([float(x) for x in lengths], int(n_robots)))


def default_max_moves(k: int, n_vertices: int) -> int:
    """Vertex moves allowed per seeding of a k-part search: more parts need more moves; large
    parts (each move costs a walk search per boundary vertex) get about their size."""
    moves = max(400, 8 * k)
    if n_vertices > LARGE_PART * k:
        moves = min(moves, 2 * n_vertices // k)
    return moves


def partition_tours(patrol_map: Any, n_robots: int, max_moves: int | None = None,
                    parts: int | None = None) -> Partition:
    """`parts` (default min(N, |V|)) connected parts balanced by tour length, each part's closed
    walk and the robots per part (cached per map object, and on disk when $TPUAF_PLAN_CACHE
    names a folder). The search (C++ core): nearest-seed parts from farthest-point seeds (above
    DENSE_TOUR_MAX vertices: parts grown together to equal spanning-tree lengths), then
    single-vertex moves off the part of the longest walk while that lowers it. With one-way arcs
    the parts are strongly connected and their walks follow the arcs; no parts (an empty
    Partition) when none were found."""
    if n_robots < 1:
        raise ValueError(f"n_robots must be >= 1, got {n_robots}")
    graph = patrol_map.graph
    k = min(n_robots, graph.num_vertices)
    if parts is not None:
        if not 1 <= parts <= k:
            raise ValueError(f"parts must be in 1..{k}, got {parts}")
        k = parts
    moves = default_max_moves(k, graph.num_vertices) if max_moves is None else max_moves
    large = graph.num_vertices > LARGE_PART * k  # parts scored by spanning-tree length

    def search() -> Partition:
        progress = _Progress(f"{k} parts of {graph.num_vertices} vertices")
        try:
            parts = tpuaf_core.balanced_partition(graph, k, moves, *PART_SCORE, SEED, progress,
                                                  large)
        finally:
            progress.close()
        if not parts:  # one-way arcs: no k parts that can each be toured inside themselves
            return Partition([], [], [])
        tours = [Tour(*closed_walk(graph, part, None, *_part_effort(graph.num_vertices, len(part))))
                 for part in parts]
        return Partition(parts, tours, robots_per_part([t.length for t in tours], n_robots))

    key = ("partition", n_robots, moves) + (() if k == min(n_robots, graph.num_vertices) else (k,))

    def compute() -> Partition:
        return _disk_cached(
            graph, key, search,
            lambda p: {"parts": p.parts, "walks": [t.walk for t in p.tours],
                       "lengths": [t.length for t in p.tours], "robots": p.robots_per_part},
            lambda d: Partition([[int(v) for v in q] for q in d["parts"]],
                                [Tour([int(v) for v in w], float(x))
                                 for w, x in zip(d["walks"], d["lengths"], strict=True)],
                                [int(m) for m in d["robots"]]))

    return _cached(key, patrol_map, compute)


def tourable_partition(patrol_map: Any, n_robots: int) -> Partition:
    """partition_tours with the most parts (at most min(N, |V|)) that the one-way arcs let be
    toured each inside itself: one part, the whole strongly connected graph, always can."""
    k = min(n_robots, patrol_map.graph.num_vertices)
    partition = partition_tours(patrol_map, n_robots)
    while not partition.parts and k > 1:
        k -= 1
        partition = partition_tours(patrol_map, n_robots, parts=k)
    return partition


def assign_parts(
    partition: Partition, start_vertices: list[int], distances: np.ndarray
) -> list[int]:
    """Part index per robot: minimum total distance from the robots' start vertices to their
    parts, each part getting its `robots_per_part` robots (Hungarian assignment; the C++ core's
    linear_sum_assignment returns what scipy's does, ties included, without importing scipy)."""
    slots = [p for p, m in enumerate(partition.robots_per_part) for _ in range(m)]
    dist = np.asarray(distances)
    cost = np.array([[dist[s, partition.parts[p]].min() for p in slots] for s in start_vertices])
    rows, cols = tpuaf_core.linear_sum_assignment(cost)
    out = [0] * len(start_vertices)
    for r, c in zip(rows, cols, strict=True):
        out[r] = slots[c]
    return out


def first_coverage_bound(patrol_map: Any, starts: list[int], speed: float) -> float:
    """Lower bound [s] on the time until every vertex has been visited once, for robots leaving
    the vertices `starts` (graph indices) at t = 0 at `speed` [m/s], by any strategy:
    the larger of
    - the farthest vertex from every start: max_v min_r d(start_r, v) / v;
    - the spanning forest: robots' walks from the starts cover the graph, so together they hold
      a forest spanning every vertex with a start in each tree, of length >= the minimum one
      (Kruskal with the starts merged); the longest walk is at least 1/N of it."""
    if speed <= 0:
        raise ValueError(f"speed must be > 0 m/s, got {speed}")
    graph = patrol_map.graph
    n = graph.num_vertices
    walkers = len(starts)  # robots sharing a start vertex still walk apart
    starts = sorted({int(s) for s in starts})
    if not starts or n <= 1:
        return 0.0
    nearest = np.asarray(graph.distances_from(starts[0]), dtype=float)  # rows, not all pairs
    for s in starts[1:]:
        nearest = np.minimum(nearest, graph.distances_from(s))
    farthest = float(nearest.max())
    root = list(range(n))

    def find(v: int) -> int:
        while root[v] != v:
            root[v] = root[root[v]]
            v = root[v]
        return v

    for s in starts[1:]:
        root[find(s)] = find(starts[0])
    forest = 0.0
    for u, v, length in sorted(graph.edges, key=lambda e: (float(e[2]), e[0], e[1])):
        a, b = find(int(u)), find(int(v))
        if a != b:
            root[a] = b
            forest += float(length)
    return max(farthest, forest / walkers) / speed


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
    # No partition (a one-way plan cut into parts no robot can tour): its figures are inf.
    p_time = (sum(pi["avg_time"] * len(p) for pi, p in zip(per_part, part.parts, strict=True))
              / n if per_part else math.inf)
    p_visit = (sum(pi["avg_visit"] * len(p) for pi, p in zip(per_part, part.parts, strict=True))
               / n if per_part else math.inf)
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
        "worst_idleness_s": max((pi["worst"] for pi in per_part), default=math.inf),
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
