// Linear sum assignment (the rectangular assignment problem): the pairing of rows with columns
// of a dense cost matrix of minimum total cost, each row and each column used at most once and
// min(rows, cols) pairs. Same algorithm, arithmetic and tie-breaking as
// scipy.optimize.linear_sum_assignment (checked against scipy 1.10.1), so both return the same
// pairs, ties included: the shortest augmenting path method of Crouse (2016, "On implementing
// 2D rectangular assignment algorithms", IEEE TAES 52(4)), a Jonker-Volgenant variant.
#pragma once

#include <cstdint>
#include <vector>

namespace tpuaf {

struct Assignment {
  std::vector<std::int64_t> rows;  // row indices, ascending
  std::vector<std::int64_t> cols;  // the column of each row in `rows`
};

// Minimum-cost assignment of the row-major rows x cols matrix `cost` (any unit; +inf forbids a
// pair). min(rows, cols) pairs; empty when rows or cols is 0. Throws std::invalid_argument when
// an entry is NaN or -inf, or when no assignment avoids the +inf entries.
Assignment linear_sum_assignment(const double* cost, int rows, int cols);
Assignment linear_sum_assignment(const std::vector<double>& cost, int rows, int cols);

}  // namespace tpuaf
