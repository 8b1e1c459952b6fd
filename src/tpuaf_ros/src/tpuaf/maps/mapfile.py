"""Our own map format (docs/MAPS.md): a folder with `map.yaml` and a graph file `graph.yaml`.

map.yaml:
    name: grid                      # required
    description: "..."              # optional
    graph: graph.yaml               # optional, default graph.yaml
    occupancy: occupancy.yaml       # optional map_server YAML; else corridors from the graph
    corridor_width: 1.5             # [m] optional, for the generated corridors
    bounds: [0, 0, 25.8, 25.8]      # [m] optional extent of the generated corridors
    settings: {...}                 # any MapSettings field (see model.py)

graph.yaml:
    vertices:
      - {id: 0, x: 1.425, y: 24.375}                    # [m]; optional importance, initial_uncertainty
    edges:
      - [0, 1]                                          # length = Euclidean
      - [1, 2, 6.0]                                     # length [m]

Unknown keys are refused; every error names the file and line. The files are parsed by libyaml
(`yamlfile.read_yaml_fast`, no lines); on any problem the folder is read again with the
line-tracking parser, whose documents hold the same data, for the message naming the line.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Hashable
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from tpuaf_core import yamlfile

from tpuaf.errors import MapError
from tpuaf.maps.model import MapSettings, PatrolMap
from tpuaf.maps.occupancy import as_number, load_occupancy
from tpuaf.maps.params import MAP_FILE


def read_yaml(path: Path) -> Any:
    """The document of a map or graph file: mappings and sequences carry their line; duplicate
    and non-scalar keys are refused (MapError naming the file and line)."""
    return yamlfile.read_yaml(path, MapError)


def _read(path: Path, fast: bool) -> Any:
    """`read_yaml`, or with `fast` libyaml's parse without lines (MapError on any doubt)."""
    return yamlfile.read_yaml_fast(path, MapError) if fast else read_yaml(path)


# A graph file as our writers write it ("vertices:", one "  - {id: 0, x: 1.5, y: 2.25}" per
# line, "edges:", one "  - [u, v]" or "  - [u, v, length]" per line; decimal numbers, the
# vertex keys only) is read line by line: on 10,000 vertices 10x faster than libyaml's parse
# with PyYAML's constructor. Any other text (comments, other layouts or numbers) goes there.
_INT = r"-?(?:0|[1-9][0-9]*)"
_DECIMAL = rf"{_INT}(?:\.[0-9]+)?"
_VERTEX_LINE = re.compile(rf"  - \{{((?:[a-z_]+: {_DECIMAL}, )*[a-z_]+: {_DECIMAL})\}}")
_EDGE_LINE = re.compile(rf"  - \[({_INT}), ({_INT})(?:, ({_DECIMAL}))?\]")


def _decimal(text: str) -> int | float:
    """The value YAML gives a plain decimal number (an int without a dot)."""
    return float(text) if "." in text else int(text)


def _plain_graph(path: Path) -> dict | None:
    """The graph file's document (vertices and edges as YAML reads them) if it is laid out as
    our writers write it, else None."""
    text = yamlfile.decode_utf8(yamlfile.read_regular_bytes(
        path, MapError, max_bytes=yamlfile.MAX_YAML_BYTES), path, MapError)
    lines = text.split("\n")
    while lines and not lines[-1]:
        lines.pop()
    try:
        split = lines.index("edges:")
    except ValueError:
        return None
    if not lines or lines[0] != "vertices:":
        return None
    vertices = []
    for line in lines[1:split]:
        found = _VERTEX_LINE.fullmatch(line)
        if found is None:
            return None
        pairs = [item.split(": ") for item in found.group(1).split(", ")]
        vertex = {key: _decimal(value) for key, value in pairs}
        if len(vertex) != len(pairs) or not vertex.keys() <= VERTEX_KEYS:
            return None  # a repeated or unknown key: the full reader's message
        vertices.append(vertex)
    edges = []
    for line in lines[split + 1:]:
        found = _EDGE_LINE.fullmatch(line)
        if found is None:
            return None
        edge = [int(found.group(1)), int(found.group(2))]
        if found.group(3) is not None:
            edge.append(_decimal(found.group(3)))
        edges.append(edge)
    return {"vertices": vertices, "edges": edges}


