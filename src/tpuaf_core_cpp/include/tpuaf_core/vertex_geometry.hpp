// Where a point is against the patrol graph's vertices, each helper written once for every
// runtime: how far a vertex is, whether a point is within a tolerance of it, which vertex is
// nearest. Positions in metres (n x 2, the map frame).
#pragma once

#include <cmath>

#include "tpuaf_core/perception.hpp"

namespace tpuaf {

// [m] default goal tolerance: a navigator may end a leg this far from its vertex, and a robot
// this close to its goal vertex dwells there rather than drive (tpuaf.maps MapSettings).
constexpr double kDefaultGoalToleranceM = 0.4;

// [m] from (x, y) to `vertex` (unchecked index).
inline double vertex_distance(const Points& positions, int vertex, double x, double y) {
  return std::hypot(x - positions(vertex, 0), y - positions(vertex, 1));
}

// Is (x, y) within radius_m [m] of `vertex` (the boundary included)?
inline bool within_vertex(const Points& positions, int vertex, double x, double y,
                          double radius_m) {
  return vertex_distance(positions, vertex, x, y) <= radius_m;
}

// The vertex nearest (x, y), the first on ties (numpy's argmin of hypot); -1 without vertices.
inline int nearest_vertex(const Points& positions, double x, double y) {
  int best = -1;
  double best_d = 0.0;
  for (Eigen::Index v = 0; v < positions.rows(); ++v) {
    const double d = vertex_distance(positions, static_cast<int>(v), x, y);
    if (best < 0 || d < best_d) {
      best_d = d;
      best = static_cast<int>(v);
    }
  }
  return best;
}

}  // namespace tpuaf
