"""Map statistics (SPEC section 7): size, edges, lengths and the Fiedler value."""

from __future__ import annotations

import numpy as np

from tpuaf.maps.model import PatrolMap


def weight_matrix(patrol_map: PatrolMap) -> np.ndarray:
    """Symmetric weights W_ij = edge length [m] (0 where there is no edge)."""
    g = patrol_map.graph
    n = g.num_vertices
    w = np.zeros((n, n))
    for u, v, length in g.edges:
        w[u, v] = w[v, u] = length
    return w


def fiedler_value(patrol_map: PatrolMap) -> float:
    """Algebraic connectivity: 2nd smallest eigenvalue of the symmetric normalised Laplacian
    L = I - D^-1/2 W D^-1/2 with W_ij = edge length [m] (the paper's Table 1 values)."""
    w = weight_matrix(patrol_map)
    if w.shape[0] < 2:
        return 0.0
    d = w.sum(axis=1)
    inv_sqrt = 1.0 / np.sqrt(d)
    lap = np.eye(len(d)) - inv_sqrt[:, None] * w * inv_sqrt[None, :]
    return float(np.sort(np.linalg.eigvalsh(lap))[1])


def map_summary(patrol_map: PatrolMap) -> dict:
    """Statistics of a map. `size_*` is the extent of the occupancy grid (the image, or the
    generated corridors' bounds) when the map has one, else the vertices' bounding box;
    `size_source` says which. `free_area_m2` counts the free cells."""
    g = patrol_map.graph
    occ = patrol_map.occupancy
    if occ is not None:
        x0, y0, x1, y1 = occ.extent
        size_source = "occupancy grid extent"
        free_area = occ.free_area_m2()
    else:
        (x0, y0), (x1, y1) = patrol_map.positions.min(axis=0), patrol_map.positions.max(axis=0)
        size_source = "vertex bounding box"
        free_area = None
    lengths = np.array([length for _, _, length in g.edges])
    return {
        "name": patrol_map.name,
        "vertices": g.num_vertices,
        "edges": g.num_edges,
        "size_x_m": float(x1 - x0),
        "size_y_m": float(y1 - y0),
        "area_m2": float((x1 - x0) * (y1 - y0)),
        "size_source": size_source,
        "free_area_m2": free_area,
        "total_edge_length_m": float(lengths.sum()),
        "mean_edge_length_m": float(lengths.mean()) if len(lengths) else 0.0,
        "min_edge_length_m": float(lengths.min()) if len(lengths) else 0.0,
        "max_edge_length_m": float(lengths.max()) if len(lengths) else 0.0,
        "mean_degree": float(2 * g.num_edges / g.num_vertices),
        "fiedler_value": fiedler_value(patrol_map),
        "nominal_speed_m_s": patrol_map.settings.nominal_speed,
        "sensing_radius_m": patrol_map.settings.sensing_radius,
        "interference_distance_m": patrol_map.settings.interference_distance,
        "robot_radius_m": patrol_map.settings.robot_radius,
        "source": str(patrol_map.source) if patrol_map.source else "built-in",
    }
