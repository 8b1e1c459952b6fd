"""Map statistics (SPEC section 7): size, edges, lengths and the Fiedler value."""

from __future__ import annotations

import numpy as np

from tpuaf.maps.model import PatrolMap

DENSE_FIEDLER_MAX = 1000  # vertices: up to this many, the dense eigensolver (exact, < 0.2 s)
SHIFT = -1e-6  # shift-invert target of the sparse solver, just below L's eigenvalue 0


def weight_matrix(patrol_map: PatrolMap, sparse: bool = False):
    """Symmetric weights W_ij = edge length [m] (0 where there is no edge): a dense array, or
    with `sparse` a scipy CSR matrix (no n x n array)."""
    g = patrol_map.graph
    n = g.num_vertices
    edges = g.edges
    if sparse:
        from scipy.sparse import coo_matrix

        u = np.array([e[0] for e in edges], dtype=np.int64)
        v = np.array([e[1] for e in edges], dtype=np.int64)
        length = np.array([e[2] for e in edges], dtype=float)
        return coo_matrix((np.r_[length, length], (np.r_[u, v], np.r_[v, u])), shape=(n, n)).tocsr()
    w = np.zeros((n, n))
    for u, v, length in edges:
        w[u, v] = w[v, u] = length
    return w


def fiedler_value(patrol_map: PatrolMap, dense_max: int = DENSE_FIEDLER_MAX) -> float:
    """Algebraic connectivity: 2nd smallest eigenvalue of the symmetric normalised Laplacian
    L = I - D^-1/2 W D^-1/2 with W_ij = edge length [m] (the paper's Table 1 values). Up to
    `dense_max` vertices all eigenvalues of the dense L; beyond, the two nearest SHIFT of the
    sparse L (scipy's eigsh, shift-invert: a sparse factorisation, O(edges) memory)."""
    n = patrol_map.graph.num_vertices
    if n < 2:
        return 0.0
    if n > dense_max:
        from scipy.sparse import diags, identity
        from scipy.sparse.linalg import eigsh

        w = weight_matrix(patrol_map, sparse=True)
        inv_sqrt = diags(1.0 / np.sqrt(np.asarray(w.sum(axis=1)).ravel()))
        lap = (identity(n, format="csc") - inv_sqrt @ w @ inv_sqrt).tocsc()
        values = eigsh(lap, k=2, sigma=SHIFT, which="LM", return_eigenvectors=False)
        return float(np.sort(values)[1])
    w = weight_matrix(patrol_map)
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