def _at(path: Path, node: Any) -> str:
    return yamlfile.where(path, node)


MAX_COORDINATE_M = 1e6  # |x|, |y|, lengths and widths [m]: 1,000 km (beyond: float steps of mm)
MIN_EDGE_M = 1e-3  # [m] a shorter edge takes no time to travel: the run never advances
MAX_VERTEX_ID = 2**31 - 1  # ids travel as int32 in ROS parameters; -1 means "none" in messages


def _num(path: Path, node: Any, key: str, value: Any, *, minimum: float | None = None,
         positive: bool = False, maximum: float | None = MAX_COORDINATE_M,
         owner: str = "") -> float:
    value = as_number(value)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise MapError(f"{_at(path, node)}: '{key}' must be a finite number (e.g. 0.05, 5e-2 or "
                       f"\"0.05\"), got {yamlfile.shorten(repr(value))}")
    if maximum is not None and abs(value) > maximum:
        raise MapError(f"{_at(path, node)}: {owner}'{key}' = {value:g} lies beyond the "
                       f"+-{maximum:g} a map may span")
    if positive and not value > 0:
        raise MapError(f"{_at(path, node)}: '{key}' must be > 0, got {value}")
    if minimum is not None and value < minimum:
        raise MapError(f"{_at(path, node)}: '{key}' must be >= {minimum}, got {value}")
    return float(value)


def _check_keys(path: Path, node: Any, allowed: set[str], what: str) -> None:
    if isinstance(node, dict) and node.keys() <= allowed:
        return  # the common case, without formatting a location
    yamlfile.check_keys(node, allowed, what, _at(path, node), MapError)


MAP_KEYS = {"name", "description", "graph", "occupancy", "corridor_width", "bounds", "settings"}
SETTINGS_KEYS = {f.name for f in dataclasses.fields(MapSettings)} - {"initial_pose_variants"}
VERTEX_KEYS = {"id", "x", "y", "importance", "initial_uncertainty"}


def _parse_settings(path: Path, node: Any) -> MapSettings:
    _check_keys(path, node, SETTINGS_KEYS, "settings")
    s = MapSettings()
    positive = {"nominal_speed", "sensing_radius", "goal_tolerance", "visit_radius",
                "robot_radius"}
    for key in ("nominal_speed", "sensing_radius", "sensing_peak", "interference_distance",
                "goal_tolerance", "visit_radius", "robot_radius", "default_importance",
                "default_initial_uncertainty"):
        if key in node:
            setattr(s, key, _num(path, node, key, node[key], minimum=0.0,
                                 positive=key in positive))
    if "visit_radius" in node and s.visit_radius > s.goal_tolerance:
        raise MapError(f"{_at(path, node)}: visit_radius {s.visit_radius:g} m exceeds "
                       f"goal_tolerance {s.goal_tolerance:g} m")
    if "growth_coefficients" in node:
        coeffs = node["growth_coefficients"]
        if not isinstance(coeffs, list) or not coeffs:
            raise MapError(f"{_at(path, node)}: 'growth_coefficients' must be a non-empty list")
        s.growth_coefficients = [_num(path, coeffs, "growth_coefficients", c, minimum=0.0)
                                 for c in coeffs]
    if "initial_vertices" in node:
        iv = node["initial_vertices"]
        if not isinstance(iv, dict):
            raise MapError(f"{_at(path, node)}: 'initial_vertices' must map team size -> ids")
        for team, ids in iv.items():
            if not isinstance(team, int) or team <= 0 or not isinstance(ids, list) or \
                    len(ids) != team or not all(isinstance(v, int) for v in ids):
                raise MapError(f"{_at(path, ids if isinstance(ids, list) else iv)}: "
                               f"initial_vertices[{team!r}] must list {team!r} vertex ids")
            dup = sorted({v for v in ids if ids.count(v) > 1})
            if dup:
                raise MapError(f"{_at(path, ids)}: initial_vertices[{team}] starts several robots "
                               f"at vertex {', '.join(map(str, dup))}")
            s.initial_vertices[team] = list(ids)
    if "initial_poses" in node:
        ip = node["initial_poses"]
        if not isinstance(ip, dict):
            raise MapError(f"{_at(path, node)}: 'initial_poses' must map team size -> [[x, y], ...]")
        for team, poses in ip.items():
            ok = isinstance(team, int) and team > 0 and isinstance(poses, list) and \
                len(poses) == team and all(isinstance(p, list) and len(p) == 2 for p in poses)
            if not ok:
                raise MapError(f"{_at(path, poses if isinstance(poses, list) else ip)}: "
                               f"initial_poses[{team!r}] must list {team!r} [x, y] pairs [m]")
            s.initial_poses[team] = [
                (_num(path, p, "initial_poses", p[0]), _num(path, p, "initial_poses", p[1]))
                for p in poses
            ]
    return s


