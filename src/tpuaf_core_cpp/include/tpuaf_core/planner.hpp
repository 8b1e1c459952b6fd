// Global planner on the occupancy grid (move_base-like): an inflated costmap and an 8-connected
// A* whose path is shortened by cost-aware line-of-sight smoothing.
//
// Grid convention of world.hpp: GridMask is height x width, row 0 the BOTTOM row (y up); cell
// (r, c) covers x in [ox + c res, ox + (c+1) res), y likewise with r; outside the grid is
// occupied. Map frame, metres. Deterministic; not thread-safe (a planner reuses its buffers).
//
// Distances are between cells: the distance of a cell to the obstacles is the gap between its
// square and the nearest occupied square (0 for a cell touching one), so every point of a cell
// is at least that far from every obstacle. A lethal cell has a gap below the inscribed radius;
// a path that stays in non-lethal cells therefore keeps a clearance >= the inscribed radius.
#pragma once

#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "tpuaf_core/perception.hpp"
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
  const std::vector<float>& map_distances() const { return dist_; }  // map grid [m]
  const std::vector<float>& costs() const { return cost_; }          // planning grid [-]
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

// A temporary obstacle (another robot, an unmapped obstacle seen by the laser), inflated like a
// mapped one for one plan only: cells closer than radius_m + the inscribed radius to its centre
// are lethal, the cost falls off beyond.
struct Disc {
  double x_m;
  double y_m;
  double radius_m;  // > 0
};

struct PlannerOptions {
  double snap_radius_m = 0.5;  // a lethal start or goal moves to the nearest visible free cell
  bool smooth = true;          // line-of-sight shortcuts (off: the raw 8-connected cell path)
};

// 8-connected A* (octile heuristic, no corner cutting) on the planning grid. A step between
// cells a and b of length l [m] costs l (1 + cost_weight (cost_a + cost_b) / 2). Smoothing
// minimises the same weighted length (integral of 1 + cost_weight cost) over polylines whose
// segments cross no lethal cell: the cheapest one with corners on the cell path (dynamic
// programming over a window of 8 cells), then corners pulled towards their chords while the
// weighted length falls; it never costs more than the cell path. "No path" is a status;
// std::invalid_argument is for invalid arguments (non-finite coordinates, non-positive disc
// radii, unknown vertices).
class GridPlanner {
 public:
  explicit GridPlanner(std::shared_ptr<const Costmap> costmap, const PlannerOptions& options = {});

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

  const Costmap& costmap() const { return *cm_; }
  std::shared_ptr<const Costmap> costmap_ptr() const { return cm_; }
  const PlannerOptions& options() const { return options_; }
  void set_options(const PlannerOptions& options);

 private:
  struct Snap {
    int cell = -1;  // padded index, -1: blocked
    bool snapped = false;
    Eigen::Vector2d point = Eigen::Vector2d::Zero();
  };
  struct CellState {  // search state of one cell; stamps equal to gen_ are current
    double g = 0.0;     // cost from the start [m]
    int parent = -1;
    std::uint32_t seen = 0, closed = 0, target = 0;
  };
  struct Node {
    double f;  // g + h [m]
    float h;   // [m], tie-break
    int cell;
  };
  class DiscGuard;

  int padded(int row, int col) const { return (row + 1) * pw_ + col + 1; }
  Eigen::Vector2d centre_of(int cell) const;
  bool free_cell(int cell) const { return mult_[cell] < kLethal; }
  void apply_discs(const std::vector<Disc>& obstacles);
  void restore_discs();
  Snap snap(const Eigen::Vector2d& p) const;
  bool map_visible(const Eigen::Vector2d& from, const Eigen::Vector2d& to) const;
  // A* from start to every target (padded cells); returns the number expanded.
  int search(int start, const std::vector<int>& targets);
  bool reached(int cell) const { return state_[cell].closed == gen_; }
  std::vector<int> cell_path(int target) const;  // start .. target
  // Walks the planning grid along segment a-b: weighted length [m], or +inf if it touches a
  // lethal cell (when check_lethal).
  double segment_cost(const Eigen::Vector2d& a, const Eigen::Vector2d& b, bool check_lethal) const;
  Plan finish(const std::vector<int>& cells, const Eigen::Vector2d& start, const Snap& s,
              const Eigen::Vector2d& goal, const Snap& g, int expanded) const;
  void smooth(std::vector<Eigen::Vector2d>& pts, std::size_t first) const;
  void tighten(std::vector<Eigen::Vector2d>& pts, std::size_t first) const;
  void next_generation();

  static constexpr float kLethal = 1e30f;  // multiplier of a lethal cell

  std::shared_ptr<const Costmap> cm_;
  PlannerOptions options_;
  int pw_, ph_;                 // padded planning grid (one lethal ring) [cells]
  double res_, ox_, oy_, weight_;
  std::vector<float> mult_;     // 1 + weight cost per padded cell; kLethal when lethal
  std::vector<std::pair<int, float>> undo_;  // disc edits to revert
  std::vector<CellState> state_;  // per padded cell
  std::uint32_t gen_ = 0;
  std::vector<Node> heap_;
  int offsets_[8];                 // padded index offsets: E, W, N, S, NE, NW, SE, SW
  int dcol_[8], drow_[8];          // the same as column and row steps
  int side_col_[8], side_row_[8];  // the two side cells of a diagonal step
  double steps_[8];                // step lengths [m]
};

}  // namespace tpuaf
