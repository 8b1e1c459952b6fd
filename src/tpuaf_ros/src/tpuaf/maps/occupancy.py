"""Occupancy grids in the ROS map_server convention (SPEC section 2), and corridors from a graph.

`OccupancyGrid.occupied[row, col]` has row 0 at the BOTTOM of the map (y up, the ROS map frame),
unlike the image file, whose first row is the top. Cell (row, col) covers
x in [origin_x + col * res, origin_x + (col + 1) * res), likewise y with row.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from tpuaf_core import yamlfile

from tpuaf.errors import MapError


@dataclass
class OccupancyGrid:
    occupied: np.ndarray  # bool, shape (height, width); row 0 is the BOTTOM row of the map (y up)
    resolution: float  # m per cell
    origin: tuple[float, float]  # (x, y) [m] of the lower-left corner of cell (0, 0)
    source: Path | None = None

    @property
    def height(self) -> int:
        return int(self.occupied.shape[0])

    @property
    def width(self) -> int:
        return int(self.occupied.shape[1])

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(x_min, y_min, x_max, y_max) [m] of the whole grid."""
        x0, y0 = self.origin
        return (x0, y0, x0 + self.width * self.resolution, y0 + self.height * self.resolution)

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """(row, col) of the cell containing (x, y) [m]; may lie outside the grid."""
        col = int(np.floor((x - self.origin[0]) / self.resolution))
        row = int(np.floor((y - self.origin[1]) / self.resolution))
        return row, col

    def is_free(self, x: float, y: float) -> bool:
        """True when (x, y) [m] lies on a free cell; outside the grid is not free."""
        row, col = self.cell_of(x, y)
        if row < 0 or col < 0 or row >= self.height or col >= self.width:
            return False
        return not bool(self.occupied[row, col])

    def free_area_m2(self) -> float:
        return float(np.count_nonzero(~self.occupied)) * self.resolution**2


# ---------------------------------------------------------------------------------------------
# Image readers


MAX_IMAGE_BYTES = 1 << 30  # an image file [B]
MAX_IMAGE_PIXELS = 200_000_000  # e.g. 14,000 x 14,000 px at 5 cm: a 700 m square
BYTES_PER_PIXEL = 64  # peak while decoding: RGBA float32, its float64 copy, grey, masks


def _read_bytes(path: Path) -> bytes:
    return yamlfile.read_regular_bytes(path, MapError, max_bytes=MAX_IMAGE_BYTES, what="image")


