// Searches over the planning grid (the planner's expander seam): a CellSearch finds cheapest
// cell paths from a start to a set of targets. A step between 8-connected cells a and b of
// length l [m] costs l (1 + cost_weight (cost_a + cost_b) / 2); no corner cutting.
#pragma once

#include <cstdint>
#include <vector>

#include "tpuaf_core/planning_grid.hpp"

namespace tpuaf {

class CellSearch {
 public:
  virtual ~CellSearch() = default;
  // Searches from padded cell `start` until every target is reached or none is left reachable;
  // returns the number of cells expanded. The grid must outlive the calls below.
  virtual int search(const PlanningGrid& grid, int start, const std::vector<int>& targets) = 0;
  // Whether the last search reached `cell`, and its cell path start .. cell (when reached).
  virtual bool reached(int cell) const = 0;
  virtual std::vector<int> cell_path(int target) const = 0;
};

// A* with the octile distance to the nearest target as heuristic, or Dijkstra (no heuristic).
// Ties: min f, then min h (deepest first), then min cell, so results are deterministic.
class AStarSearch final : public CellSearch {
 public:
  explicit AStarSearch(bool use_heuristic = true) : use_heuristic_(use_heuristic) {}
  int search(const PlanningGrid& grid, int start, const std::vector<int>& targets) override;
  bool reached(int cell) const override {
    return gen_ != 0 && cell >= 0 && static_cast<std::size_t>(cell) < state_.size() &&
           state_[cell].closed == gen_;
  }
  std::vector<int> cell_path(int target) const override;

 private:
  struct CellState {  // search state of one cell; stamps equal to gen_ are current
    double g = 0.0;   // cost from the start [m]
    int parent = -1;
    std::uint32_t seen = 0, closed = 0, target = 0;
  };
  struct Node {
    double f;  // g + h [m]
    float h;   // [m], tie-break
    int cell;
  };
  void prepare(const PlanningGrid& grid);  // sizes the state, the steps; next generation

  bool use_heuristic_;
  int pw_ = -1;                   // padded width the steps were made for [cells]
  std::vector<CellState> state_;  // per padded cell
  std::uint32_t gen_ = 0;
  std::vector<Node> heap_;
  int offsets_[8];                 // padded index offsets: E, W, N, S, NE, NW, SE, SW
  int dcol_[8], drow_[8];          // the same as column and row steps
  int side_col_[8], side_row_[8];  // the two side cells of a diagonal step
  double steps_[8];                // step lengths [m]
};

}  // namespace tpuaf
