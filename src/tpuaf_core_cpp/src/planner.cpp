#include "tpuaf_core/planner.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

#include "grid_geometry.hpp"

namespace tpuaf {

using grid::finite;
using grid::kInf;

const char* to_string(PlanStatus status) {
  switch (status) {
    case PlanStatus::ok:
      return "ok";
    case PlanStatus::start_blocked:
      return "start_blocked";
    case PlanStatus::goal_blocked:
      return "goal_blocked";
    case PlanStatus::no_path:
      return "no_path";
  }
  return "unknown";
}

GridPlanner::GridPlanner(std::shared_ptr<const Costmap> costmap, const PlannerOptions& options,
                         std::unique_ptr<CellSearch> search, std::unique_ptr<PathSmoother> smoother)
    : grid_(std::move(costmap)),
      search_(search ? std::move(search) : std::make_unique<AStarSearch>()),
      smoother_(smoother ? std::move(smoother) : std::make_unique<ShortcutSmoother>()) {
  set_options(options);
}

void GridPlanner::set_options(const PlannerOptions& options) {
  if (!finite(options.snap_radius_m) || options.snap_radius_m < 0)
    throw std::invalid_argument("GridPlanner: snap_radius_m must be >= 0");
  options_ = options;
}

Plan GridPlanner::finish(const std::vector<int>& cells, const Eigen::Vector2d& start, const Snap& s,
                         const Eigen::Vector2d& goal, const Snap& g, int expanded) const {
  Plan plan;
  plan.status = PlanStatus::ok;
  plan.start_snapped = s.snapped;
  plan.goal_snapped = g.snapped;
  plan.start = s.point;
  plan.goal = g.point;
  plan.expanded = expanded;
  std::vector<Eigen::Vector2d> pts;
  pts.reserve(cells.size() + 2);
  pts.push_back(start);
  for (int c : cells) pts.push_back(grid_.centre_of(c));
  if (!g.snapped) pts.push_back(goal);
  if (options_.smooth) smoother_->smooth(grid_, pts, s.snapped ? 1 : 0);
  plan.points.reserve(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i)  // drop repeated points, keep both ends
    if (i == 0 || i + 1 == pts.size() || pts[i] != plan.points.back())
      plan.points.push_back(pts[i]);
  for (std::size_t i = 1; i < plan.points.size(); ++i) {
    plan.length_m += (plan.points[i] - plan.points[i - 1]).norm();
    plan.cost_m += grid_.segment_cost(plan.points[i - 1], plan.points[i], false);
  }
  return plan;
}

Plan GridPlanner::plan(const Eigen::Vector2d& start, const Eigen::Vector2d& goal,
                       const std::vector<Disc>& obstacles) {
  if (!start.allFinite()) throw std::invalid_argument("GridPlanner.plan: non-finite start");
  if (!goal.allFinite()) throw std::invalid_argument("GridPlanner.plan: non-finite goal");
  ScopedDiscs discs(grid_, obstacles);
  Plan plan;
  plan.start = start;
  plan.goal = goal;
  const Snap s = grid_.snap(start, options_.snap_radius_m);
  if (s.cell < 0) {
    plan.status = PlanStatus::start_blocked;
    return plan;
  }
  const Snap g = grid_.snap(goal, options_.snap_radius_m);
  if (g.cell < 0) {
    plan.status = PlanStatus::goal_blocked;
    return plan;
  }
  if (s.cell == g.cell) return finish({s.cell}, start, s, goal, g, 0);
  const int expanded = search_->search(grid_, s.cell, {g.cell});
  if (!search_->reached(g.cell)) {
    plan.status = PlanStatus::no_path;
    plan.expanded = expanded;
    return plan;
  }
  return finish(search_->cell_path(g.cell), start, s, goal, g, expanded);
}

double GridPlanner::path_length(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                                const std::vector<Disc>& obstacles) {
  const Plan p = plan(a, b, obstacles);
  return p.ok() ? p.length_m : kInf;
}

std::vector<Plan> GridPlanner::plan_edges(
    const Points& vertices, const Eigen::Matrix<int, Eigen::Dynamic, 2, Eigen::RowMajor>& edges,
    const std::vector<Disc>& obstacles) {
  const int n = static_cast<int>(vertices.rows());
  const int m = static_cast<int>(edges.rows());
  if (!vertices.allFinite())
    throw std::invalid_argument("GridPlanner.plan_edges: non-finite vertex position");
  std::vector<std::vector<int>> incident(n);
  for (int e = 0; e < m; ++e) {
    for (int k = 0; k < 2; ++k)
      if (edges(e, k) < 0 || edges(e, k) >= n)
        throw std::invalid_argument("GridPlanner.plan_edges: edge " + std::to_string(e) +
                                    " has unknown vertex " + std::to_string(edges(e, k)) + " (" +
                                    std::to_string(n) + " vertices)");
    incident[edges(e, 0)].push_back(e);
    if (edges(e, 1) != edges(e, 0)) incident[edges(e, 1)].push_back(e);
  }
  ScopedDiscs discs(grid_, obstacles);
  std::vector<Snap> snaps(n);
  std::vector<char> used(n, 0);
  for (int e = 0; e < m; ++e) used[edges(e, 0)] = used[edges(e, 1)] = 1;
  for (int i = 0; i < n; ++i)
    if (used[i]) snaps[i] = grid_.snap(vertices.row(i).transpose(), options_.snap_radius_m);

  std::vector<Plan> plans(m);
  std::vector<char> done(m, 0);
  std::vector<int> pending, targets;
  for (int u = 0; u < n; ++u) {
    pending.clear();
    targets.clear();
    for (int e : incident[u]) {
      if (done[e]) continue;
      pending.push_back(e);
      const int other = edges(e, 0) == u ? edges(e, 1) : edges(e, 0);
      if (snaps[u].cell >= 0 && snaps[other].cell >= 0 && snaps[other].cell != snaps[u].cell)
        targets.push_back(snaps[other].cell);
    }
    if (pending.empty()) continue;
    const int expanded = targets.empty() ? 0 : search_->search(grid_, snaps[u].cell, targets);
    for (int e : pending) {
      done[e] = 1;
      const int a = edges(e, 0), b = edges(e, 1);
      const int other = a == u ? b : a;
      Plan& p = plans[e];
      p.start = vertices.row(a).transpose();
      p.goal = vertices.row(b).transpose();
      p.expanded = expanded;
      if (snaps[a].cell < 0) {
        p.status = PlanStatus::start_blocked;
      } else if (snaps[b].cell < 0) {
        p.status = PlanStatus::goal_blocked;
      } else if (snaps[a].cell == snaps[b].cell) {
        p = finish({snaps[a].cell}, p.start, snaps[a], p.goal, snaps[b], expanded);
      } else if (!search_->reached(snaps[other].cell)) {
        p.status = PlanStatus::no_path;
      } else {
        std::vector<int> cells = search_->cell_path(snaps[other].cell);
        if (u != a) std::reverse(cells.begin(), cells.end());
        p = finish(cells, p.start, snaps[a], p.goal, snaps[b], expanded);
      }
    }
  }
  return plans;
}

}  // namespace tpuaf