def parse_graph_yaml(path: Path, settings: MapSettings, *, fast: bool = False) -> dict:
    """The graph file's vertices and edges, checked. `fast`: parsed by libyaml without lines
    (a MapError without the line: see load_map_folder)."""
    doc = (_plain_graph(path) if fast else None) or _read(path, fast)
    _check_keys(path, doc, {"vertices", "edges"}, "graph file")
    verts = doc.get("vertices")
    if not isinstance(verts, list) or not verts:
        raise MapError(f"{_at(path, doc)}: 'vertices' must be a non-empty list")
    ids: list[int] = []
    id_set: set[int] = set()
    pos: list[tuple[float, float]] = []
    imp: list[float] = []
    x0: list[float] = []
    for v in verts:
        _check_keys(path, v, VERTEX_KEYS, "vertex")
        for key in ("id", "x", "y"):
            if key not in v:
                raise MapError(f"{_at(path, v)}: vertex without '{key}'")
        vid = v["id"]
        if isinstance(vid, bool) or not isinstance(vid, int):
            raise MapError(f"{_at(path, v)}: vertex id must be an integer, got "
                           f"{yamlfile.shorten(repr(vid))}")
        if not 0 <= vid <= MAX_VERTEX_ID:
            raise MapError(f"{_at(path, v)}: vertex id must be in 0 .. {MAX_VERTEX_ID}, got "
                           f"{yamlfile.shorten(str(vid))}")
        if vid in id_set:
            raise MapError(f"{_at(path, v)}: duplicate vertex id {vid}")
        ids.append(vid)
        id_set.add(vid)
        pos.append((_num(path, v, "x", v["x"], owner=f"vertex {vid}: "),
                    _num(path, v, "y", v["y"], owner=f"vertex {vid}: ")))
        imp.append(_num(path, v, "importance", v.get("importance", settings.default_importance),
                        minimum=0.0))
        x0.append(_num(path, v, "initial_uncertainty",
                       v.get("initial_uncertainty", settings.default_initial_uncertainty),
                       minimum=0.0))
    index = {vid: i for i, vid in enumerate(ids)}
    edges_node = doc.get("edges")
    if not isinstance(edges_node, list):
        raise MapError(f"{_at(path, doc)}: 'edges' must be a list of [u, v] or [u, v, length_m]")
    edges: list[tuple[int, int, float]] = []
    seen: dict[tuple[int, int], int] = {}
    for e in edges_node:
        if not isinstance(e, list) or len(e) not in (2, 3):
            raise MapError(f"{_at(path, e if isinstance(e, list) else edges_node)}: an edge is "
                           f"[u, v] or [u, v, length_m], got {yamlfile.shorten(repr(e))}")
        u, w = e[0], e[1]
        for vid in (u, w):
            if not isinstance(vid, Hashable) or vid not in index:  # e.g. a list: no vertex id
                short = yamlfile.shorten
                raise MapError(f"{_at(path, e)}: edge {short(str(u))}-{short(str(w))} names "
                               f"unknown vertex {short(repr(vid))}")
        if u == w:
            raise MapError(f"{_at(path, e)}: self-loop at vertex {u}")
        key = (min(index[u], index[w]), max(index[u], index[w]))
        if key in seen:
            raise MapError(f"{_at(path, e)}: edge {u}-{w} repeats the edge of line {seen[key]}")
        seen[key] = yamlfile.line_of(e)
        length = math.nan
        if len(e) == 3:
            length = _num(path, e, "length", e[2], positive=True)
            if length < MIN_EDGE_M:
                raise MapError(f"{_at(path, e)}: edge {u}-{w} is {length:g} m long, less than "
                               f"{MIN_EDGE_M:g} m (travel would take no time)")
        edges.append((index[u], index[w], length))
    return {"ids": ids, "positions": np.array(pos, dtype=float), "importance": np.array(imp),
            "initial": np.array(x0), "edges": edges}


