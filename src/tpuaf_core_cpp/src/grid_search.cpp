#include "tpuaf_core/grid_search.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "grid_geometry.hpp"

namespace tpuaf {

using grid::kInf;
using grid::kSqrt2;
constexpr float kLethal = PlanningGrid::kLethal;

void AStarSearch::prepare(const PlanningGrid& grid) {
  if (state_.size() != grid.size()) {
    state_.assign(grid.size(), CellState{});
    gen_ = 0;
  }
  if (pw_ != grid.padded_width()) {
    pw_ = grid.padded_width();
    const int dcol[8] = {1, -1, 0, 0, 1, -1, 1, -1};
    const int drow[8] = {0, 0, 1, -1, 1, 1, -1, -1};
    for (int k = 0; k < 8; ++k) {
      offsets_[k] = drow[k] * pw_ + dcol[k];
      dcol_[k] = dcol[k];
      drow_[k] = drow[k];
      side_col_[k] = dcol[k];
      side_row_[k] = drow[k] * pw_;
    }
  }
  for (int k = 0; k < 8; ++k) steps_[k] = (k < 4 ? 1.0 : kSqrt2) * grid.resolution();
  if (++gen_ == 0) {  // wrapped: clear the stamps once every 2^32 searches
    std::fill(state_.begin(), state_.end(), CellState{});
    gen_ = 1;
  }
}

int AStarSearch::search(const PlanningGrid& grid, int start, const std::vector<int>& targets) {
  prepare(grid);
  const double res = grid.resolution();
  heap_.clear();
  int remaining = 0;
  std::vector<std::pair<int, int>> goals;  // padded (col, row) of each target
  for (int t : targets) {
    if (state_[t].target == gen_) continue;
    state_[t].target = gen_;
    ++remaining;
    goals.emplace_back(t % pw_, t / pw_);
  }
  if (remaining == 0) return 0;
  auto heuristic = [&](int c, int r) {  // octile distance to the nearest target [m]
    double best = kInf;
    for (const auto& [gc, gr] : goals) {
      const int dx = std::abs(c - gc), dy = std::abs(r - gr);
      best = std::min(best, std::max(dx, dy) + (kSqrt2 - 1.0) * std::min(dx, dy));
    }
    return use_heuristic_ ? best * res : 0.0;
  };
  // Min f; ties: min h (deepest first), then min cell. Stale entries are skipped when their cell
  // is closed: with a consistent heuristic the best entry of a cell pops first.
  auto later = [](const Node& a, const Node& b) {
    if (a.f != b.f) return a.f > b.f;
    if (a.h != b.h) return a.h > b.h;
    return a.cell > b.cell;
  };
  state_[start].g = 0.0;
  state_[start].parent = -1;
  state_[start].seen = gen_;
  {
    const float h = static_cast<float>(heuristic(start % pw_, start / pw_));
    heap_.push_back({h, h, start});
  }
  int expanded = 0;
  while (!heap_.empty()) {
    std::pop_heap(heap_.begin(), heap_.end(), later);
    const int u = heap_.back().cell;
    heap_.pop_back();
    CellState& su = state_[u];
    if (su.closed == gen_) continue;
    su.closed = gen_;
    ++expanded;
    if (su.target == gen_ && --remaining == 0) break;
    const int ru = u / pw_, cu = u - ru * pw_;
    const double gu = su.g, mu = grid.multiplier(u);
    for (int k = 0; k < 8; ++k) {
      const int v = u + offsets_[k];
      const float mv = grid.multiplier(v);
      CellState& sv = state_[v];
      if (mv >= kLethal || sv.closed == gen_) continue;
      if (k >= 4 && (grid.multiplier(u + side_col_[k]) >= kLethal ||
                     grid.multiplier(u + side_row_[k]) >= kLethal))
        continue;  // no corner cutting
      const double ng = gu + steps_[k] * 0.5 * (mu + mv);
      if (sv.seen == gen_ && ng >= sv.g) continue;
      sv.seen = gen_;
      sv.g = ng;
      sv.parent = u;
      const double h = heuristic(cu + dcol_[k], ru + drow_[k]);
      heap_.push_back({ng + h, static_cast<float>(h), v});
      std::push_heap(heap_.begin(), heap_.end(), later);
    }
  }
  return expanded;
}

std::vector<int> AStarSearch::cell_path(int target) const {
  std::vector<int> cells;
  for (int c = target; c >= 0; c = state_[c].parent) cells.push_back(c);
  std::reverse(cells.begin(), cells.end());
  return cells;
}

}  // namespace tpuaf
