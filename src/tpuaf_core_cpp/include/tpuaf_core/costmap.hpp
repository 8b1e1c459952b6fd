// Inflated costmap of an occupancy grid (move_base-like): exact Euclidean distance transform,
// lethal cells within the inscribed radius, an exponential cost fall-off to the inflation radius.
//
// Grid convention of world.hpp: GridMask is height x width, row 0 the BOTTOM row (y up); cell
// (r, c) covers x in [ox + c res, ox + (c+1) res), y likewise with r; outside the grid is
// occupied. Map frame, metres.
//
// Distances are between cells: the distance of a cell to the obstacles is the gap between its
// square and the nearest occupied square (0 for a cell touching one), so every point of a cell
// is at least that far from every obstacle. A lethal cell has a gap below the inscribed radius;
// a path that stays in non-lethal cells therefore keeps a clearance >= the inscribed radius.
#pragma once

#include <Eigen/Dense>
#include <cstdint>
#include <vector>

#include "tpuaf_core/world.hpp"

namespace tpuaf {

struct CostmapSpec {
  double inscribed_radius_m = 0.2;  // robot radius + safety margin: closer cells are lethal [m]
  double inflation_radius_m = 0.6;  // the cost is 0 at and beyond this distance [m]
  double cost_scaling_per_m = 5.0;  // cost = exp(-scaling (d - inscribed)) in between [1/m]
  double cost_weight = 1.0;         // extra metres of path per metre travelled at cost 1 [-]
};

// The distance transform, lethal cells and costs of an occupancy grid. The planning grid may be
// coarser than the map: planning_resolution_m is rounded to a whole number k of map cells
// (0: the map's own resolution); a planning cell is lethal if any of its k x k map cells is
// lethal or lies outside the map, and its cost is the highest of theirs (conservative).
class Costmap {
 public:
  // Throws std::invalid_argument for an empty grid, a non-positive or non-finite resolution, a
  // non-finite origin, or an invalid spec (radii < 0, inflation < inscribed, negative scaling
  // or weight).
  Costmap(const GridMask& occupied, double resolution_m, double origin_x_m, double origin_y_m,
          const CostmapSpec& spec = {}, double planning_resolution_m = 0.0);

  const CostmapSpec& spec() const { return spec_; }
  double origin_x() const { return ox_; }
  double origin_y() const { return oy_; }
  // The map grid.
  int map_width() const { return mw_; }
  int map_height() const { return mh_; }
  double map_resolution() const { return mres_; }
  // The planning grid (same origin), k map cells per planning cell.
  int width() const { return w_; }
  int height() const { return h_; }
  double resolution() const { return res_; }
  int downsample() const { return k_; }

  // Map grid: gap [m] between the cell holding (x, y) and the nearest occupied cell (exact
  // Euclidean distance transform; 0 on and next to obstacles and outside the map). Every point
  // of the cell is at least this far from every obstacle.
  double distance_to_obstacle(double x, double y) const;
  // Planning grid, at (x, y); outside the map is lethal with cost 1.
  bool is_lethal(double x, double y) const;
  double cost(double x, double y) const;  // in [0, 1]; 1 on lethal cells
  bool map_occupied(double x, double y) const;

  // Raw grids, row-major, row 0 at the bottom.
  const std::vector<float>& map_distances() const { return dist_; }    // map grid [m]
  const std::vector<float>& costs() const { return cost_; }            // planning grid [-]
  const std::vector<std::uint8_t>& lethal() const { return lethal_; }  // planning grid
  const std::vector<std::uint8_t>& map_occupancy() const { return occ_; }

  // Cell arithmetic of the planning grid; the cell may lie outside the grid.
  int col_of(double x) const;
  int row_of(double y) const;
  Eigen::Vector2d centre(int row, int col) const;

  // Cost of a cell at gap d [m] from an obstacle (1 below the inscribed radius, then the
  // exponential fall-off, 0 from the inflation radius on).
  double cost_at_distance(double d) const;

 private:
  CostmapSpec spec_;
  int mw_, mh_, w_, h_, k_;
  double mres_, res_, ox_, oy_;
  std::vector<std::uint8_t> occ_;     // map grid, 1 = occupied
  std::vector<float> dist_;           // map grid [m]
  std::vector<float> cost_;           // planning grid
  std::vector<std::uint8_t> lethal_;  // planning grid
};

}  // namespace tpuaf
