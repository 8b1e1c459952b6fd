// Linear sum assignment: shortest augmenting paths with dual variables (Crouse 2016), arranged
// as scipy.optimize.linear_sum_assignment does so that results, ties included, are equal.
#include "tpuaf_core/assignment.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace tpuaf {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Solver state for a wide matrix (n_rows <= n_cols), row-major `c`.
class Solver {
 public:
  Solver(const double* c, int n_rows, int n_cols)
      : c_(c),
        nr_(n_rows),
        nc_(n_cols),
        u_(n_rows, 0.0),
        v_(n_cols, 0.0),
        dist_(n_cols, kInf),
        pred_(n_cols, -1),
        col_of_row_(n_rows, -1),
        row_of_col_(n_cols, -1),
        row_seen_(n_rows, 0),
        col_done_(n_cols, 0),
        todo_(n_cols, 0) {}

  // Column per row, or throws when some row cannot be assigned.
  std::vector<int> solve() {
    for (int row = 0; row < nr_; ++row) {
      double reach = 0.0;  // reduced length of the shortest augmenting path from `row`
      const int sink = shortest_path(row, &reach);
      if (sink < 0) {
        throw std::invalid_argument("linear_sum_assignment: cost matrix is infeasible (no "
                                    "assignment avoids the +inf entries)");
      }
      // Dual update: keeps reduced costs >= 0 and the new path's edges at 0.
      u_[row] += reach;
      for (int i = 0; i < nr_; ++i) {
        if (row_seen_[i] && i != row) u_[i] += reach - dist_[col_of_row_[i]];
      }
      for (int j = 0; j < nc_; ++j) {
        if (col_done_[j]) v_[j] -= reach - dist_[j];
      }
      // Flip the path: from the free sink column back to `row`.
      int j = sink;
      while (true) {
        const int i = pred_[j];
        row_of_col_[j] = i;
        std::swap(col_of_row_[i], j);
        if (i == row) break;
      }
    }
    return col_of_row_;
  }

 private:
  // Dijkstra on reduced costs from the free row `start` to the first free column it settles
  // (the sink), or -1 when every remaining column is at +inf. *reach: the sink's distance.
  int shortest_path(int start, double* reach) {
    double settled = 0.0;  // distance of the last settled column
    // Columns not yet settled, listed from the last: a constant matrix gives the identity.
    int n_todo = nc_;
    for (int k = 0; k < nc_; ++k) todo_[k] = nc_ - 1 - k;
    std::fill(row_seen_.begin(), row_seen_.end(), 0);
    std::fill(col_done_.begin(), col_done_.end(), 0);
    std::fill(dist_.begin(), dist_.end(), kInf);
    int sink = -1;
    int i = start;
    while (sink < 0) {
      row_seen_[i] = 1;
      int best = -1;  // position in todo_ of the next column to settle
      double lowest = kInf;
      const double* ci = c_ + static_cast<std::size_t>(i) * nc_;
      for (int k = 0; k < n_todo; ++k) {
        const int j = todo_[k];
        const double d = settled + ci[j] - u_[i] - v_[j];
        if (d < dist_[j]) {
          pred_[j] = i;
          dist_[j] = d;
        }
        // Ties: the first in todo_ order, except that a free column (ends the search) beats an
        // assigned one of the same distance.
        if (dist_[j] < lowest || (dist_[j] == lowest && row_of_col_[j] < 0)) {
          lowest = dist_[j];
          best = k;
        }
      }
      settled = lowest;
      if (settled == kInf) return -1;  // also when no column is left (cannot happen: rows <= cols)
      const int j = todo_[best];
      if (row_of_col_[j] < 0) {
        sink = j;
      } else {
        i = row_of_col_[j];
      }
      col_done_[j] = 1;
      todo_[best] = todo_[--n_todo];
    }
    *reach = settled;
    return sink;
  }

  const double* c_;
  int nr_, nc_;
  std::vector<double> u_, v_;  // row and column duals
  std::vector<double> dist_;   // shortest reduced distance to each column this search
  std::vector<int> pred_;      // row before each column on its shortest path
  std::vector<int> col_of_row_, row_of_col_;
  std::vector<char> row_seen_, col_done_;
  std::vector<int> todo_;
};

}  // namespace

Assignment linear_sum_assignment(const double* cost, int rows, int cols) {
  if (rows < 0 || cols < 0) {
    throw std::invalid_argument("linear_sum_assignment: negative shape " + std::to_string(rows) +
                                " x " + std::to_string(cols));
  }
  Assignment out;
  if (rows == 0 || cols == 0) return out;
  const std::size_t n = static_cast<std::size_t>(rows) * cols;
  for (std::size_t k = 0; k < n; ++k) {
    if (std::isnan(cost[k]) || cost[k] == -kInf) {
      throw std::invalid_argument("linear_sum_assignment: cost matrix contains NaN or -inf");
    }
  }
  // A tall matrix is solved transposed (every row of the wide one gets a column).
  const bool tall = rows > cols;
  std::vector<double> transposed;
  const double* wide = cost;
  if (tall) {
    transposed.resize(n);
    for (int i = 0; i < rows; ++i) {
      for (int j = 0; j < cols; ++j) {
        transposed[static_cast<std::size_t>(j) * rows + i] =
            cost[static_cast<std::size_t>(i) * cols + j];
      }
    }
    wide = transposed.data();
  }
  const int nr = tall ? cols : rows;
  const int nc = tall ? rows : cols;
  const std::vector<int> col_of_row = Solver(wide, nr, nc).solve();
  out.rows.resize(nr);
  out.cols.resize(nr);
  if (!tall) {
    for (int i = 0; i < nr; ++i) {
      out.rows[i] = i;
      out.cols[i] = col_of_row[i];
    }
    return out;
  }
  // Transposed: the wide matrix's columns are our rows; list them ascending.
  std::vector<int> order(nr);
  for (int i = 0; i < nr; ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return col_of_row[a] < col_of_row[b]; });
  for (int k = 0; k < nr; ++k) {
    out.rows[k] = col_of_row[order[k]];
    out.cols[k] = order[k];
  }
  return out;
}

Assignment linear_sum_assignment(const std::vector<double>& cost, int rows, int cols) {
  if (rows < 0 || cols < 0 ||
      cost.size() != static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols)) {
    throw std::invalid_argument("linear_sum_assignment: cost has " + std::to_string(cost.size()) +
                                " entries, not " + std::to_string(rows) + " x " +
                                std::to_string(cols));
  }
  return linear_sum_assignment(cost.data(), rows, cols);
}

}  // namespace tpuaf
