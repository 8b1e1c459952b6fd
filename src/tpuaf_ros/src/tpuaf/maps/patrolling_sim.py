"""Importer for patrolling_sim maps (`<name>.graph` + `<name>.yaml` + image), SPEC section 7.

Graph format: whitespace-separated tokens. Header: vertex count, image width px, image height
px, resolution m/px, offset x m, offset y m. Then per vertex: id, x px, y px, neighbour count k,
and k triples (neighbour id, compass direction, edge cost px). Metric coordinates:
x = x_px * res + offset_x, y = y_px * res + offset_y (y up). Edge length = cost px * res.

Edges are listed in both directions; an edge listed in one direction only is an error. Parallel
edges (the same pair listed more than once, or with different costs each way) are merged into
one edge with the shortest cost; each merge is recorded in `PatrolMap.notes`.

Settings of imported maps (the files carry none): the reference simulator's robot (a 0.33 m
disc at 1 m/s: the simulator's patrolling_sim preset), r = 5 m, d_if = 2 m (SPEC), goal
tolerance 0.4 m (tpuaf.maps.params.imported_defaults); other values MapSettings defaults. Any
of them can be overridden per run (`--map-param`, launch arg `map_params`).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import numpy as np
from tpuaf_core.yamlfile import decode_utf8, read_regular_bytes, shorten

from tpuaf.errors import MapError
from tpuaf.maps.model import MapSettings, PatrolMap
from tpuaf.maps.occupancy import load_occupancy
from tpuaf.maps.params import imported_defaults

# Fixed settings of imported maps; speed, r, d_if and the robot radius: imported_defaults.
IMPORTED_SETTINGS = {
    "goal_tolerance": 0.4,  # [m]
}


MAX_GRAPH_BYTES = 64 << 20  # the largest reference map's .graph is about 30 kB
MAX_INTEGER = 2**31 - 1  # ids, counts and image sizes (int32 as in patrolling_sim)
MAX_VERTICES = 1_000_000
MAX_PIXELS = 1e7  # |coordinate| and cost [px]
MAX_METRES = 1e6  # |coordinate| and edge length [m] of the metric map (mapfile's bound)
MIN_METRES = 1e-3  # shortest edge [m]: a shorter one takes no time, the run never advances
_INTEGER = re.compile(r"[+-]?[0-9]+")
_NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


class _Tokens:
    """Tokens of a text file with their line numbers, for error messages."""

    def __init__(self, path: Path):
        self.path = path
        data = read_regular_bytes(path, MapError, max_bytes=MAX_GRAPH_BYTES, what="graph file")
        text = decode_utf8(data, path, MapError)
        self.items: list[tuple[str, int]] = [
            (tok, lineno)
            for lineno, line in enumerate(text.splitlines(), start=1)
            for tok in line.split()
        ]
        self.pos = 0

    def where(self, index: int | None = None) -> str:
        i = self.pos if index is None else index
        if i < len(self.items):
            return f"{self.path}:{self.items[i][1]} (token {i + 1})"
        last = self.items[-1][1] if self.items else 1
        return f"{self.path}:{last} (end of file)"

    def next(self, what: str) -> str:
        if self.pos >= len(self.items):
            raise MapError(f"{self.where()}: file is truncated, expected {what}")
        tok = self.items[self.pos][0]
        self.pos += 1
        return tok

    def integer(self, what: str, low: int = -MAX_INTEGER, high: int = MAX_INTEGER) -> int:
        """A plain ASCII decimal integer in low .. high (int() would take '2_39' and '２３９')."""
        tok = self.next(what)
        if not _INTEGER.fullmatch(tok):
            raise MapError(f"{self.where(self.pos - 1)}: expected an integer {what} (decimal "
                           f"digits), got {shorten(repr(tok))}")
        value = int(tok)
        if not low <= value <= high:
            raise MapError(f"{self.where(self.pos - 1)}: {what} must be in {low} .. {high}, "
                           f"got {shorten(tok)}")
        return value

    def number(self, what: str, bound: float = MAX_PIXELS) -> float:
        """A plain ASCII decimal number within +-bound (float() would take 'nan', '1_0')."""
        tok = self.next(what)
        if not _NUMBER.fullmatch(tok):
            raise MapError(f"{self.where(self.pos - 1)}: expected a number {what} (decimal "
                           f"digits), got {shorten(repr(tok))}")
        value = float(tok)
        if not (np.isfinite(value) and abs(value) <= bound):
            raise MapError(f"{self.where(self.pos - 1)}: {what} must be finite and within "
                           f"+-{bound:g}, got {shorten(tok)}")
        return value


_DIRECTIONS = {"N", "S", "E", "W", "NE", "NW", "SE", "SW"}


def parse_graph(path: str | Path) -> dict:
    """Parse a patrolling_sim .graph file. Returns header values, vertices and merged edges."""
    path = Path(path)
    tk = _Tokens(path)
    n = tk.integer("vertex count", 1, MAX_VERTICES)
    width = tk.integer("image width [px]", 0)
    height = tk.integer("image height [px]", 0)
    res = tk.number("resolution [m/px]")
    if res <= 0:
        raise MapError(f"{tk.where(3)}: resolution must be > 0, got {res}")
    off_x = tk.number("offset x [m]")
    off_y = tk.number("offset y [m]")
    ids, px, adjacency = _read_vertices(tk, n)
    edges, notes = _merged_edges(tk, ids, adjacency, res)
    positions = np.array(px, dtype=float) * res + np.array([off_x, off_y])
    _check_extent(path, positions, edges)
    return {
        "n": n,
        "width_px": width,
        "height_px": height,
        "resolution": res,
        "offset": (off_x, off_y),
        "ids": ids,
        "pixels": np.array(px, dtype=float),
        "positions": positions,
        "edges": edges,
        "notes": notes,
        "directed_count": sum(len(a) for a in adjacency),
    }


def _read_vertices(tk: _Tokens, n: int) -> tuple[list[int], list[tuple[float, float]],
                                                  list[list[tuple[int, float, int]]]]:
    """The n vertices after the header: ids, pixel positions and each one's listed neighbours
    (neighbour id, cost [px], token index); nothing may follow them."""
    ids: list[int] = []
    px: list[tuple[float, float]] = []
    adjacency: list[list[tuple[int, float, int]]] = []  # (neighbour id, cost px, token index)
    vertex_token: dict[int, int] = {}
    for k in range(n):
        start = tk.pos
        vid = tk.integer(f"id of vertex {k + 1} of {n}", 0)
        if vid in vertex_token:
            raise MapError(f"{tk.where(start)}: duplicate vertex id {vid}")
        vertex_token[vid] = start
        x = tk.number(f"x [px] of vertex {vid}")
        y = tk.number(f"y [px] of vertex {vid}")
        count = tk.integer(f"neighbour count of vertex {vid}", 0, n * 8)
        nbrs = []
        for _ in range(count):
            at = tk.pos
            nb = tk.integer(f"neighbour id of vertex {vid}", 0)
            direction = tk.next(f"direction to neighbour {nb} of vertex {vid}")
            if direction.upper() not in _DIRECTIONS:
                raise MapError(
                    f"{tk.where(tk.pos - 1)}: expected a compass direction (N, NE, ...) "
                    f"for edge {vid}-{nb}, got {shorten(repr(direction))}"
                )
            cost = tk.number(f"cost [px] of edge {vid}-{nb}")
            if cost <= 0:
                raise MapError(f"{tk.where(tk.pos - 1)}: edge {vid}-{nb} has cost {cost} <= 0")
            nbrs.append((nb, cost, at))
        ids.append(vid)
        px.append((x, y))
        adjacency.append(nbrs)
    if tk.pos < len(tk.items):
        raise MapError(
            f"{tk.where()}: unexpected data after {n} vertices (vertex count mismatch: "
            f"header says {n})"
        )
    return ids, px, adjacency


def _merged_edges(tk: _Tokens, ids: list[int], adjacency: list[list[tuple[int, float, int]]],
                  res: float) -> tuple[list[tuple[int, int, float]], list[str]]:
    """Undirected edges (index, index, length [m]) from the listed directed costs, the
    shortest kept per pair, and notes on parallel and asymmetric costs; a neighbour unknown,
    the vertex itself, or listed one way only is refused."""
    index = {v: i for i, v in enumerate(ids)}
    # Directed costs, merged (shortest) per ordered pair; remember parallels.
    directed: dict[tuple[int, int], float] = {}
    notes: list[str] = []
    parallel: set[tuple[int, int]] = set()
    for i, nbrs in enumerate(adjacency):
        for nb, cost, at in nbrs:
            if nb not in index:
                raise MapError(f"{tk.where(at)}: vertex {ids[i]} lists unknown neighbour {nb}")
            j = index[nb]
            if j == i:
                raise MapError(f"{tk.where(at)}: vertex {ids[i]} lists itself as a neighbour")
            if (i, j) in directed:
                pair = (min(ids[i], nb), max(ids[i], nb))
                if pair not in parallel:
                    parallel.add(pair)
                    notes.append(
                        f"parallel edge {pair[0]}-{pair[1]} listed more than once: kept the "
                        "shortest"
                    )
                directed[(i, j)] = min(directed[(i, j)], cost)
            else:
                directed[(i, j)] = cost
    edges: list[tuple[int, int, float]] = []
    for (i, j), cost in directed.items():
        if (j, i) not in directed:
            at = next(a for nb, _, a in adjacency[i] if nb == ids[j])
            raise MapError(
                f"{tk.where(at)}: asymmetric edge: vertex {ids[i]} lists {ids[j]}, "
                f"but vertex {ids[j]} does not list {ids[i]}"
            )
        if i < j:
            back = directed[(j, i)]
            if back != cost:
                notes.append(
                    f"edge {ids[i]}-{ids[j]} has cost {cost:g} px one way and {back:g} px the "
                    "other: kept the shortest"
                )
            edges.append((i, j, min(cost, back) * res))
    return edges, notes


def _check_extent(path: Path, positions: np.ndarray, edges: list[tuple[int, int, float]]) -> None:
    """Edges at least MIN_METRES long; vertices and edges within MAX_METRES."""
    far = float(np.abs(positions).max()) if len(positions) else 0.0
    longest = max((length for _, _, length in edges), default=0.0)
    shortest = min((length for _, _, length in edges), default=MIN_METRES)
    if shortest < MIN_METRES:
        raise MapError(f"{path}: an edge of {shortest:g} m (cost px x resolution): edges must "
                       f"be at least {MIN_METRES:g} m long (travel would take no time)")
    if far > MAX_METRES or longest > MAX_METRES:
        what = f"a vertex at {far:g} m" if far > MAX_METRES else f"an edge of {longest:g} m"
        raise MapError(f"{path}: {what} (pixels x resolution + offset): a map must lie within "
                       f"+-{MAX_METRES:g} m, edges at most {MAX_METRES:g} m long")


def read_initial_poses(path: str | Path, map_name: str) -> tuple[dict, dict]:
    """Poses [m] of map `map_name` from a patrolling_sim `initial_poses.txt` (INI, section
    [InitialPoses], keys `<map>_<N>`, values `[x0, y0, x1, y1, ...]`).

    Returns ({N: [(x, y), ...]}, {"<N>_<suffix>": [(x, y), ...]}) for keys with a suffix.
    """
    path = Path(path)
    data = read_regular_bytes(path, MapError, max_bytes=MAX_GRAPH_BYTES, what="initial poses file")
    lines = data.decode("utf-8", "replace").splitlines()
    poses: dict[int, list[tuple[float, float]]] = {}
    variants: dict[str, list[tuple[float, float]]] = {}
    section = None
    key_re = re.compile(rf"^{re.escape(map_name)}_(\d+)(?:_(\w+))?$")
    for lineno, raw in enumerate(lines, start=1):
        line = raw.strip()
        if not line or line.startswith(("#", ";")):
            continue
        if line.startswith("["):
            if not line.endswith("]"):
                raise MapError(f"{path}:{lineno}: malformed section header {line!r}")
            section = line[1:-1].strip()
            continue
        m = re.match(r"^([^:=]+)[:=](.*)$", line)
        if not m:
            raise MapError(f"{path}:{lineno}: expected 'key: [x0, y0, ...]', got {line!r}")
        if section != "InitialPoses":
            continue
        key, value = m.group(1).strip(), m.group(2).strip()
        km = key_re.match(key)
        if not km:
            continue
        try:
            numbers = ast.literal_eval(value)
            numbers = [float(v) for v in numbers]
        except (ValueError, SyntaxError, TypeError):
            raise MapError(f"{path}:{lineno}: '{key}' must be a list of numbers, got {value!r}") from None
        team = int(km.group(1))
        if len(numbers) != 2 * team:
            raise MapError(
                f"{path}:{lineno}: '{key}' needs {2 * team} numbers (x, y per robot), "
                f"got {len(numbers)}"
            )
        pts = [(numbers[2 * i], numbers[2 * i + 1]) for i in range(team)]
        if km.group(2):
            variants[f"{team}_{km.group(2)}"] = pts
        else:
            poses[team] = pts
    return poses, variants


def find_graph_file(folder: Path) -> Path:
    graphs = sorted(folder.glob("*.graph"))
    if not graphs:
        raise MapError(f"{folder}: no .graph file (not a patrolling_sim map folder)")
    preferred = folder / f"{folder.name}.graph"
    if preferred in graphs:
        return preferred
    if len(graphs) > 1:
        names = ", ".join(p.name for p in graphs)
        raise MapError(f"{folder}: several .graph files ({names}); pass the one to use")
    return graphs[0]


def load_patrolling_sim(path: str | Path) -> PatrolMap:
    """Import a patrolling_sim map: a folder holding `<name>.graph`, or the .graph file itself.

    The map_server YAML is `<name>.yaml` beside the graph; when the image it names does not
    exist, `<name>.pgm` / `<name>.png` beside it is used (ctcv's YAML names `ctcv_map.pgm`).
    `initial_poses.txt` is read from the folder or its parent when present.
    """
    path = Path(path)
    graph_file = path if path.is_file() else find_graph_file(path)
    folder = graph_file.parent
    name = graph_file.stem
    g = parse_graph(graph_file)
    yaml_file = folder / f"{name}.yaml"
    if not yaml_file.is_file():
        raise MapError(f"{graph_file}: map YAML {yaml_file.name} not found beside it")
    occ = load_occupancy(
        yaml_file, image_fallbacks=(folder / f"{name}.pgm", folder / f"{name}.png")
    )
    notes = list(g["notes"])
    warnings = []
    if (occ.width, occ.height) != (g["width_px"], g["height_px"]):
        text = (f"graph header says {g['width_px']}x{g['height_px']} px, image is "
                f"{occ.width}x{occ.height} px")
        if g["width_px"] > occ.width or g["height_px"] > occ.height:
            warnings.append(f"{graph_file}: the graph is larger than its image: {text}")
        else:
            notes.append(text)
    defaults = imported_defaults(g["positions"])
    settings = MapSettings(**IMPORTED_SETTINGS, **{k: v for k, (v, _) in defaults.items()})
    for candidate in (folder / "initial_poses.txt", folder.parent / "initial_poses.txt"):
        if candidate.is_file():
            settings.initial_poses, settings.initial_pose_variants = read_initial_poses(
                candidate, name
            )
            break
    n = g["n"]
    pm = PatrolMap(
        name=name,
        vertex_ids=g["ids"],
        positions=g["positions"],
        edges=g["edges"],
        importance=np.full(n, settings.default_importance),
        initial_uncertainty=np.full(n, settings.default_initial_uncertainty),
        settings=settings,
        source=graph_file,
        occupancy=occ,
        description=f"patrolling_sim map '{name}' imported from {folder}",
        notes=notes,
        warnings=warnings,
        setting_sources={k: why for k, (_, why) in defaults.items()},
    )
    pm.graph  # noqa: B018 - validates connectivity now, with the file named in the error
    return pm


_COMPASS = ("E", "NE", "N", "NW", "W", "SW", "S", "SE")  # 45 degree sectors from east, y up


def write_graph(patrol_map: PatrolMap, path: str | Path, grid) -> Path:
    """Write `patrol_map` as a patrolling_sim `.graph` over occupancy grid `grid` (its size,
    resolution and origin in the header): pixels = floor((x - origin) / resolution), edge
    costs = length / resolution rounded (at least 1 px)."""
    res = float(grid.resolution)
    ox, oy = (float(v) for v in grid.origin)
    pos = np.asarray(patrol_map.positions, dtype=float)
    px = np.floor((pos - [ox, oy]) / res + 1e-6).astype(np.int64)
    lengths = patrol_map.graph
    adjacency: dict[int, list[int]] = {i: [] for i in range(len(pos))}
    for u, v, _ in patrol_map.edges:
        adjacency[u].append(v)
        adjacency[v].append(u)
    ids = patrol_map.vertex_ids
    lines = [str(len(pos)), str(grid.width), str(grid.height), f"{res:g}", f"{ox:g}", f"{oy:g}",
             ""]
    for i in range(len(pos)):
        lines += [str(ids[i]), str(px[i, 0]), str(px[i, 1]), str(len(adjacency[i]))]
        for j in sorted(adjacency[i]):
            dx, dy = pos[j] - pos[i]
            sector = int(round(np.degrees(np.arctan2(dy, dx)) / 45.0)) % 8
            cost = max(1, int(round(float(lengths.edge_length(i, j)) / res)))
            lines += [str(ids[j]), _COMPASS[sector], str(cost)]
        lines.append("")
    path = Path(path)
    path.write_text("\n".join(lines) + "\n")
    return path
