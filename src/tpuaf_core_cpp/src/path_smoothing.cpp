#include "tpuaf_core/path_smoothing.hpp"

#include <algorithm>
#include <cmath>

#include "grid_geometry.hpp"

namespace tpuaf {

using grid::kInf;
using grid::kTol;

void ShortcutSmoother::smooth(const PlanningGrid& grid, std::vector<Eigen::Vector2d>& pts,
                              std::size_t first) const {
  // Cheapest polyline (weighted length) whose corners are points of the cell path at most
  // kWindow apart and whose segments cross no lethal cell (dynamic programming), then tightened.
  constexpr std::size_t kWindow = 8;
  const std::size_t n = pts.size();
  if (n <= first + 2) return;
  std::vector<double> best(n, kInf);  // weighted length from pts[first] [m]
  std::vector<std::size_t> from(n, first);
  best[first] = 0.0;
  for (std::size_t j = first + 1; j < n; ++j) {
    best[j] = best[j - 1] + grid.segment_cost(pts[j - 1], pts[j], false);  // the cell path itself
    from[j] = j - 1;
    for (std::size_t i = j > first + kWindow ? j - kWindow : first; i + 1 < j; ++i) {
      const double c = best[i] + grid.segment_cost(pts[i], pts[j], true);
      if (c < best[j] - kTol) {
        best[j] = c;
        from[j] = i;
      }
    }
  }
  std::vector<std::size_t> corners;
  for (std::size_t j = n - 1; j > first; j = from[j]) corners.push_back(j);
  std::vector<Eigen::Vector2d> out(pts.begin(), pts.begin() + first + 1);
  for (auto it = corners.rbegin(); it != corners.rend(); ++it) out.push_back(pts[*it]);
  pts.swap(out);
  tighten(grid, pts, first);
}

void ShortcutSmoother::tighten(const PlanningGrid& grid, std::vector<Eigen::Vector2d>& pts,
                               std::size_t first) const {
  // Pulls each corner towards the chord of its neighbours as far as the segments stay clear and
  // their weighted length falls (bisection), so the path hugs the lethal boundary instead of
  // the cell centres; midpoints added once become corners that can slide around a bend;
  // corners that become unnecessary are dropped.
  constexpr int kPasses = 2, kSubdivisions = 1, kBisections = 4;
  {  // drop corners on the chord of their neighbours (straight runs of the cell path)
    std::vector<Eigen::Vector2d> out(pts.begin(), pts.begin() + first + 1);
    for (std::size_t i = first + 1; i + 1 < pts.size(); ++i) {
      const Eigen::Vector2d a = out.back(), b = pts[i + 1], v = pts[i];
      const Eigen::Vector2d ab = b - a;
      const double cross = std::abs(ab.x() * (v - a).y() - ab.y() * (v - a).x());
      const bool between = (v - a).dot(ab) >= 0 && (v - b).dot(-ab) >= 0;
      if (between && cross <= 1e-9 * ab.norm()) continue;
      out.push_back(v);
    }
    out.push_back(pts.back());
    pts.swap(out);
  }
  for (int pass = 0; pass < kPasses && pts.size() > first + 2; ++pass) {
    bool moved = false;
    if (pass < kSubdivisions) {
      std::vector<Eigen::Vector2d> finer(pts.begin(), pts.begin() + first + 1);
      for (std::size_t i = first + 1; i < pts.size(); ++i) {
        finer.push_back(0.5 * (pts[i - 1] + pts[i]));
        finer.push_back(pts[i]);
      }
      pts.swap(finer);
    }
    for (std::size_t i = first + 1; i + 1 < pts.size(); ++i) {
      const Eigen::Vector2d a = pts[i - 1], b = pts[i + 1], v = pts[i];
      const Eigen::Vector2d ab = b - a;
      const double len2 = ab.squaredNorm();
      const double t = len2 > 0 ? std::clamp((v - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
      const Eigen::Vector2d q = a + t * ab;               // nearest point of the chord
      if ((q - v).squaredNorm() < kTol * kTol) continue;  // already straight
      double lo = 0.0, hi = 1.0,
             best = grid.segment_cost(a, v, true) + grid.segment_cost(v, b, true);
      for (int k = 0; k < kBisections; ++k) {
        const double mid = 0.5 * (lo + hi);
        const Eigen::Vector2d w = v + mid * (q - v);
        const double c = grid.segment_cost(a, w, true) + grid.segment_cost(w, b, true);
        if (c < best - kTol) {
          lo = mid;
          best = c;
        } else {
          hi = mid;
        }
      }
      if (lo > 0.0) {
        pts[i] = v + lo * (q - v);
        moved = true;
      }
    }
    for (std::size_t i = first + 1; i + 1 < pts.size(); ++i) {  // drop unnecessary corners
      const double now =
          grid.segment_cost(pts[i - 1], pts[i], true) + grid.segment_cost(pts[i], pts[i + 1], true);
      if (grid.segment_cost(pts[i - 1], pts[i + 1], true) <= now + kTol * (1.0 + now)) {
        pts.erase(pts.begin() + static_cast<std::ptrdiff_t>(i));
        --i;
      }
    }
    if (!moved) break;
  }
}

}  // namespace tpuaf
