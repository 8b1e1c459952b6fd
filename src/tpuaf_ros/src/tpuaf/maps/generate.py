"""A patrol graph generated from an occupancy map (`tpuaf graph`, docs/MAPS.md).

On a work grid of whole map cells (at most MAX_RADIUS_CELLS cells per sensing radius, never
coarser than the robot's clearance, so that no wall vanishes between two drivable cells):
1. drivable space: free cells farther than the robot radius + SAFETY_MARGIN_M from every
   occupied or unknown cell (exact distance transform of the map's own cells); its largest
   connected part is where robots drive;
2. its skeleton (thinning): the candidate targets, kept central; its dead ends are the branches
   longer than SPUR_FACTOR x the clearance at their junction (a corridor's end, not a room's
   corner);
3. targets: the user's fixed points, the dead ends, then greedily the candidate (skeleton, or a
   drivable cell of a lattice) that sees the most free cells not seen yet (line of sight within
   the sensing radius), until `coverage` of the reachable free cells are seen; no two targets
   closer than `min_spacing_m`, nor than a robot's width with the margin. A candidate where
   two robots cannot stand side by side (a doorway) counts NARROW_GAIN_SHARE of the cells it
   sees: a vertex there would make every edge from it a lane one robot wide
   (navigation/lanes.py), corridor and all;
4. edges: pairs of targets whose geodesic Voronoi cells in the drivable space touch, minus an
   edge that a path through a third target, each leg shorter, lengthens by at most DETOUR.
Edge lengths here are geodesic on the work grid; `tpuaf graph` re-plans every edge with the
robot's planner (navigation/planner.py) for its length and free width.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, field

import numpy as np

from tpuaf.errors import MapError
from tpuaf.maps.occupancy import OccupancyGrid
from tpuaf.params import pass_band_m

# [m] added to the robot radius: >= the planner's 0.05 m margin + its coarser planning cells
SAFETY_MARGIN_M = 0.15
MAX_RADIUS_CELLS = 40  # work cells per sensing radius, at most (visibility cost ~ this^2)
SPUR_FACTOR = 2.0  # a skeleton branch shorter than this x its junction's clearance: no dead end
NARROW_GAIN_SHARE = 0.5  # share of its new cells a candidate in a doorway counts (step 3)
SPACING_ROBOT_WIDTHS = 1.0  # targets at least this many robot widths (with margin) apart
DETOUR = 0.25  # an edge is dropped when a 2-edge path via a third target is at most 25 % longer
LATTICE_PER_RADIUS = 3  # extra candidates: drivable cells every r / 3 [m]
MAX_CANDIDATES = 4000  # skeleton candidates kept (evenly thinned beyond)
MAX_WORK_CELLS = 2.5e7  # work grid cells, at most


@dataclass(frozen=True)
class GraphOptions:
    """What `tpuaf graph` generates: units in the names."""

    robot_radius_m: float
    sensing_radius_m: float
    min_spacing_m: float = 0.0  # [m] between two targets
    coverage: float = 1.0  # fraction of the reachable free cells each seen by some target
    fixed: tuple[tuple[float, float], ...] = ()  # [m] user targets, always vertices
    margin_m: float = SAFETY_MARGIN_M

    def check(self) -> None:
        for name in ("robot_radius_m", "sensing_radius_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise MapError(f"{name.replace('_m', '').replace('_', ' ')} must be > 0 m, "
                               f"got {value:g}")
        if not (math.isfinite(self.min_spacing_m) and self.min_spacing_m >= 0):
            raise MapError(f"min spacing must be >= 0 m, got {self.min_spacing_m:g}")
        if not (0.0 < self.coverage <= 1.0):
            raise MapError(f"coverage must be a fraction in (0, 1], got {self.coverage:g}")


@dataclass
class WorkGrid:
    """The map's cells pooled f x f: row 0 at the bottom, as OccupancyGrid."""

    factor: int  # map cells per work cell (each way)
    cell_m: float  # [m] work cell size
    origin: tuple[float, float]  # [m] lower-left corner
    occupied: np.ndarray  # any map cell occupied or unknown (blocks the view)
    drivable: np.ndarray  # some map cell has the robot's clearance (main part only)
    clearance_m: np.ndarray  # [m] best distance to an obstacle of the cell's map cells
    spot: np.ndarray  # (rows, cols, 2) [m] the map cell centre of best clearance
    region: np.ndarray  # free cells connected to the drivable space: what coverage counts
    fine: np.ndarray  # the map's own cells where the robot drives (main part): edges' grid
    fine_m: float  # [m] map cell size

    def cell_of(self, xy) -> tuple[int, int]:
        return (int((xy[1] - self.origin[1]) // self.cell_m),
                int((xy[0] - self.origin[0]) // self.cell_m))


@dataclass
class GeneratedGraph:
    positions: np.ndarray  # (n, 2) [m]
    edges: list[tuple[int, int, float]]  # (i, j, geodesic length [m])
    kinds: list[str]  # per vertex: fixed | dead end | cover
    coverage: float  # fraction of the reachable free cells seen
    covered: np.ndarray  # work-grid mask of the cells seen
    grid: WorkGrid
    notes: list[str] = field(default_factory=list)


# ------------------------------------------------------------------------------ work grid


def _pool(a: np.ndarray, f: int, fill, how: str) -> np.ndarray:
    rows, cols = -(-a.shape[0] // f), -(-a.shape[1] // f)
    padded = np.full((rows * f, cols * f), fill, dtype=a.dtype)
    padded[:a.shape[0], :a.shape[1]] = a
    blocks = padded.reshape(rows, f, cols, f).swapaxes(1, 2).reshape(rows, cols, f * f)
    return getattr(blocks, how)(axis=2)


def work_grid(occ: OccupancyGrid, opts: GraphOptions) -> WorkGrid:
    """The pooled grid and the drivable space (MapError when a robot fits nowhere)."""
    from scipy import ndimage

    res = float(occ.resolution)
    clearance = opts.robot_radius_m + opts.margin_m  # [m]
    f = max(1, min(math.ceil(opts.sensing_radius_m / (MAX_RADIUS_CELLS * res)),
                   math.floor(clearance / res)))
    f = max(f, math.ceil(math.sqrt(occ.width * occ.height / MAX_WORK_CELLS)))
    free = ~occ.occupied
    if not free.any():
        raise MapError(f"{occ.source or 'map'}: the image has no free cell")
    edt = ndimage.distance_transform_edt(np.pad(free, 1))[1:-1, 1:-1] * res  # [m]
    labels, count = ndimage.label(edt > clearance, structure=np.ones((3, 3)))
    if count == 0:
        raise MapError(f"{occ.source or 'map'}: no free space where a robot of radius "
                       f"{opts.robot_radius_m:g} m (+ {opts.margin_m:g} m margin) fits")
    fine = labels == int(np.argmax(np.bincount(labels.ravel())[1:])) + 1
    del labels
    occupied = _pool(occ.occupied, f, True, "any")
    main = np.where(fine, edt, -1.0)  # [m] clearance of the main part's cells
    best = _pool(main, f, -1.0, "max")
    arg = _pool(main, f, -1.0, "argmax")
    rows, cols = np.indices(best.shape)
    spot = np.stack([occ.origin[0] + (cols * f + arg % f + 0.5) * res,
                     occ.origin[1] + (rows * f + arg // f + 0.5) * res], axis=-1)
    drivable = best > clearance
    free_labels, _ = ndimage.label(~occupied, structure=np.ones((3, 3)))
    reached = np.unique(free_labels[drivable & ~occupied])
    region = np.isin(free_labels, reached[reached > 0])
    return WorkGrid(f, f * res, (float(occ.origin[0]), float(occ.origin[1])), occupied,
                    drivable, best, spot, region, fine, res)


# ------------------------------------------------------------------------------ skeleton


def _shifts(img: np.ndarray) -> list[np.ndarray]:
    """The 8 neighbours P2..P9 (N, NE, E, SE, S, SW, W, NW) of every cell (0 outside)."""
    p = np.pad(img, 1)
    h, w = img.shape
    offsets = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1)]
    return [p[1 + dr:1 + dr + h, 1 + dc:1 + dc + w] for dr, dc in offsets]


def thin(mask: np.ndarray) -> np.ndarray:
    """A one-cell skeleton of `mask` (Zhang-Suen thinning, vectorised)."""
    img = mask.astype(np.uint8)
    changed = True
    while changed:
        changed = False
        for step in (0, 1):
            n = _shifts(img)
            count = sum(n)
            ring = n + [n[0]]
            transitions = sum(((ring[k] == 0) & (ring[k + 1] == 1)).astype(np.uint8)
                              for k in range(8))
            p2, p4, p6, p8 = n[0], n[2], n[4], n[6]
            if step == 0:
                side = (p2 * p4 * p6 == 0) & (p4 * p6 * p8 == 0)
            else:
                side = (p2 * p4 * p8 == 0) & (p2 * p6 * p8 == 0)
            drop = (img == 1) & (count >= 2) & (count <= 6) & (transitions == 1) & side
            if drop.any():
                img[drop] = 0
                changed = True
    return img.astype(bool)


def _branches(img: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(neighbour count, crossing number: separate neighbour groups) of every cell."""
    n = _shifts(img.astype(np.uint8))
    ring = n + [n[0]]
    crossings = sum(((ring[k] == 0) & (ring[k + 1] == 1)).astype(np.uint8) for k in range(8))
    return sum(n), crossings


def dead_ends(skeleton: np.ndarray, grid: WorkGrid) -> list[tuple[int, int]]:
    """Skeleton end cells whose branch (to the first junction: 3 or more neighbour groups) is
    longer than SPUR_FACTOR x the clearance [m] at that junction; a branch without junction
    (a lone corridor) counts."""
    count, crossings = _branches(skeleton)
    ends = np.argwhere(skeleton & (crossings == 1) & (count <= 2))
    h, w = skeleton.shape
    out = []
    for r0, c0 in ends:
        cur, length, visited, junction = (int(r0), int(c0)), 0.0, set(), False
        while True:
            visited.add(cur)
            if crossings[cur] >= 3:
                junction = True
                break
            nxt = sorted((abs(dr) + abs(dc), (cur[0] + dr, cur[1] + dc))
                         for dr in (-1, 0, 1) for dc in (-1, 0, 1)
                         if 0 <= cur[0] + dr < h and 0 <= cur[1] + dc < w
                         and skeleton[cur[0] + dr, cur[1] + dc]
                         and (cur[0] + dr, cur[1] + dc) not in visited)
            if not nxt:
                break
            step = nxt[0][1]
            length += grid.cell_m * math.hypot(step[0] - cur[0], step[1] - cur[1])
            cur = step
        if not junction or length > SPUR_FACTOR * float(grid.clearance_m[cur]):
            out.append((int(r0), int(c0)))
    return out


# ------------------------------------------------------------------------------ visibility


def visible_cells(grid: WorkGrid, xy, radius_m: float) -> np.ndarray:
    """Flat indices of the work cells seen from `xy` [m]: along rays every half cell, within
    `radius_m`, up to the first occupied cell."""
    h, w = grid.occupied.shape
    reach = radius_m / grid.cell_m  # [cells]
    rays = max(64, int(math.ceil(2.0 * math.pi * reach * 1.2)))
    angles = np.linspace(0.0, 2.0 * math.pi, rays, endpoint=False)
    steps = np.arange(0.0, reach + 1e-9, 0.5)
    x = (xy[0] - grid.origin[0]) / grid.cell_m + np.cos(angles)[:, None] * steps
    y = (xy[1] - grid.origin[1]) / grid.cell_m + np.sin(angles)[:, None] * steps
    c, r = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    inside = (r >= 0) & (r < h) & (c >= 0) & (c < w)
    blocked = ~inside
    blocked[inside] = grid.occupied[r[inside], c[inside]]
    seen = ~np.logical_or.accumulate(blocked, axis=1)
    return np.unique(r[seen] * w + c[seen])


def coverage_of(grid: WorkGrid, positions, radius_m: float) -> tuple[float, np.ndarray]:
    """(fraction of the reachable free cells seen from some of `positions` [m], the mask)."""
    covered = np.zeros(grid.occupied.size, dtype=bool)
    for xy in np.asarray(positions, dtype=float).reshape(-1, 2):
        covered[visible_cells(grid, xy, radius_m)] = True
    covered = covered.reshape(grid.occupied.shape) & grid.region
    return float(covered.sum()) / max(1, int(grid.region.sum())), covered


# ------------------------------------------------------------------------------ targets


def _candidates(grid: WorkGrid, skeleton: np.ndarray, radius_m: float
                ) -> tuple[np.ndarray, int]:
    """(k, 2) work cells: the skeleton's (evenly thinned) first, then a lattice of drivable
    cells; and how many are the skeleton's."""
    skel = np.argwhere(skeleton)
    if len(skel) > MAX_CANDIDATES:
        skel = skel[np.linspace(0, len(skel) - 1, MAX_CANDIDATES).astype(int)]
    step = max(1, int(radius_m / LATTICE_PER_RADIUS / grid.cell_m))
    lattice = np.zeros_like(grid.drivable)
    lattice[::step, ::step] = True
    extra = np.argwhere(lattice & grid.drivable & ~skeleton)
    return np.vstack([skel, extra]).astype(np.int64), len(skel)


def _fixed_cells(grid: WorkGrid, fixed, opts: GraphOptions) -> list[tuple[int, int]]:
    out = []
    h, w = grid.fine.shape
    for x, y in fixed:
        r = int((y - grid.origin[1]) // grid.fine_m)
        c = int((x - grid.origin[0]) // grid.fine_m)
        if not (0 <= r < h and 0 <= c < w and grid.fine[r, c]):
            raise MapError(f"fixed target ({x:g}, {y:g}) m is not where a robot of radius "
                           f"{opts.robot_radius_m:g} m can drive (outside the map, too near a "
                           "wall, or cut off from the main free space)")
        if (r, c) in out:
            raise MapError(f"fixed target ({x:g}, {y:g}) m is on the map cell of an earlier one")
        out.append((r, c))
    return out


def choose_targets(grid: WorkGrid, skeleton: np.ndarray, opts: GraphOptions
                   ) -> tuple[list[np.ndarray], list[str], np.ndarray]:
    """Target positions [m] and their kinds, and the covered mask (flat)."""
    radius = opts.sensing_radius_m
    spot = grid.spot
    targets: list[np.ndarray] = []
    kinds: list[str] = []
    covered = np.zeros(grid.occupied.size, dtype=bool)
    region = grid.region.ravel()
    goal = opts.coverage * max(1, int(region.sum()))

    # [m] never two in one cell, nor closer than a robot's width (radius + margin, twice): a
    # robot on one would stand on the other (the greedy's tail takes slivers at the sensing
    # radius's rim from spots a few centimetres apart)
    spacing = max(opts.min_spacing_m, 2.0 * grid.cell_m,
                  SPACING_ROBOT_WIDTHS * 2.0 * (opts.robot_radius_m + opts.margin_m))

    def far_enough(xy) -> bool:
        return all(math.dist(xy, t) >= spacing for t in targets)

    def take(xy, kind: str) -> None:
        targets.append(np.asarray(xy, dtype=float))
        kinds.append(kind)
        covered[visible_cells(grid, xy, radius)] = True

    for x, y in opts.fixed:  # exactly where the user put them
        take((x, y), "fixed")
    for r, c in dead_ends(skeleton, grid):
        if far_enough(spot[r, c]):
            take(spot[r, c], "dead end")
    cells, on_skeleton = _candidates(grid, skeleton, radius)
    seen = [visible_cells(grid, spot[r, c], radius) for r, c in cells]
    seen = [s[region[s]] for s in seen]
    bonus = np.where(np.arange(len(cells)) < on_skeleton, 0.5, 0.0)  # ties: the skeleton's
    # Two robots side by side there: a band of robot centres across the way of at least the
    # lane map's pass band (a centre at least radius + margin from the walls).
    side_by_side = opts.robot_radius_m + opts.margin_m + 0.5 * pass_band_m(opts.robot_radius_m)
    share = np.where(grid.clearance_m[cells[:, 0], cells[:, 1]] >= side_by_side, 1.0,
                     NARROW_GAIN_SHARE)
    heap = [(-(len(s) - covered[s].sum() + bonus[k]) * share[k], k) for k, s in enumerate(seen)]
    heapq.heapify(heap)
    while heap and (covered & region).sum() < goal:
        neg, k = heapq.heappop(heap)
        new = len(seen[k]) - covered[seen[k]].sum()
        gain = (new + bonus[k]) * share[k]
        if gain < -neg - 1e-9:  # stale: re-queue with the current gain
            heapq.heappush(heap, (-gain, k))
            continue
        if new < 1:
            break  # the best candidate sees no new cell (so none does: one cell outweighs
            # any bonus)
        xy = spot[cells[k][0], cells[k][1]]
        if far_enough(xy):
            take(xy, "cover")
    keep = _redundant_dropped(grid, targets, kinds, radius)
    return [targets[i] for i in keep], [kinds[i] for i in keep], (covered & region)


def _redundant_dropped(grid: WorkGrid, targets: list, kinds: list[str], radius_m: float
                       ) -> list[int]:
    """Indices of the targets kept: a cover target (latest first) whose every seen cell some
    other kept target also sees is dropped (the greedy's tail leaves such)."""
    seen = [visible_cells(grid, t, radius_m) for t in targets]
    seen = [s[grid.region.ravel()[s]] for s in seen]
    count = np.zeros(grid.occupied.size, dtype=np.int32)
    for s in seen:
        count[s] += 1
    keep = set(range(len(targets)))
    for i in reversed(range(len(targets))):
        if kinds[i] == "cover" and (count[seen[i]] >= 2).all():
            count[seen[i]] -= 1
            keep.discard(i)
    return sorted(keep)


# ------------------------------------------------------------------------------ edges


def voronoi_edges(grid: WorkGrid, targets: list[np.ndarray]) -> list[tuple[int, int, float]]:
    """Pairs of targets whose geodesic Voronoi cells (8-connected drivable map cells) touch,
    with the shortest geodesic length [m] across their common border."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    h, w = grid.fine.shape
    index = np.full(grid.fine.shape, -1, dtype=np.int64)
    cells = np.argwhere(grid.fine)
    index[cells[:, 0], cells[:, 1]] = np.arange(len(cells))
    pairs = []
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = index[max(0, -dr):h - max(0, dr), max(0, -dc):w - max(0, dc)]
        b = index[max(0, dr):h + min(0, dr) or None, max(0, dc):w + min(0, dc) or None]
        ok = (a >= 0) & (b >= 0)
        pairs.append((a[ok], b[ok], grid.fine_m * math.hypot(dr, dc)))
    src = np.concatenate([p[0] for p in pairs])
    dst = np.concatenate([p[1] for p in pairs])
    cost = np.concatenate([np.full(len(p[0]), p[2]) for p in pairs])
    graph = coo_matrix((cost, (src, dst)), shape=(len(cells), len(cells))).tocsr()
    sources = [int(index[int((t[1] - grid.origin[1]) // grid.fine_m),
                         int((t[0] - grid.origin[0]) // grid.fine_m)]) for t in targets]
    dist, _, owner = dijkstra(graph, directed=False, indices=sources, min_only=True,
                              return_predecessors=True)
    label = np.full(len(cells), -1, dtype=np.int64)
    where = {s: k for k, s in enumerate(sources)}
    label[owner >= 0] = [where[int(o)] for o in owner[owner >= 0]]
    lu, lv = label[src], label[dst]
    length = dist[src] + cost + dist[dst]
    cut = (lu != lv) & (lu >= 0) & (lv >= 0)
    best: dict[tuple[int, int], float] = {}
    for u, v, d in zip(lu[cut], lv[cut], length[cut], strict=True):
        key = (int(min(u, v)), int(max(u, v)))
        if d < best.get(key, math.inf):
            best[key] = float(d)
    return [(u, v, d) for (u, v), d in sorted(best.items())]


def prune_edges(edges: list[tuple[int, int, float]]) -> list[tuple[int, int, float]]:
    """Longest first, drop (u, v) when some w has both legs shorter than it and
    L(u, w) + L(w, v) <= (1 + DETOUR) L(u, v): the graph stays connected."""
    adj: dict[int, dict[int, float]] = {}
    for u, v, d in edges:
        adj.setdefault(u, {})[v] = d
        adj.setdefault(v, {})[u] = d
    for u, v, d in sorted(edges, key=lambda e: -e[2]):
        for x in set(adj[u]) & set(adj[v]):
            a, b = adj[u][x], adj[v][x]
            if a < d and b < d and a + b <= (1.0 + DETOUR) * d:
                del adj[u][v], adj[v][u]
                break
    return [(u, v, d) for u, v, d in edges if v in adj[u]]


def generate_graph(occ: OccupancyGrid, opts: GraphOptions) -> GeneratedGraph:
    """Targets and edges for `occ` (MapError on bad options or a map without room)."""
    opts.check()
    grid = work_grid(occ, opts)
    _fixed_cells(grid, opts.fixed, opts)
    skeleton = thin(grid.drivable)
    targets, kinds, covered = choose_targets(grid, skeleton, opts)
    notes = []
    if not targets:
        raise MapError(f"{occ.source or 'map'}: no target found in the drivable space")
    edges = prune_edges(voronoi_edges(grid, targets)) if len(targets) > 1 else []
    fraction = float(covered.sum()) / max(1, int(grid.region.sum()))
    if fraction < opts.coverage - 1e-9:
        notes.append(f"coverage {100 * fraction:.2f} % < the {100 * opts.coverage:g} % asked: "
                     "the rest is out of sight of every drivable spot (or held off by the min "
                     "spacing)")
    return GeneratedGraph(np.array(targets, dtype=float).reshape(-1, 2), edges, kinds,
                          fraction, covered.reshape(grid.occupied.shape), grid, notes)
