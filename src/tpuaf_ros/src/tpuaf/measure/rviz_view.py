"""An RViz config framed on a patrol map (ROS-free): the shipped config (rviz/tpuaf.rviz) with
its top-down view centred on the map and zoomed so that the whole map shows (rviz.launch,
`config:=auto`; the node is tpuaf.ros.rviz_view)."""

from __future__ import annotations

import re

import numpy as np

# [px] of RViz's window that the 3-D view does not get: the left dock (Displays panel) and the
# menu, tool bar and status bar (RViz 1.14 at its default font).
DOCK_WIDTH_PX = 330
BARS_HEIGHT_PX = 100
FILL = 0.9  # the map spans at most this fraction of the view's width and height
MIN_SPAN_M = 1.0  # [m] a view never zooms in beyond this span


def map_extent(patrol_map) -> tuple[float, float, float, float]:
    """(x_min, y_min, x_max, y_max) [m]: the vertices and the occupancy grid's image."""
    pos = np.asarray(patrol_map.positions, dtype=float).reshape(-1, 2)
    lo, hi = pos.min(axis=0), pos.max(axis=0)
    grid = patrol_map.occupancy_grid()
    res = float(grid.resolution)
    ox, oy = (float(v) for v in grid.origin[:2])
    lo = np.minimum(lo, [ox, oy])
    hi = np.maximum(hi, [ox + grid.width * res, oy + grid.height * res])
    return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])


def _window(text: str) -> tuple[int, int]:
    """(width, height) [px] of the config's `Window Geometry`."""
    block = text[text.find("Window Geometry:"):]
    width = re.search(r"^  Width: (\d+)", block, re.M)
    height = re.search(r"^  Height: (\d+)", block, re.M)
    return (int(width.group(1)) if width else 1100), (int(height.group(1)) if height else 720)


def top_down_view(extent: tuple[float, float, float, float], width_px: int, height_px: int
                  ) -> dict[str, float]:
    """RViz TopDownOrtho view {X, Y [m], Scale [px/m]} showing `extent` in a window of
    width_px x height_px."""
    x0, y0, x1, y1 = extent
    view_w = max(width_px - DOCK_WIDTH_PX, 100)
    view_h = max(height_px - BARS_HEIGHT_PX, 100)
    span_x, span_y = max(x1 - x0, MIN_SPAN_M), max(y1 - y0, MIN_SPAN_M)
    scale = FILL * min(view_w / span_x, view_h / span_y)
    return {"X": round((x0 + x1) / 2, 4), "Y": round((y0 + y1) / 2, 4), "Scale": round(scale, 3)}


def framed_config(template: str, extent: tuple[float, float, float, float],
                  map_name: str) -> str:
    """`template` (an RViz config with a TopDownOrtho current view) framed on `extent`."""
    start = template.find("  Views:")
    end = template.find("    Saved:", start)
    if start < 0 or end < 0 or "rviz/TopDownOrtho" not in template[start:end]:
        raise ValueError("the RViz config has no TopDownOrtho current view to frame")
    view = top_down_view(extent, *_window(template))
    block = template[start:end]
    for key, value in view.items():
        block, count = re.subn(rf"^(      {key}): .*$", rf"\g<1>: {value:g}", block, flags=re.M)
        if count != 1:
            raise ValueError(f"the RViz config's current view has no single '{key}'")
    x0, y0, x1, y1 = extent
    head = (f"# Framed on map '{map_name}': x {x0:g} .. {x1:g} m, y {y0:g} .. {y1:g} m "
            "(tpuaf.measure.rviz_view)\n")
    return head + template[:start] + block + template[end:]
