// Global planner on the occupancy grid (move_base-like, global_planner's seams): an inflated
// costmap (costmap.hpp), a search over the padded planning grid (grid_search.hpp: A* by
// default) and a smoother of its cell path (path_smoothing.hpp: cost-aware line-of-sight
// shortcuts by default). Map frame, metres. Deterministic; not thread-safe (a planner reuses
// its buffers).
#pragma once

#include <Eigen/Dense>
#include <memory>
#include <vector>

#include "tpuaf_core/costmap.hpp"
#include "tpuaf_core/grid_search.hpp"
#include "tpuaf_core/path_smoothing.hpp"
#include "tpuaf_core/perception.hpp"
#include "tpuaf_core/planning_grid.hpp"

namespace tpuaf {

enum class PlanStatus {
  ok,             // points hold a path
  start_blocked,  // the start is lethal and no free cell is visible within the snap radius
  goal_blocked,   // likewise the goal
  no_path,        // the goal is not reachable through non-lethal cells
};
const char* to_string(PlanStatus status);

struct Plan {
  // Map frame [m]. points[0] is the start as given (the robot's position), then, when the start
  // was snapped, the snapped start; the last point is the goal, or the snapped goal. Empty unless
  // status == ok. Clearance >= the inscribed radius holds from the (snapped) start to the end.
  std::vector<Eigen::Vector2d> points;
  double length_m = 0.0;  // polyline length [m] (0 unless ok)
  double cost_m = 0.0;    // integral of 1 + cost_weight cost along the path [m]
  PlanStatus status = PlanStatus::no_path;
  bool start_snapped = false;
  bool goal_snapped = false;
  Eigen::Vector2d start = Eigen::Vector2d::Zero();  // planned-from point (snapped or given) [m]
  Eigen::Vector2d goal = Eigen::Vector2d::Zero();   // planned-to point (snapped or given) [m]
  int expanded = 0;  // cells expanded by the search that found it (shared by plan_edges edges)
  bool ok() const { return status == PlanStatus::ok; }
};

struct PlannerOptions {
  double snap_radius_m = 0.5;  // a lethal start or goal moves to the nearest visible free cell
  bool smooth = true;          // line-of-sight shortcuts (off: the raw 8-connected cell path)
};

// Plans on the planning grid with a CellSearch and a PathSmoother (by default 8-connected A*
// and ShortcutSmoother: the cheapest polyline never costs more than the cell path). "No path"
// is a status; std::invalid_argument is for invalid arguments (non-finite coordinates,
// non-positive disc radii, unknown vertices).
class GridPlanner {
 public:
  explicit GridPlanner(std::shared_ptr<const Costmap> costmap, const PlannerOptions& options = {},
                       std::unique_ptr<CellSearch> search = nullptr,
                       std::unique_ptr<PathSmoother> smoother = nullptr);

  Plan plan(const Eigen::Vector2d& start, const Eigen::Vector2d& goal,
            const std::vector<Disc>& obstacles = {});
  // Length [m] of plan(a, b).points, +inf when there is no path.
  double path_length(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                     const std::vector<Disc>& obstacles = {});
  // One plan per edge (u, v) of a patrol graph, from vertices.row(u) to vertices.row(v): one
  // multi-target search per source vertex, stopped when all its neighbours are reached.
  std::vector<Plan> plan_edges(const Points& vertices,
                               const Eigen::Matrix<int, Eigen::Dynamic, 2, Eigen::RowMajor>& edges,
                               const std::vector<Disc>& obstacles = {});

  const Costmap& costmap() const { return grid_.costmap(); }
  std::shared_ptr<const Costmap> costmap_ptr() const { return grid_.costmap_ptr(); }
  const PlannerOptions& options() const { return options_; }
  void set_options(const PlannerOptions& options);

 private:
  using Snap = PlanningGrid::Snap;
  Plan finish(const std::vector<int>& cells, const Eigen::Vector2d& start, const Snap& s,
              const Eigen::Vector2d& goal, const Snap& g, int expanded) const;

  PlanningGrid grid_;
  PlannerOptions options_;
  std::unique_ptr<CellSearch> search_;
  std::unique_ptr<PathSmoother> smoother_;
};

}  // namespace tpuaf
