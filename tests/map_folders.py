"""Hand-made map folders for tests (our format: map.yaml, graph.yaml, occupancy.yaml and a PGM
image), written once for every test that builds its own corridor, rooms or aisles."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def write_map_folder(folder: Path, occupied: np.ndarray, vertices, edges, *, res: float,
                     settings: dict[str, float], name: str | None = None,
                     extra_settings: str = "") -> Path:
    """A map folder from `occupied[row, col]` (row 0 at the bottom, y up; `res` [m per cell],
    origin at 0, 0). `vertices`: (x, y) [m] with ids 0, 1, ... in order, or (id, x, y);
    `settings`: map.yaml settings (nominal_speed [m/s], goal_tolerance [m], robot_radius [m])."""
    folder.mkdir(parents=True, exist_ok=True)
    h, w = occupied.shape
    pixels = np.where(occupied, 0, 254).astype(np.uint8)[::-1]  # the image's first row: the top
    (folder / "occupancy.pgm").write_bytes(f"P5\n{w} {h}\n255\n".encode() + pixels.tobytes())
    (folder / "occupancy.yaml").write_text(
        f"image: occupancy.pgm\nresolution: {res}\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    (folder / "map.yaml").write_text(
        f"name: {name or folder.name}\ngraph: graph.yaml\noccupancy: occupancy.yaml\n"
        "settings:\n" + "".join(f"  {key}: {value}\n" for key, value in settings.items())
        + extra_settings)
    rows = [v if len(v) == 3 else (i, *v) for i, v in enumerate(vertices)]
    (folder / "graph.yaml").write_text(
        "vertices:\n" + "".join(f"  - {{id: {i}, x: {x}, y: {y}}}\n" for i, x, y in rows)
        + "edges:\n" + "".join(f"  - [{u}, {v}]\n" for u, v in edges))
    return folder


def write_map_server(folder: Path, free, size_m: tuple[float, float], name: str,
                     res: float = 0.05, origin: tuple[float, float] = (0.0, 0.0),
                     walls=()) -> Path:
    """A ROS map_server YAML + PGM (what `tpuaf graph` reads): walls everywhere but the free
    rectangles (x0, y0, x1, y1) [m, from the image's lower left corner] of a size_m (width,
    height) [m] map whose lower left corner is at `origin` [m], then the `walls` rectangles
    inside them."""
    folder.mkdir(parents=True, exist_ok=True)
    w, h = int(size_m[0] / res), int(size_m[1] / res)
    grid = np.zeros((h, w), dtype=np.uint8)  # row 0 = bottom
    for value, rects in ((254, free), (0, walls)):
        for x0, y0, x1, y1 in rects:
            grid[int(round(y0 / res)):int(round(y1 / res)),
                 int(round(x0 / res)):int(round(x1 / res))] = value
    (folder / f"{name}.pgm").write_bytes(f"P5\n{w} {h}\n255\n".encode() + grid[::-1].tobytes())
    path = folder / f"{name}.yaml"
    path.write_text(f"image: {name}.pgm\nresolution: {res}\n"
                    f"origin: [{origin[0]}, {origin[1]}, 0.0]\n"
                    "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return path
