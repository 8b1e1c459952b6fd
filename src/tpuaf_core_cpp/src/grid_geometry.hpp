// Grid helpers shared by the costmap, the planning grid, the search and the smoother (internal
// to tpuaf_core_cpp). Cells of a unit grid; lengths in metres where stated.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

namespace tpuaf::grid {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kSqrt2 = 1.4142135623730951;
constexpr double kTol = 1e-9;  // [m] slack of the distance comparisons

inline bool finite(double v) { return std::isfinite(v); }

// Visits, in order, the cells of a unit grid crossed by segment a-b (coordinates in cells):
// visit(col, row, fraction of the segment inside the cell) returns false to stop. Passing
// through a corner also visits the two side cells (fraction 0), to be conservative.
template <class Visit>
bool walk_cells(double ax, double ay, double bx, double by, Visit&& visit) {
  int cx = static_cast<int>(std::floor(ax)), cy = static_cast<int>(std::floor(ay));
  const int ex = static_cast<int>(std::floor(bx)), ey = static_cast<int>(std::floor(by));
  const double dx = bx - ax, dy = by - ay;
  const int sx = dx > 0 ? 1 : (dx < 0 ? -1 : 0), sy = dy > 0 ? 1 : (dy < 0 ? -1 : 0);
  const double tdx = sx ? 1.0 / std::abs(dx) : kInf, tdy = sy ? 1.0 / std::abs(dy) : kInf;
  double tx = sx > 0 ? (cx + 1 - ax) / dx : (sx < 0 ? (ax - cx) / -dx : kInf);
  double ty = sy > 0 ? (cy + 1 - ay) / dy : (sy < 0 ? (ay - cy) / -dy : kInf);
  double t = 0.0;
  for (int guard = std::abs(ex - cx) + std::abs(ey - cy) + 4; guard > 0; --guard) {
    const double tn = std::min(tx, ty);
    if (tn >= 1.0 || (cx == ex && cy == ey)) return visit(cx, cy, 1.0 - t);
    if (!visit(cx, cy, tn - t)) return false;
    if (std::abs(tx - ty) <= 1e-9) {
      if (!visit(cx + sx, cy, 0.0) || !visit(cx, cy + sy, 0.0)) return false;
      cx += sx;
      cy += sy;
      tx += tdx;
      ty += tdy;
    } else if (tx < ty) {
      cx += sx;
      tx += tdx;
    } else {
      cy += sy;
      ty += tdy;
    }
    t = tn;
  }
  return true;
}

// Gap [m] between point (x, y) and the axis-aligned square [x0, x0 + s] x [y0, y0 + s].
inline double gap_to_square(double x, double y, double x0, double y0, double s) {
  const double dx = std::max({x0 - x, 0.0, x - (x0 + s)});
  const double dy = std::max({y0 - y, 0.0, y - (y0 + s)});
  return std::hypot(dx, dy);
}

inline int clamp_cell(double v,
                      int n) {  // floor(v), kept within [-2, n + 1] (outside stays outside)
  return static_cast<int>(std::max(-2.0, std::min(static_cast<double>(n) + 1.0, std::floor(v))));
}

}  // namespace tpuaf::grid
