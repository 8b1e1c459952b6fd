"""`tpuaf graph MAP_YAML --out DIR`: a patrol graph generated from a ROS occupancy map
(maps/generate.py), every edge planned for the robot's footprint (navigation/planner.py), written
as a map folder our tools and patrolling_sim read, with its picture (docs/MAPS.md)."""

from __future__ import annotations

import argparse
import math
import re
import sys
from pathlib import Path

from tpuaf.errors import CliError

PRELOAD = ("numpy", "scipy.ndimage", "scipy.sparse.csgraph", "tpuaf.maps.generate")


def _point(text: str) -> tuple[float, float]:
    """An argparse type: 'X,Y' [m]."""
    parts = text.split(",")
    try:
        x, y = (float(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected X,Y in metres, got {text!r}") from None
    if not (math.isfinite(x) and math.isfinite(y)):
        raise argparse.ArgumentTypeError(f"expected finite X,Y in metres, got {text!r}")
    return x, y


def _number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("map_yaml", metavar="MAP_YAML",
                   help="ROS map_server YAML (image, resolution, origin, negate, thresholds)")
    p.add_argument("--out", required=True, type=Path,
                   help="map folder to write (new or empty): map.yaml, graph.yaml, <name>.graph, "
                   "<name>.yaml + .pgm, generation.yaml, graph.png")
    p.add_argument("--robot", default="auto",
                   help="robot preset (burger, waffle, waffle_pi, patrolling_sim) or auto "
                   "($TURTLEBOT3_MODEL, else the default map's preset): its radius [m]")
    p.add_argument("--sensing-radius", type=_number, default=None, metavar="M",
                   help="sensing radius r [m] (default: the robot's laser range)")
    p.add_argument("--min-spacing", type=_number, default=0.0, metavar="M",
                   help="least distance between two targets [m] (default 0; never under two "
                        "work cells nor a robot's width, 2 (radius + 0.15 m))")
    p.add_argument("--fixed", type=_point, action="append", default=[], metavar="X,Y",
                   help="a target that must be a vertex [m] (repeatable)")
    p.add_argument("--coverage", type=_number, default=1.0, metavar="F",
                   help="fraction of the reachable free cells seen by some target (default 1: "
                   "every cell any drivable spot sees)")
    p.add_argument("--name", default=None, help="map name (default: the YAML's file name)")


def _check_out(out: Path) -> None:
    if out.exists() and not out.is_dir():
        raise CliError(f"--out {out}: is an existing file, not a folder")
    if out.is_dir() and any(out.iterdir()):
        raise CliError(f"--out {out}: folder exists and is not empty: choose a new folder")


def plan_edges(pm, radius_m: float) -> tuple[object, list[dict], list[str]]:
    """The map with every edge's planned length [m] for a robot of `radius_m`, each edge's
    length and free width [m] (2 x the least clearance along its path), and the edges dropped
    for want of a collision-free path."""
    from dataclasses import replace

    import numpy as np

    from tpuaf.navigation.planner import PathPlanner

    planner = PathPlanner(pm, radius_m)
    ids = pm.vertex_ids
    kept, table, dropped = [], [], []
    for c in planner.check_edges():
        if not math.isfinite(c.planned_m):
            dropped.append(f"{ids[c.u]}-{ids[c.v]}")
            continue
        path = planner.edge_path(c.u, c.v)
        seg = np.diff(path, axis=0)
        steps = np.maximum(1, np.ceil(np.hypot(seg[:, 0], seg[:, 1]) / 0.02).astype(int))
        points = np.vstack([path[k] + np.linspace(0, 1, s, endpoint=False)[:, None] * seg[k]
                            for k, s in enumerate(steps)] + [path[-1:]])
        width = 2.0 * float(planner.distances_to_obstacle(points).min())
        kept.append((c.u, c.v, c.planned_m))
        table.append({"edge": [ids[c.u], ids[c.v]], "length_m": round(c.planned_m, 3),
                      "free_width_m": round(width, 3)})
    return replace(pm, edges=kept), table, dropped


def _main_part(n: int, edges) -> list[int]:
    """The vertices of the largest connected part of a graph on 0..n-1 (union-find)."""
    parent = list(range(n))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for u, v, *_ in edges:
        parent[root(u)] = root(v)
    roots = [root(i) for i in range(n)]
    best = max(set(roots), key=roots.count)
    return [i for i in range(n) if roots[i] == best]


def _keep_main_part(pm, gen, table: list[dict], opts) -> tuple[object, list[str]]:
    """Vertices cut off by dropped edges are dropped (named); the generated graph's kinds,
    coverage and covered mask follow."""
    from dataclasses import replace

    from tpuaf.maps.generate import coverage_of

    keep = _main_part(pm.num_vertices, pm.edges)
    if len(keep) == pm.num_vertices:
        return pm, []
    new = {old: k for k, old in enumerate(keep)}
    gone = [str(i) for i in range(pm.num_vertices) if i not in new]
    edges = [(new[u], new[v], d) for u, v, d in pm.edges if u in new and v in new]
    table[:] = [e for e in table if e["edge"][0] in new and e["edge"][1] in new]
    for e in table:
        e["edge"] = [new[e["edge"][0]], new[e["edge"][1]]]
    pm = replace(pm, vertex_ids=list(range(len(keep))), positions=pm.positions[keep],
                 edges=edges, importance=pm.importance[keep],
                 initial_uncertainty=pm.initial_uncertainty[keep])
    gen.positions = pm.positions
    gen.kinds = [gen.kinds[i] for i in keep]
    gen.coverage, gen.covered = coverage_of(gen.grid, pm.positions, opts.sensing_radius_m)
    return pm, [f"dropped vertex {', '.join(gone)}: no collision-free path to the rest"]


def build(occ, opts, name: str, settings) -> tuple[object, object, dict]:
    """(patrol map with planned edge lengths, the generated graph, the report) for occupancy
    grid `occ` and GraphOptions `opts`; `settings`: the MapSettings to write."""
    import numpy as np

    from tpuaf.maps.generate import generate_graph
    from tpuaf.maps.model import PatrolMap
    from tpuaf.maps.tours import cyclic_tour

    gen = generate_graph(occ, opts)
    n = len(gen.positions)
    pm = PatrolMap(name=name, vertex_ids=list(range(n)), positions=gen.positions,
                   edges=gen.edges, importance=np.full(n, settings.default_importance),
                   initial_uncertainty=np.full(n, settings.default_initial_uncertainty),
                   settings=settings, occupancy=occ,
                   description=f"generated by tpuaf graph from {occ.source}")
    try:
        pm, table, dropped = plan_edges(pm, opts.robot_radius_m)
        pm, cut_off = _keep_main_part(pm, gen, table, opts)
        gen.notes += cut_off
        pm.graph  # noqa: B018 - validates the graph written
    except Exception as err:
        from tpuaf.errors import MapError

        if not isinstance(err, MapError):
            raise
        raise MapError(f"{err} (edges without a collision-free path were dropped)") from None
    tour = cyclic_tour(pm).length if n > 1 else 0.0
    report = {
        "vertices": n, "edges": len(pm.edges), "coverage": round(gen.coverage, 4),
        "tour_length_m": round(float(tour), 2),
        "dead_ends": gen.kinds.count("dead end"), "fixed": gen.kinds.count("fixed"),
        "work_cell_m": round(gen.grid.cell_m, 4), "dropped_edges": dropped,
        "notes": list(gen.notes), "edge_table": table,
    }
    return pm, gen, report


def write_folder(pm, gen, report: dict, out: Path, opts) -> None:
    """map.yaml + graph.yaml (ours), <name>.graph + <name>.yaml + .pgm (patrolling_sim),
    generation.yaml (options, figures, edges), graph.png."""
    import yaml

    from tpuaf.experiments.graph_figure import graph_png
    from tpuaf.maps.mapfile import save_map_folder
    from tpuaf.maps.patrolling_sim import write_graph

    out.mkdir(parents=True, exist_ok=True)
    save_map_folder(pm, out, occupancy_file=True, occupancy_name=f"{pm.name}.yaml",
                    header="generated by `tpuaf graph` (docs/MAPS.md)")
    write_graph(pm, out / f"{pm.name}.graph", pm.occupancy)
    doc = {"options": {"robot_radius_m": opts.robot_radius_m,
                       "sensing_radius_m": opts.sensing_radius_m,
                       "min_spacing_m": opts.min_spacing_m, "coverage": opts.coverage,
                       "fixed": [list(p) for p in opts.fixed], "margin_m": opts.margin_m},
           **{k: v for k, v in report.items() if k != "edge_table"},
           "vertex_kinds": {i: k for i, k in zip(pm.vertex_ids, gen.kinds, strict=True)},
           "edges_m": report["edge_table"]}
    (out / "generation.yaml").write_text(yaml.safe_dump(doc, sort_keys=False, width=100))
    g = gen.grid
    x0, y0 = g.origin
    h, w = g.occupied.shape
    graph_png(pm, out / "graph.png", covered=gen.covered, region=g.region,
              extent=(x0, x0 + w * g.cell_m, y0, y0 + h * g.cell_m), kinds=gen.kinds,
              title=f"{pm.name}: {report['vertices']} vertices, coverage "
                    f"{100 * report['coverage']:.1f} % at r = {opts.sensing_radius_m:g} m")


def run(args: argparse.Namespace) -> int:
    from tpuaf.maps.generate import GraphOptions
    from tpuaf.maps.model import MapSettings
    from tpuaf.maps.occupancy import load_occupancy
    from tpuaf.robot.model import choose_robot

    _check_out(args.out)
    yaml_path = Path(args.map_yaml)
    if not yaml_path.is_file():
        raise CliError(f"{yaml_path}: map YAML not found")
    occ = load_occupancy(yaml_path)
    robot = choose_robot(args.robot, MapSettings())
    radius = args.sensing_radius if args.sensing_radius is not None else robot.sensor_range_m
    opts = GraphOptions(robot_radius_m=robot.radius_m, sensing_radius_m=radius,
                        min_spacing_m=args.min_spacing, coverage=args.coverage,
                        fixed=tuple(args.fixed))
    settings = MapSettings(nominal_speed=robot.speed_mps, sensing_radius=radius,
                           robot_radius=robot.radius_m)
    name = args.name or yaml_path.stem
    if not re.fullmatch(r"[A-Za-z0-9_.-]+", name) or name.startswith("."):
        raise CliError(f"--name {name!r}: use letters, digits, '_', '-' and '.' (a file name)")
    pm, gen, report = build(occ, opts, name, settings)
    write_folder(pm, gen, report, args.out, opts)
    print(f"{name}: {report['vertices']} vertices ({report['dead_ends']} dead ends, "
          f"{report['fixed']} fixed), {report['edges']} edges; coverage "
          f"{100 * report['coverage']:.1f} % of the reachable free space at r = {radius:g} m "
          f"(line of sight); cyclic tour {report['tour_length_m']:.1f} m; robot "
          f"{robot.preset} (radius {robot.radius_m:g} m)")
    for note in report["notes"]:
        print(f"tpuaf graph: note: {note}", file=sys.stderr)
    if report["dropped_edges"]:
        print(f"tpuaf graph: note: dropped {len(report['dropped_edges'])} edge(s) without a "
              f"collision-free path: {', '.join(report['dropped_edges'][:10])}", file=sys.stderr)
    print(f"wrote {args.out} (map.yaml, {name}.graph, graph.png)")
    return 0