def load_map_folder(folder: str | Path) -> PatrolMap:
    """Load one of our map folders (with map.yaml). Parsed by libyaml first; on any MapError
    the folder is read again with the line-tracking parser: the same checks on the same data
    then raise the message naming the file and line (or accept a text libyaml doubted)."""
    folder = Path(folder)
    if yamlfile.HAS_LIBYAML:
        try:
            return _load_map_folder(folder, fast=True)
        except MapError:
            pass  # the line-tracking parse below names the file and line (or decides a doubt)
    return _load_map_folder(folder, fast=False)


def _load_map_folder(folder: Path, fast: bool) -> PatrolMap:
    path = folder / "map.yaml"
    if not path.is_file():
        raise MapError(f"{folder}: no map.yaml (not a tpuaf map folder)")
    doc = _read(path, fast)
    _check_keys(path, doc, MAP_KEYS, "map.yaml")
    name = doc.get("name")
    if not isinstance(name, str) or not name:
        raise MapError(f"{_at(path, doc)}: 'name' (a non-empty string) is required")
    settings = _parse_settings(path, doc.get("settings", {}))
    graph_name = doc.get("graph", "graph.yaml")
    graph_path = folder / str(graph_name)
    if not graph_path.is_file():
        raise MapError(f"{_at(path, doc)}: graph file '{graph_name}' not found in {folder}")
    g = parse_graph_yaml(graph_path, settings, fast=fast)
    occupancy = None
    if doc.get("occupancy") is not None:
        occ_path = folder / str(doc["occupancy"])
        if not occ_path.is_file():
            raise MapError(f"{_at(path, doc)}: occupancy file '{doc['occupancy']}' not found")
        occupancy = load_occupancy(occ_path)
    corridor = doc.get("corridor_width")
    if corridor is not None:
        corridor = _num(path, doc, "corridor_width", corridor, positive=True)
    bounds = doc.get("bounds")
    if bounds is not None:
        if not isinstance(bounds, list) or len(bounds) != 4:
            raise MapError(f"{_at(path, doc)}: 'bounds' must be [x_min, y_min, x_max, y_max] [m]")
        bounds = tuple(_num(path, bounds, "bounds", b) for b in bounds)
        if not (bounds[0] < bounds[2] and bounds[1] < bounds[3]):
            raise MapError(f"{_at(path, doc)}: 'bounds' must have x_min < x_max and y_min < y_max")
    for team, ids in settings.initial_vertices.items():
        for vid in ids:
            if vid not in g["ids"]:
                raise MapError(f"{path}: initial_vertices[{team}] names unknown vertex {vid}")
    pm = PatrolMap(
        name=name,
        vertex_ids=g["ids"],
        positions=g["positions"],
        edges=g["edges"],
        importance=g["importance"],
        initial_uncertainty=g["initial"],
        settings=settings,
        source=folder,
        occupancy=occupancy,
        corridor_width=corridor,
        bounds=bounds,
        description=str(doc.get("description", "")),
        setting_sources={k: MAP_FILE for k in doc.get("settings", {})},
    )
    pm.graph  # noqa: B018 - validates (connected, lengths) now, naming the map folder
    return pm


def _flow_list(values: list) -> str:
    return "[" + ", ".join(_fmt(v) for v in values) + "]"


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return repr(round(v, 6))
    return str(v)


