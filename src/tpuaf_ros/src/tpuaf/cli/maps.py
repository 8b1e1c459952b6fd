"""`tpuaf maps [NAME_OR_PATH ...]`: statistics of maps (SPEC section 7), the effective map
parameters and where each came from (map file, imported default, --map-param), and every edge
checked against the map's robot footprint (planned paths on the occupancy grid,
navigation/planner.py)."""

from __future__ import annotations

import argparse
import json
import math
import sys

from tpuaf.cli.run import add_map_params, map_params
from tpuaf.errors import CliError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "maps",
        nargs="*",
        metavar="NAME_OR_PATH",
        help="built-in map name (grid, lab), a map folder, a patrolling_sim folder or a .graph "
        "file (default: all built-in maps)",
    )
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument("--allow-occupied-vertices", action="store_true",
                        help="a vertex outside the image's free space is a warning, not an error")
    parser.add_argument("--lanes", action="store_true",
                        help="also find the lanes: stretches one robot wide, with their waiting "
                        "spots (docs/LANES.md), for the map's robot radius")
    parser.add_argument("--picture", metavar="DIR", default=None,
                        help="write DIR/<map>.png: the map, its graph and (with --lanes) its "
                        "lanes")
    add_map_params(p=parser)


COLUMNS = [
    ("map", "name", "{}"),
    ("V", "vertices", "{}"),
    ("E", "edges", "{}"),
    ("size [m]", None, ""),
    ("area [m2]", "area_m2", "{:.1f}"),
    ("total edge [m]", "total_edge_length_m", "{:.1f}"),
    ("mean edge [m]", "mean_edge_length_m", "{:.2f}"),
    ("Fiedler", "fiedler_value", "{:.4f}"),
    ("v [m/s]", "nominal_speed_m_s", "{:g}"),
    ("r [m]", "sensing_radius_m", "{:g}"),
    ("d_if [m]", "interference_distance_m", "{:g}"),
]


def format_table(summaries: list[dict]) -> str:
    rows = [[title for title, _, _ in COLUMNS]]
    for s in summaries:
        row = []
        for _, key, fmt in COLUMNS:
            if key is None:
                row.append(f"{s['size_x_m']:.1f} x {s['size_y_m']:.1f}")
            else:
                row.append(fmt.format(s[key]))
        rows.append(row)
    widths = [max(len(r[i]) for r in rows) for i in range(len(COLUMNS))]
    lines = ["  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in
                       enumerate(zip(r, widths, strict=True))) for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    lines.append("")
    lines.append("size = extent of the occupancy grid; Fiedler = algebraic connectivity of the "
                 "normalised Laplacian, weights = edge length [m]")
    return "\n".join(lines)


LONG_RATIO = 1.5  # planned / declared length above this: a warning
SHOWN = 10  # blocked or long edges listed one by one per map; the rest are counted


WINDOW_CELLS = 4_000_000  # grid cells (a 100 m square at 5 cm): beyond, edges in windows
TILE_M = 40.0  # [m] side of the squares grouping a big grid's edges by their midpoints


class _Window:
    """A map seen through part of its occupancy grid, with some of its edges: what PathPlanner
    reads of a map."""

    def __init__(self, patrol_map, grid, edges: list):
        self.positions, self.graph, self.edges = patrol_map.positions, patrol_map.graph, edges
        self._grid = grid

    def occupancy_grid(self):
        return self._grid