def check_pixels(path: Path, width: int, height: int) -> None:
    """Refuse, before decoding, an image too large for MAX_IMAGE_PIXELS or this machine's
    memory (the estimate: BYTES_PER_PIXEL per pixel)."""
    from tpuaf.files import available_bytes

    pixels = width * height
    budget = available_bytes() * 3 // 4
    most = min(MAX_IMAGE_PIXELS, budget // BYTES_PER_PIXEL)
    if pixels > most:
        raise MapError(f"{path}: a {width:,} x {height:,} px image ({pixels:,} px) would need "
                       f"about {pixels * BYTES_PER_PIXEL / 1e9:,.1f} GB to decode; at most "
                       f"{most:,} px fit (e.g. {int(most ** 0.5):,} x {int(most ** 0.5):,})")


def _png_size(path: Path, data: bytes) -> tuple[int, int]:
    """Width and height [px] from a PNG's IHDR chunk (read before decoding)."""
    if data[:8] != b"\x89PNG\r\n\x1a\n" or data[12:16] != b"IHDR" or len(data) < 24:
        raise MapError(f"{path}: not a PNG image (no PNG signature and IHDR header)")
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def _read_pnm(path: Path) -> np.ndarray:
    """Grey values of a binary (P5) or ASCII (P2) PGM, in [0, 1], first row = image top."""
    data = _read_bytes(path)
    magic = data[:2]
    if magic not in (b"P5", b"P2"):
        raise MapError(f"{path}: not a PGM image (magic {magic!r}, expected P5 or P2)")
    # Header: magic, width, height, maxval, separated by whitespace and '#' comments.
    fields: list[int] = []
    pos = 2
    n = len(data)
    while len(fields) < 3:
        while pos < n and data[pos : pos + 1].isspace():
            pos += 1
        if pos < n and data[pos : pos + 1] == b"#":
            while pos < n and data[pos : pos + 1] not in (b"\n", b"\r"):
                pos += 1
            continue
        start = pos
        while pos < n and not data[pos : pos + 1].isspace() and data[pos : pos + 1] != b"#":
            pos += 1
        token = data[start:pos]
        if not token:
            raise MapError(f"{path}: truncated PGM header")
        if not token.isdigit():
            raise MapError(f"{path}: bad PGM header value {token.decode(errors='replace')!r}")
        fields.append(int(token))
    width, height, maxval = fields
    if width <= 0 or height <= 0 or not 0 < maxval < 65536:
        raise MapError(f"{path}: bad PGM size {width}x{height} or maxval {maxval}")
    check_pixels(path, width, height)
    count = width * height
    if magic == b"P5":
        pos += 1  # exactly one whitespace byte after maxval
        dtype = np.dtype(">u2") if maxval > 255 else np.dtype("u1")
        raw = data[pos : pos + count * dtype.itemsize]
        if len(raw) < count * dtype.itemsize:
            raise MapError(
                f"{path}: truncated PGM data ({len(raw)} of {count * dtype.itemsize} bytes)"
            )
        pixels = np.frombuffer(raw, dtype=dtype).astype(float)
    else:
        body = re.sub(rb"#[^\n]*", b"", data[pos:]).split()
        if len(body) < count:
            raise MapError(f"{path}: truncated PGM data ({len(body)} of {count} values)")
        try:
            pixels = np.array([int(v) for v in body[:count]], dtype=float)
        except ValueError:
            raise MapError(f"{path}: non-integer value in ASCII PGM data") from None
    return pixels.reshape(height, width) / maxval


def _read_png(path: Path) -> np.ndarray:
    data = _read_bytes(path)
    check_pixels(path, *_png_size(path, data))
    try:
        import io

        import matplotlib.image as mpimg

        img = np.asarray(mpimg.imread(io.BytesIO(data), format="png"), dtype=float)
    except Exception as err:  # noqa: BLE001 - any decoder failure is a bad file
        raise MapError(f"{path}: cannot read PNG image: {err}") from None
    if img.ndim == 3:
        img = img[..., :3].mean(axis=2)  # alpha ignored; colour averaged to grey
    if img.max(initial=0.0) > 1.0:
        img = img / 255.0
    return img


def read_image(path: Path) -> np.ndarray:
    """Grey values in [0, 1] (1 = white), first row = top of the image."""
    if not path.is_file():
        raise MapError(f"{path}: image file not found")
    if path.suffix.lower() == ".png":
        return _read_png(path)
    return _read_pnm(path)


# ---------------------------------------------------------------------------------------------
# map_server YAML

_MAP_SERVER_KEYS = {"image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh",
                    "mode"}


# A number as text: YAML 1.1 reads `5e-2` (no dot) as a string, and ROS map yamls quote
# numbers ("0.075"); both are numbers to every ROS tool.
NUMBER_TEXT = re.compile(r"[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?")


def as_number(value: Any) -> Any:
    """`value` as a float when it is a number's text (quoted or `5e-2`); else unchanged."""
    if isinstance(value, str) and NUMBER_TEXT.fullmatch(value.strip()):
        return float(value)
    return value


def _number(path: Path, key: str, value: Any) -> float:
    value = as_number(value)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or \
            not math.isfinite(value):
        raise MapError(f"{path}: '{key}' must be a finite number (e.g. 0.05, 5e-2 or "
                       f"\"0.05\"), got {yamlfile.shorten(repr(value))}")
    return float(value)


def _flag(path: Path, key: str, value: Any) -> bool:
    """map_server's 0/1 flag (`negate`): 0, 1, true, false, or their quoted text."""
    value = as_number(value)
    if isinstance(value, bool) or value in (0, 1):
        return bool(value)
    text = str(value).strip().lower() if isinstance(value, str) else None
    if text in ("true", "false"):
        return text == "true"
    raise MapError(f"{path}: '{key}' must be 0 or 1 (or true / false), got "
                   f"{yamlfile.shorten(repr(value))}")


def load_occupancy(yaml_path: str | Path, image_fallbacks: tuple[Path, ...] = ()) -> OccupancyGrid:
    """Occupancy grid from a map_server YAML and its PGM (P5/P2) or PNG image.

    A pixel with occupancy probability p (p = (255 - v) / 255, or v / 255 when `negate`) is
    occupied when p > occupied_thresh, free when p < free_thresh, and unknown otherwise;
    unknown counts as occupied. `image_fallbacks`: images tried in turn when the file named
    in the YAML does not exist (used by the patrolling_sim importer).
    """
    path = Path(yaml_path)
    data = yamlfile.read_regular_bytes(path, MapError, max_bytes=yamlfile.MAX_YAML_BYTES,
                                       what="map YAML")
    text = yamlfile.decode_utf8(data, path, MapError)
    doc = yamlfile.parse_yaml(text, path, MapError, lines=False)  # as map_server reads it
    if not isinstance(doc, dict):
        raise MapError(f"{path}: expected a map_server YAML mapping")
    yamlfile.check_keys(doc, _MAP_SERVER_KEYS, None, str(path), MapError)
    for key in ("image", "resolution", "origin"):
        if key not in doc:
            raise MapError(f"{path}: missing key '{key}'")
    resolution = _number(path, "resolution", doc["resolution"])
    if not resolution > 0:
        raise MapError(f"{path}: 'resolution' must be > 0, got {resolution}")
    origin = doc["origin"]
    if not isinstance(origin, list) or len(origin) < 2:
        raise MapError(f"{path}: 'origin' must be [x, y, yaw], got "
                       f"{yamlfile.shorten(repr(origin))}")
    ox, oy = (_number(path, "origin", v) for v in origin[:2])
    if len(origin) > 2 and _number(path, "origin", origin[2]) != 0.0:
        raise MapError(f"{path}: rotated map origins (yaw != 0) are not supported")
    negate = _flag(path, "negate", doc.get("negate", 0))
    occ_t = _number(path, "occupied_thresh", doc.get("occupied_thresh", 0.65))
    free_t = _number(path, "free_thresh", doc.get("free_thresh", 0.196))
    if not 0.0 <= free_t <= occ_t <= 1.0:
        raise MapError(f"{path}: need 0 <= free_thresh <= occupied_thresh <= 1")
    image = path.parent / str(doc["image"])
    if not image.is_file():
        found = [p for p in image_fallbacks if p.is_file()]
        if not found:
            raise MapError(f"{path}: image file '{doc['image']}' not found (looked in {path.parent})")
        image = found[0]
    grey = read_image(image)
    p_occ = grey if negate else 1.0 - grey
    free = p_occ < free_t
    occupied = ~free  # occupied and unknown
    return OccupancyGrid(np.ascontiguousarray(occupied[::-1]), resolution, (ox, oy), source=image)


def write_occupancy(grid: OccupancyGrid, yaml_path: str | Path) -> None:
    """Write `grid` as map_server YAML + binary PGM (occupied black, free white)."""
    path = Path(yaml_path)
    image = path.with_suffix(".pgm")
    pixels = np.where(grid.occupied[::-1], 0, 254).astype(np.uint8)
    header = f"P5\n# tpuaf generated\n{grid.width} {grid.height}\n255\n".encode()
    image.write_bytes(header + pixels.tobytes())
    doc = {
        "image": image.name,
        "resolution": float(grid.resolution),
        "origin": [float(grid.origin[0]), float(grid.origin[1]), 0.0],
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,
    }
    path.write_text(yaml.safe_dump(doc, sort_keys=False))


# ---------------------------------------------------------------------------------------------
# Corridors generated from a patrol graph


def default_corridor_width(patrol_map: Any) -> float:
    """[m]: wide enough for two robots to pass and for the goal tolerance disc."""
    s = patrol_map.settings
    return float(max(6.0 * s.robot_radius, 2.0 * s.goal_tolerance + 2.0 * s.robot_radius))


MAX_GENERATED_CELLS = 4.0e7  # cells of a generated grid (bool: 40 MB), e.g. 316 m square at 5 cm


def corridors_from_graph(
    patrol_map: Any,
    corridor_width_m: float | None = None,
    resolution_m: float | None = None,
    bounds: tuple[float, float, float, float] | None = None,
) -> OccupancyGrid:
    """Free space = straight corridors of `corridor_width_m` along every edge (and a disc of
    that diameter around every vertex); everything else is occupied.

    `bounds` (x_min, y_min, x_max, y_max) [m] fixes the grid extent; by default it is the
    vertices' bounding box plus one corridor width. Defaults: the map's `corridor_width` /
    `bounds` when it has them, width from `default_corridor_width`, resolution = min(0.05 m,
    width / 8).
    """
    width = corridor_width_m or getattr(patrol_map, "corridor_width", None)
    width = float(width) if width else default_corridor_width(patrol_map)
    res = float(resolution_m) if resolution_m else min(0.05, width / 8.0)
    if not (width > 0 and res > 0):
        raise MapError("corridor width and resolution must be > 0")
    pos = np.asarray(patrol_map.positions, dtype=float)
    bounds = bounds or getattr(patrol_map, "bounds", None)
    if bounds is None:
        lo = pos.min(axis=0) - width
        hi = pos.max(axis=0) + width
    else:
        lo = np.array(bounds[:2], dtype=float)
        hi = np.array(bounds[2:], dtype=float)
    span = hi - lo
    cells = float(span[0] / res) * float(span[1] / res)
    coarse = math.sqrt(float(span[0]) * float(span[1]) / MAX_GENERATED_CELLS)
    if not cells <= MAX_GENERATED_CELLS and not resolution_m and coarse <= width / 4.0:
        res = coarse  # a large map: coarser cells, still 4 across a corridor
        cells = float(span[0] / res) * float(span[1] / res)
    if not cells <= MAX_GENERATED_CELLS * 1.0001:
        where = f"map '{patrol_map.name}'" if hasattr(patrol_map, "name") else "map"
        raise MapError(f"{where}: spans {span[0]:g} x {span[1]:g} m; corridors generated at "
                       f"{res:g} m would need {cells:.3g} cells (at most "
                       f"{MAX_GENERATED_CELLS:.0e}): give an occupancy image or smaller bounds")
    cols = max(1, int(round(span[0] / res)))
    rows = max(1, int(round(span[1] / res)))
    xs = lo[0] + (np.arange(cols) + 0.5) * res
    ys = lo[1] + (np.arange(rows) + 0.5) * res
    half2 = (width / 2.0) ** 2
    free = np.zeros((rows, cols), dtype=bool)
    segments = [(u, v) for u, v, *_ in patrol_map.edges]
    for u, v in segments:
        a, b = pos[u], pos[v]
        # Only the cells of the segment's bounding box (plus half a width) can be free.
        c0 = max(0, int(np.floor((min(a[0], b[0]) - width / 2 - lo[0]) / res)))
        c1 = min(cols, int(np.ceil((max(a[0], b[0]) + width / 2 - lo[0]) / res)) + 1)
        r0 = max(0, int(np.floor((min(a[1], b[1]) - width / 2 - lo[1]) / res)))
        r1 = min(rows, int(np.ceil((max(a[1], b[1]) + width / 2 - lo[1]) / res)) + 1)
        if c0 >= c1 or r0 >= r1:
            continue
        px = xs[c0:c1][None, :] - a[0]
        py = ys[r0:r1][:, None] - a[1]
        d = b - a
        dd = float(d @ d)
        t = np.clip((px * d[0] + py * d[1]) / dd, 0.0, 1.0) if dd > 0 else 0.0
        ex = px - t * d[0]
        ey = py - t * d[1]
        free[r0:r1, c0:c1] |= ex * ex + ey * ey <= half2
    for x, y in pos:
        c0 = max(0, int(np.floor((x - width / 2 - lo[0]) / res)))
        c1 = min(cols, int(np.ceil((x + width / 2 - lo[0]) / res)) + 1)
        r0 = max(0, int(np.floor((y - width / 2 - lo[1]) / res)))
        r1 = min(rows, int(np.ceil((y + width / 2 - lo[1]) / res)) + 1)
        if c0 < c1 and r0 < r1:
            dx = xs[c0:c1][None, :] - x
            dy = ys[r0:r1][:, None] - y
            free[r0:r1, c0:c1] |= dx * dx + dy * dy <= half2
    return OccupancyGrid(~free, res, (float(lo[0]), float(lo[1])))
