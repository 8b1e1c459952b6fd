"""`tpuaf maps [NAME_OR_PATH ...]`: statistics of maps (SPEC section 7)."""

from __future__ import annotations

import argparse
import json
import sys

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


def run(args: argparse.Namespace) -> int:
    from tpuaf.maps import MapError, builtin_map_names, load_map, map_summary

    names = args.maps or builtin_map_names()
    summaries = []
    for name in names:
        try:
            pm = load_map(name, allow_occupied_vertices=args.allow_occupied_vertices)
        except MapError as err:
            raise CliError(str(err)) from None
        summary = map_summary(pm)
        if pm.notes:
            summary["notes"] = list(pm.notes)
        if pm.warnings:
            summary["warnings"] = list(pm.warnings)
        for warning in pm.warnings:
            print(f"tpuaf maps: warning ({pm.name}): {warning}", file=sys.stderr)
        summaries.append(summary)
    if args.json:
        print(json.dumps(summaries, indent=2))
    else:
        print(format_table(summaries))
        for s in summaries:
            for note in s.get("notes", []):
                print(f"note ({s['name']}): {note}")
    return 0