def save_map_folder(patrol_map: PatrolMap, folder: str | Path, *, occupancy_file: bool = False,
                    header: str = "", occupancy_name: str = "occupancy.yaml") -> Path:
    """Write `patrol_map` in our format (map.yaml + graph.yaml [+ the occupancy grid as
    map_server YAML `occupancy_name` and its PGM])."""
    from tpuaf.maps.occupancy import write_occupancy

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    s = patrol_map.settings
    lines = [f"# {line}" for line in header.splitlines()] if header else []
    lines.append(f"name: {patrol_map.name}")
    if patrol_map.description:
        lines.append(f"description: {yaml.safe_dump(patrol_map.description, width=1000).splitlines()[0]}")
    lines.append("graph: graph.yaml")
    if occupancy_file:
        lines.append(f"occupancy: {occupancy_name}")
    if patrol_map.corridor_width is not None:
        lines.append(f"corridor_width: {_fmt(float(patrol_map.corridor_width))}  # [m]")
    if patrol_map.bounds is not None:
        lines.append(f"bounds: {_flow_list([float(b) for b in patrol_map.bounds])}  # [m]")
    lines.append("settings:")
    lines += [
        f"  nominal_speed: {_fmt(s.nominal_speed)}  # [m/s]",
        f"  sensing_radius: {_fmt(s.sensing_radius)}  # r [m], Eq. 1",
        f"  sensing_peak: {_fmt(s.sensing_peak)}  # G, Eq. 1",
        f"  interference_distance: {_fmt(s.interference_distance)}  # d_if [m]",
        f"  goal_tolerance: {_fmt(s.goal_tolerance)}  # [m]",
        f"  visit_radius: {_fmt(min(s.visit_radius, s.goal_tolerance))}  # [m] of a visit",
        f"  robot_radius: {_fmt(s.robot_radius)}  # [m]",
        f"  growth_coefficients: {_flow_list(list(s.growth_coefficients))}  # a_l of g(X), Eq. 2",
        f"  default_importance: {_fmt(s.default_importance)}  # C_j",
        f"  default_initial_uncertainty: {_fmt(s.default_initial_uncertainty)}  # X0_j",
    ]
    if s.initial_vertices:
        lines.append("  initial_vertices:  # team size: vertex ids")
        lines += [f"    {k}: {_flow_list(v)}" for k, v in sorted(s.initial_vertices.items())]
    if s.initial_poses:
        lines.append("  initial_poses:  # team size: [[x, y], ...] [m]")
        lines += [f"    {k}: [{', '.join(_flow_list(list(p)) for p in v)}]"
                  for k, v in sorted(s.initial_poses.items())]
    (folder / "map.yaml").write_text("\n".join(lines) + "\n")

    g = ["# Patrol graph: vertices [m] (optional importance C, initial_uncertainty X0),",
         "# edges [u, v] or [u, v, length_m] (default length: Euclidean).", "vertices:"]
    for i, vid in enumerate(patrol_map.vertex_ids):
        x, y = patrol_map.positions[i]
        extra = ""
        if patrol_map.importance[i] != s.default_importance:
            extra += f", importance: {_fmt(float(patrol_map.importance[i]))}"
        if patrol_map.initial_uncertainty[i] != s.default_initial_uncertainty:
            extra += f", initial_uncertainty: {_fmt(float(patrol_map.initial_uncertainty[i]))}"
        g.append(f"  - {{id: {vid}, x: {_fmt(float(x))}, y: {_fmt(float(y))}{extra}}}")
    g.append("edges:")
    for u, v, length in patrol_map.edges:
        a, b = patrol_map.vertex_ids[u], patrol_map.vertex_ids[v]
        if length is None or (isinstance(length, float) and math.isnan(length)):
            g.append(f"  - [{a}, {b}]")
        else:
            g.append(f"  - [{a}, {b}, {_fmt(float(length))}]")
    (folder / "graph.yaml").write_text("\n".join(g) + "\n")
    if occupancy_file:
        write_occupancy(patrol_map.occupancy_grid(), folder / occupancy_name)
    return folder
