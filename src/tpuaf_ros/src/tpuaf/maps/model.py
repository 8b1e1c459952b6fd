"""In-memory patrol map: the graph, per-target parameters and per-map settings (SPEC section 7)."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import tpuaf_core

from tpuaf.errors import MapError
from tpuaf.maps.occupancy import corridors_from_graph


@dataclass
class MapSettings:
    """Per-map settings. Units in the names' comments."""

    nominal_speed: float = 1.0  # [m/s]
    sensing_radius: float = 5.0  # r_i [m] of Eq. 1
    sensing_peak: float = 1.0  # G_i of Eq. 1
    interference_distance: float = 2.0  # d_if [m] (SPEC section 6)
    # [m] the navigator may end a leg this far from a vertex (tpuaf_core's declared default)
    goal_tolerance: float = tpuaf_core.DEFAULT_GOAL_TOLERANCE_M
    # [m] a visit is an arrival this close (tpuaf_core.VisitRule; at most goal_tolerance)
    visit_radius: float = tpuaf_core.DEFAULT_VISIT_RADIUS_M
    robot_radius: float = 0.105  # [m], TurtleBot3 Burger
    # g(X) = sum a_l X^l of Eq. 2, and the defaults for targets without a per-vertex value.
    growth_coefficients: list[float] = field(default_factory=lambda: [1.0, 0.6])
    default_importance: float = 0.01  # C_j [1/s-ish units of M]
    default_initial_uncertainty: float = 1.0  # X0_j
    # Start positions per team size: vertex ids, or poses [m] (x, y) snapped to the nearest vertex.
    initial_vertices: dict[int, list[int]] = field(default_factory=dict)
    initial_poses: dict[int, list[tuple[float, float]]] = field(default_factory=dict)
    # Named alternative pose sets, e.g. "4_a" from patrolling_sim's `grid_4_a` key.
    initial_pose_variants: dict[str, list[tuple[float, float]]] = field(default_factory=dict)


@dataclass
class PatrolMap:
    """A patrol graph with metric coordinates, targets' C and X0, and settings.

    Vertex indices (0..n-1) are used inside the core and by the policies; `vertex_ids` are the
    ids of the source file, used in every file we write and every message we print.
    """

    name: str
    vertex_ids: list[int]
    positions: np.ndarray  # (n, 2) [m], map frame
    edges: list[tuple[int, int, float]]  # (i, j, length_m) by index; NaN length = Euclidean
    importance: np.ndarray  # (n,) C_j >= 0
    initial_uncertainty: np.ndarray  # (n,) X0_j >= 0
    settings: MapSettings = field(default_factory=MapSettings)
    source: Path | None = None
    occupancy: Any = None  # tpuaf.maps.occupancy.OccupancyGrid, or None (generated on demand)
    # For a generated occupancy grid (no image): corridor width [m] and extent
    # (x_min, y_min, x_max, y_max) [m]; None = defaults of `corridors_from_graph`.
    corridor_width: float | None = None
    bounds: tuple[float, float, float, float] | None = None
    description: str = ""
    notes: list[str] = field(default_factory=list)  # import remarks (e.g. parallel edges dropped)
    warnings: list[str] = field(default_factory=list)  # geometry doubts (tpuaf.maps.geometry)
    # settings field -> where its value came from (tpuaf.maps.params; absent = MapSettings')
    setting_sources: dict[str, str] = field(default_factory=dict)
    # One-way arcs (u, v) by index: edges driven only from u to v (a traffic orientation of
    # the lanes, navigation/one_way.py); empty: every edge both ways.
    one_way: tuple[tuple[int, int], ...] = ()
    # Vertices no robot can reach by index (a dead robot's body next to them, robot/lanes.py):
    # each keeps one edge (the graph stays connected), plans do not visit them and goals there
    # fail at once; empty: every vertex can be reached.
    closed: frozenset[int] = frozenset()
    # [s] added to edge (u, v)'s duration when the robot arrived at u from w, by index
    # (w, u, v): the turn at u against the mean heading the edge's time assumes (a timed map:
    # navigation/travel_time.py `turn_times`); empty: none.
    turns: dict[tuple[int, int, int], float] = field(default_factory=dict)

    def occupancy_grid(self) -> Any:
        """The occupancy grid: the map's image, or corridors generated from the graph (cached)."""
        if self.occupancy is None:
            self.occupancy = corridors_from_graph(self)
        return self.occupancy

    @cached_property
    def graph(self) -> tpuaf_core.PatrolGraph:
        from tpuaf.maps.geometry import check_coincident

        check_coincident(self)  # two vertices on one spot: named here, not as a short edge
        try:
            return tpuaf_core.PatrolGraph(
                np.asarray(self.positions, dtype=float), list(self.edges), list(self.vertex_ids),
                [(int(u), int(v)) for u, v in self.one_way]
            )
        except (ValueError, IndexError) as err:
            where = f" ({self.source})" if self.source else ""
            raise MapError(f"map '{self.name}'{where}: {err}") from None

    @property
    def num_vertices(self) -> int:
        return len(self.vertex_ids)

    def index_of(self, vertex_id: int) -> int:
        try:
            return self._index[int(vertex_id)]
        except KeyError:
            raise MapError(f"map '{self.name}' has no vertex {vertex_id}") from None

    def lookup_index(self, vertex_id: int) -> int | None:
        """Index of vertex id `vertex_id` (-1 for a negative id: "no vertex"), None when the
        map has no such vertex (a message about another map: ignored by its readers)."""
        if vertex_id < 0:
            return -1
        return self._index.get(int(vertex_id))

    @cached_property
    def _index(self) -> dict[int, int]:
        return {int(v): i for i, v in enumerate(self.vertex_ids)}

    def uncertainty_model(self) -> tpuaf_core.UncertaintyModel:
        return tpuaf_core.UncertaintyModel(list(self.settings.growth_coefficients))

    @property
    def visit_radius_m(self) -> float:
        """[m] the visit radius in force: the setting, at most the goal tolerance."""
        s = self.settings
        return min(float(s.visit_radius), float(s.goal_tolerance))

    def visit_rule(self) -> tpuaf_core.VisitRule:
        """A new VisitRule (the one definition of a visit) for one robot on this map."""
        return tpuaf_core.VisitRule(np.asarray(self.positions, dtype=float), self.visit_radius_m)

    def nearest_vertex(self, x: float, y: float) -> int:
        """The vertex nearest (x, y) [m], the first on ties (the core's one rule)."""
        return tpuaf_core.nearest_vertex(self.positions, float(x), float(y))
