// The planning grid the search and the smoother share: the costmap's planning cells padded with
// one lethal ring, each holding its step multiplier 1 + cost_weight cost (kLethal when lethal),
// with temporary obstacle discs applied for one plan. Map frame, metres.
#pragma once

#include <Eigen/Dense>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "tpuaf_core/costmap.hpp"

namespace tpuaf {

// A temporary obstacle (another robot, an unmapped obstacle seen by the laser), inflated like a
// mapped one for one plan only: cells closer than radius_m + the inscribed radius to its centre
// are lethal, the cost falls off beyond.
struct Disc {
  double x_m;
  double y_m;
  double radius_m;  // > 0
};

class PlanningGrid {
 public:
  static constexpr float kLethal = 1e30f;  // multiplier of a lethal cell

  struct Snap {
    int cell = -1;  // padded index, -1: blocked
    bool snapped = false;
    Eigen::Vector2d point = Eigen::Vector2d::Zero();
  };

  explicit PlanningGrid(std::shared_ptr<const Costmap> costmap);

  const Costmap& costmap() const { return *cm_; }
  std::shared_ptr<const Costmap> costmap_ptr() const { return cm_; }
  int padded_width() const { return pw_; }
  int padded_height() const { return ph_; }
  std::size_t size() const { return mult_.size(); }
  double resolution() const { return res_; }  // [m] per planning cell

  int padded(int row, int col) const { return (row + 1) * pw_ + col + 1; }
  Eigen::Vector2d centre_of(int cell) const;  // [m]
  float multiplier(int cell) const { return mult_[cell]; }
  bool free_cell(int cell) const { return mult_[cell] < kLethal; }

  // Discs stay applied until restore_discs (ScopedDiscs does both). Throws
  // std::invalid_argument for a non-finite centre or a radius <= 0.
  void apply_discs(const std::vector<Disc>& obstacles);
  void restore_discs();

  // The free cell holding p, or the nearest free cell centre within radius_m [m] visible from p
  // on the map grid; cell -1 when none.
  Snap snap(const Eigen::Vector2d& p, double radius_m) const;
  // Walks the planning grid along segment a-b: weighted length [m] (integral of the multiplier),
  // or +inf if it touches a lethal cell (when check_lethal; otherwise lethal cells count as cost
  // 1).
  double segment_cost(const Eigen::Vector2d& a, const Eigen::Vector2d& b, bool check_lethal) const;

 private:
  bool map_visible(const Eigen::Vector2d& from, const Eigen::Vector2d& to) const;

  std::shared_ptr<const Costmap> cm_;
  int pw_, ph_;  // padded planning grid (one lethal ring) [cells]
  double res_, ox_, oy_, weight_;
  std::vector<float> mult_;                  // per padded cell
  std::vector<std::pair<int, float>> undo_;  // disc edits to revert
};

// Applies discs to a grid for the lifetime of the guard.
class ScopedDiscs {
 public:
  ScopedDiscs(PlanningGrid& grid, const std::vector<Disc>& obstacles) : grid_(grid) {
    grid_.apply_discs(obstacles);
  }
  ~ScopedDiscs() { grid_.restore_discs(); }
  ScopedDiscs(const ScopedDiscs&) = delete;
  ScopedDiscs& operator=(const ScopedDiscs&) = delete;

 private:
  PlanningGrid& grid_;
};

}  // namespace tpuaf
