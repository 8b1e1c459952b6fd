// Path smoothing on the planning grid (the planner's traceback seam): a PathSmoother shortens
// the polyline through a cell path's centres without letting it cross a lethal cell.
#pragma once

#include <Eigen/Dense>
#include <cstddef>
#include <vector>

#include "tpuaf_core/planning_grid.hpp"

namespace tpuaf {

class PathSmoother {
 public:
  virtual ~PathSmoother() = default;
  // Rewrites pts[first + 1 ..] in place [m]; pts[0 .. first] and the last point stay. The
  // weighted length (PlanningGrid::segment_cost) never grows.
  virtual void smooth(const PlanningGrid& grid, std::vector<Eigen::Vector2d>& pts,
                      std::size_t first) const = 0;
};

// The cheapest polyline (weighted length) whose corners are points of the cell path at most
// 8 apart and whose segments cross no lethal cell (dynamic programming), then corners pulled
// towards their chords while the weighted length falls, so the path hugs the lethal boundary
// instead of the cell centres.
class ShortcutSmoother final : public PathSmoother {
 public:
  void smooth(const PlanningGrid& grid, std::vector<Eigen::Vector2d>& pts,
              std::size_t first) const override;

 private:
  void tighten(const PlanningGrid& grid, std::vector<Eigen::Vector2d>& pts,
               std::size_t first) const;
};

}  // namespace tpuaf