def _windows(patrol_map, radius: float):
    """(grid window, edges) of a big grid: edges grouped by the TILE_M square of their midpoint,
    each group planned on the grid cropped to its endpoints plus a margin holding every path up
    to LONG_RATIO x the edge's length (an ellipse round the edge) and the costmap's reach
    beyond it, so the check's verdicts are those of the whole grid."""
    import numpy as np

    from tpuaf.maps.occupancy import OccupancyGrid
    from tpuaf.navigation.planner import PlannerConfig

    grid = patrol_map.occupancy_grid()
    c = PlannerConfig()
    res, (ox, oy) = float(grid.resolution), grid.origin
    step = max(1, math.floor(0.5 * (radius + c.safety_margin_m) / res + 1e-9))  # planning cell
    pos = np.asarray(patrol_map.positions, dtype=float)
    groups: dict[tuple[int, int], list] = {}
    for u, v, length in patrol_map.graph.edges:
        mid = 0.5 * (pos[u] + pos[v])
        groups.setdefault((int(mid[0] // TILE_M), int(mid[1] // TILE_M)), []).append((u, v, length))
    for key in sorted(groups):
        edges = groups[key]
        ends = pos[[i for u, v, _ in edges for i in (u, v)]]
        margin = 0.5 * LONG_RATIO * max(float(e[2]) for e in edges) + radius + \
            c.safety_margin_m + c.inflation_m
        (x0, y0), (x1, y1) = ends.min(axis=0) - margin, ends.max(axis=0) + margin
        c0 = max(0, math.floor((x0 - ox) / res) // step * step)
        r0 = max(0, math.floor((y0 - oy) / res) // step * step)
        c1, r1 = min(grid.width, math.ceil((x1 - ox) / res)), min(grid.height, math.ceil((y1 - oy) / res))
        window = OccupancyGrid(np.ascontiguousarray(grid.occupied[r0:r1, c0:c1]), res,
                               (ox + c0 * res, oy + r0 * res))
        yield window, edges


def planned_edges(patrol_map, radius: float) -> list:
    """EdgeCheck of every edge (navigation/planner.py), sorted by vertex indices: on the whole
    grid, or, on a grid of more than WINDOW_CELLS cells, window by window (`_windows`: the
    costmap of one window at a time, not of the whole grid)."""
    from tpuaf.navigation.planner import PathPlanner

    if patrol_map.occupancy_grid().occupied.size <= WINDOW_CELLS:
        return PathPlanner(patrol_map, radius).check_edges()
    checks = []
    for window, edges in _windows(patrol_map, radius):
        checks += PathPlanner(_Window(patrol_map, window, edges), radius).check_edges()
    return sorted(checks, key=lambda c: (c.u, c.v))


def edge_check(patrol_map) -> dict:
    """Every edge of the map planned for a robot of the map's `settings.robot_radius` [m]:
    counts, the edges without a collision-free path ("blocked", with the ids of their vertices
    on occupied cells, if any), those planned more than LONG_RATIO x their declared length
    ("long"), median and max ratio planned / declared over the drivable edges (None without
    any)."""
    import numpy as np

    radius = float(patrol_map.settings.robot_radius)
    ids = patrol_map.vertex_ids
    grid = patrol_map.occupancy_grid()
    occupied = {i for i, (x, y) in enumerate(patrol_map.positions) if not grid.is_free(x, y)}
    blocked, long, ratios = [], [], []
    for c in planned_edges(patrol_map, radius):
        edge = {"edge": f"{ids[c.u]}-{ids[c.v]}", "declared_m": c.declared_m}
        if not math.isfinite(c.planned_m):
            blocked.append({**edge, "occupied_vertices": [ids[i] for i in (c.u, c.v)
                                                          if i in occupied]})
            continue
        ratios.append(c.ratio)
        if c.ratio > LONG_RATIO:
            long.append({**edge, "planned_m": c.planned_m, "ratio": c.ratio})
    return {
        "robot_radius_m": radius,
        "edges": len(blocked) + len(ratios),
        "blocked": blocked,
        "long": long,
        "median_ratio": float(np.median(ratios)) if ratios else None,
        "max_ratio": float(max(ratios)) if ratios else None,
    }


def format_edge_check(name: str, check: dict, allow_occupied_vertices: bool = False
                      ) -> tuple[str, list[str], list[str]]:
    """(summary line, error lines, warning lines) of one map's edge check; past SHOWN edges of
    a kind, one line counts the rest. A blocked edge is a warning, not an error, when it ends
    at a vertex on an occupied cell and such vertices are accepted (--allow-occupied-vertices).
    """
    radius = check["robot_radius_m"]

    def ratio(key: str) -> str:
        return "n/a" if check[key] is None else f"{check[key]:.2f}"

    def accepted(b: dict) -> bool:
        return allow_occupied_vertices and bool(b["occupied_vertices"])

    def no_path(b: dict) -> str:
        where = ""
        if b["occupied_vertices"]:
            where = (f" (vertex {', '.join(str(v) for v in b['occupied_vertices'])} on an "
                     "occupied cell" + (", accepted)" if accepted(b) else ")"))
        return (f"edge {b['edge']} (declared {b['declared_m']:.2f} m): no collision-free path "
                f"for a robot of radius {radius:g} m{where}")

    def listed(kind: str, texts: list[str], rest: str) -> list[str]:
        lines = [f"tpuaf maps: {kind} ({name}): {t}" for t in texts[:SHOWN]]
        if len(texts) > SHOWN:
            lines.append(f"tpuaf maps: {kind} ({name}): and {len(texts) - SHOWN} more {rest}")
        return lines

    line = (f"edges of {name} for a robot of radius {radius:g} m: {check['edges']} checked, "
            f"{len(check['blocked'])} without a collision-free path, {len(check['long'])} "
            f"planned > {LONG_RATIO:g} x declared; planned / declared median "
            f"{ratio('median_ratio')}, max {ratio('max_ratio')}")
    no_path_rest = "edges without a collision-free path"
    errors = listed("error", [no_path(b) for b in check["blocked"] if not accepted(b)],
                    no_path_rest)
    warnings = listed("warning", [no_path(b) for b in check["blocked"] if accepted(b)],
                      no_path_rest + " (at accepted vertices)")
    warnings += listed("warning", [f"edge {e['edge']} planned {e['planned_m']:.2f} m, "
                                   f"{e['ratio']:.2f} x its declared {e['declared_m']:.2f} m"
                                   for e in check["long"]],
                       f"edges planned > {LONG_RATIO:g} x declared")
    return line, errors, warnings


def lanes_of(pm):
    """The map's lanes for its robot radius (navigation/lanes.py)."""
    from tpuaf.navigation.lanes import find_lanes
    from tpuaf.navigation.planner import shared_planner

    return find_lanes(shared_planner(pm, float(pm.settings.robot_radius)), pm)


def lane_summary(pm, lane_map) -> list[dict]:
    ids = pm.vertex_ids
    texts = lane_map.describe(ids)
    return [{"edges": [[ids[u], ids[v]] for u, v in lane.edges],
             "waiting_spots": [ids[s] for s in lane.spots],
             "narrowest_band_m": round(lane.min_width_m, 3), "text": text}
            for lane, text in zip(lane_map.lanes, texts, strict=True)]


def picture(pm, folder: str, lane_map, orientation=None):
    """DIR/<map>.png: the map and graph, lanes drawn over it (their planned paths), one-way
    lanes with arrows."""
    from pathlib import Path

    from tpuaf.experiments.graph_figure import graph_png

    out = Path(folder)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise CliError(f"--picture: cannot create folder {out}: {err.strerror}") from None
    lanes = None
    if lane_map is not None:
        from tpuaf.navigation.planner import shared_planner

        planner = shared_planner(pm, float(pm.settings.robot_radius))
        lanes = [([planner.edge_path(u, v) for u, v in lane.edges], list(lane.spots))
                 for lane in lane_map.lanes]
    return graph_png(pm, out / f"{pm.name}.png", lanes=lanes,
                     arrows=orientation.arcs if orientation is not None else None,
                     title=f"{pm.name}" + (f": {len(lanes)} lane{'' if len(lanes) == 1 else 's'}"
                                           if lanes is not None else "")
                     + (f", {len(orientation.chains)} one-way" if orientation else ""))


def run(args: argparse.Namespace) -> int:
    from tpuaf.maps import MapError, builtin_map_names, load_map, map_summary
    from tpuaf.maps.params import CLI, effective_params, format_params

    names = args.maps or builtin_map_names()
    overrides = map_params(args)
    summaries = []
    for name in names:
        try:
            pm = load_map(name, allow_occupied_vertices=args.allow_occupied_vertices,
                          params=overrides, params_origin=CLI)
        except MapError as err:
            raise CliError(str(err)) from None
        summary = map_summary(pm)
        summary["parameters"] = effective_params(pm)
        summary["edge_check"] = edge_check(pm)
        if pm.notes:
            summary["notes"] = list(pm.notes)
        if pm.warnings:
            summary["warnings"] = list(pm.warnings)
        lane_map = lanes_of(pm) if args.lanes else None
        orientation = None
        if lane_map is not None:
            from tpuaf.navigation.one_way import orient_lanes

            summary["lanes"] = lane_summary(pm, lane_map)
            orientation = orient_lanes(lane_map, pm) if lane_map else None
            summary["one_way"] = ({"text": orientation.describe(pm.vertex_ids),
                                   "arcs": [[pm.vertex_ids[u], pm.vertex_ids[v]]
                                            for u, v in orientation.arcs]}
                                  if orientation is not None else None)
        if args.picture:
            summary["picture"] = str(picture(pm, args.picture, lane_map, orientation))
        for warning in pm.warnings:
            print(f"tpuaf maps: warning ({pm.name}): {warning}", file=sys.stderr)
        summaries.append(summary)
    if args.json:
        print(json.dumps(summaries, indent=2))
    else:
        print(format_table(summaries))
        for s in summaries:
            print(format_params(s["name"], s["parameters"]))
        for s in summaries:
            for note in s.get("notes", []):
                print(f"note ({s['name']}): {note}")
            if "lanes" in s:
                print(f"lanes of {s['name']}: {len(s['lanes'])} (one robot wide, entered "
                      "holding a lock from a waiting spot)")
                for lane in s["lanes"]:
                    print("  " + lane["text"])
                if s.get("one_way"):
                    print(f"traffic orientation of {s['name']} (one-way lanes: no lock; "
                          "two-way lanes keep theirs):")
                    for text in s["one_way"]["text"]:
                        print("  " + text)
    blocked = False
    for s in summaries:
        line, errors, warnings = format_edge_check(s["name"], s["edge_check"],
                                                   args.allow_occupied_vertices)
        if not args.json:
            print(line, flush=True)
        for text in errors + warnings:
            print(text, file=sys.stderr, flush=True)
        blocked = blocked or bool(errors)
    return 2 if blocked else 0
