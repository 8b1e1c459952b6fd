#include "tpuaf_core/planning_grid.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <tuple>

#include "grid_geometry.hpp"

namespace tpuaf {

using grid::finite;
using grid::gap_to_square;
using grid::kInf;
using grid::kTol;
using grid::walk_cells;

PlanningGrid::PlanningGrid(std::shared_ptr<const Costmap> costmap) : cm_(std::move(costmap)) {
  if (!cm_) throw std::invalid_argument("GridPlanner: no costmap");
  pw_ = cm_->width() + 2;
  ph_ = cm_->height() + 2;
  res_ = cm_->resolution();
  ox_ = cm_->origin_x();
  oy_ = cm_->origin_y();
  weight_ = cm_->spec().cost_weight;
  mult_.assign(static_cast<std::size_t>(pw_) * ph_, kLethal);
  for (int r = 0; r < cm_->height(); ++r)
    for (int c = 0; c < cm_->width(); ++c) {
      const std::size_t i = static_cast<std::size_t>(r) * cm_->width() + c;
      if (!cm_->lethal()[i])
        mult_[padded(r, c)] = static_cast<float>(1.0 + weight_ * cm_->costs()[i]);
    }
}

Eigen::Vector2d PlanningGrid::centre_of(int cell) const {
  const int r = cell / pw_ - 1, c = cell % pw_ - 1;
  return {ox_ + (c + 0.5) * res_, oy_ + (r + 0.5) * res_};
}

void PlanningGrid::apply_discs(const std::vector<Disc>& obstacles) {
  for (const Disc& d : obstacles) {
    if (!finite(d.x_m) || !finite(d.y_m))
      throw std::invalid_argument("GridPlanner: an obstacle disc has a non-finite centre");
    if (!finite(d.radius_m) || d.radius_m <= 0)
      throw std::invalid_argument("GridPlanner: an obstacle disc radius must be > 0, got " +
                                  std::to_string(d.radius_m));
  }
  const CostmapSpec& spec = cm_->spec();
  for (const Disc& d : obstacles) {
    const double reach = d.radius_m + spec.inflation_radius_m;
    const int c0 = std::max(0, cm_->col_of(d.x_m - reach));
    const int c1 = std::min(cm_->width() - 1, cm_->col_of(d.x_m + reach));
    const int r0 = std::max(0, cm_->row_of(d.y_m - reach));
    const int r1 = std::min(cm_->height() - 1, cm_->row_of(d.y_m + reach));
    for (int r = r0; r <= r1; ++r) {
      for (int c = c0; c <= c1; ++c) {
        const double gap =
            gap_to_square(d.x_m, d.y_m, ox_ + c * res_, oy_ + r * res_, res_) - d.radius_m;
        if (gap >= spec.inflation_radius_m) continue;
        const float m = gap < spec.inscribed_radius_m - kTol
                            ? kLethal
                            : static_cast<float>(1.0 + weight_ * cm_->cost_at_distance(gap));
        const int cell = padded(r, c);
        if (m > mult_[cell]) {
          undo_.emplace_back(cell, mult_[cell]);
          mult_[cell] = m;
        }
      }
    }
  }
}

void PlanningGrid::restore_discs() {
  for (auto it = undo_.rbegin(); it != undo_.rend(); ++it) mult_[it->first] = it->second;
  undo_.clear();
}

bool PlanningGrid::map_visible(const Eigen::Vector2d& from, const Eigen::Vector2d& to) const {
  const Costmap& cm = *cm_;
  const double mres = cm.map_resolution();
  const int mw = cm.map_width(), mh = cm.map_height();
  bool first = true;
  return walk_cells((from.x() - ox_) / mres, (from.y() - oy_) / mres, (to.x() - ox_) / mres,
                    (to.y() - oy_) / mres, [&](int c, int r, double) {
                      if (first) {  // the cell of the point itself may be occupied
                        first = false;
                        return true;
                      }
                      if (r < 0 || c < 0 || r >= mh || c >= mw) return false;
                      return cm.map_occupancy()[static_cast<std::size_t>(r) * mw + c] == 0;
                    });
}

PlanningGrid::Snap PlanningGrid::snap(const Eigen::Vector2d& p, double radius_m) const {
  const int w = cm_->width(), h = cm_->height();
  const int c = cm_->col_of(p.x()), r = cm_->row_of(p.y());
  if (r >= 0 && c >= 0 && r < h && c < w && free_cell(padded(r, c)))
    return {padded(r, c), false, p};
  const double radius = radius_m;
  const int reach = static_cast<int>(std::ceil(radius / res_)) + 1;
  std::vector<std::tuple<double, int, int>> candidates;  // distance [m], row, col
  for (int rr = std::max(0, r - reach); rr <= std::min(h - 1, r + reach); ++rr)
    for (int cc = std::max(0, c - reach); cc <= std::min(w - 1, c + reach); ++cc) {
      if (!free_cell(padded(rr, cc))) continue;
      const double d = (cm_->centre(rr, cc) - p).norm();
      if (d <= radius) candidates.emplace_back(d, rr, cc);
    }
  std::sort(candidates.begin(), candidates.end());
  for (const auto& [d, rr, cc] : candidates) {
    const Eigen::Vector2d q = cm_->centre(rr, cc);
    if (map_visible(p, q)) return {padded(rr, cc), true, q};
  }
  return {};
}

double PlanningGrid::segment_cost(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                                  bool check_lethal) const {
  const double length = (b - a).norm();
  const int w = cm_->width(), h = cm_->height();
  const float worst = static_cast<float>(1.0 + weight_);
  double sum = 0.0;  // fraction-weighted multiplier
  const bool clear =
      walk_cells((a.x() - ox_) / res_, (a.y() - oy_) / res_, (b.x() - ox_) / res_,
                 (b.y() - oy_) / res_, [&](int c, int r, double fraction) {
                   float m = (r < 0 || c < 0 || r >= h || c >= w) ? kLethal : mult_[padded(r, c)];
                   if (m >= kLethal) {
                     if (check_lethal) return false;
                     m = worst;
                   }
                   sum += fraction * m;
                   return true;
                 });
  return clear ? sum * length : kInf;
}

}  // namespace tpuaf
