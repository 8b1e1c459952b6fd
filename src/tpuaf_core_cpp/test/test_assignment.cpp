// Linear sum assignment on hand-checked matrices: optimum, rectangular both ways, scipy's
// tie-breaking, +inf entries, errors.
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

#include "tpuaf_core/assignment.hpp"

namespace tpuaf {
namespace {

using Ids = std::vector<std::int64_t>;
constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(Assignment, SquareOptimum) {
  // Optimum 1 + 2 + 2 = 5: row 0 -> col 1, row 1 -> col 0, row 2 -> col 2.
  const Assignment a = linear_sum_assignment({4, 1, 3, 2, 0, 5, 3, 2, 2}, 3, 3);
  EXPECT_EQ(a.rows, (Ids{0, 1, 2}));
  EXPECT_EQ(a.cols, (Ids{1, 0, 2}));
}

TEST(Assignment, WideAndTall) {
  // 2 x 4: row 0 -> col 0 (1), row 1 -> col 3 (0); the next best total is 2.
  const Assignment wide = linear_sum_assignment({1, 2, 3, 4, 2, 1, 5, 0}, 2, 4);
  EXPECT_EQ(wide.rows, (Ids{0, 1}));
  EXPECT_EQ(wide.cols, (Ids{0, 3}));
  // 4 x 2 (solved transposed): row 3 -> col 0 (0), row 2 -> col 1 (0); rows listed ascending.
  const Assignment tall = linear_sum_assignment({1, 2, 2, 1, 3, 0, 0, 5}, 4, 2);
  EXPECT_EQ(tall.rows, (Ids{2, 3}));
  EXPECT_EQ(tall.cols, (Ids{1, 0}));
}

TEST(Assignment, TiesAsScipy) {
  // A constant matrix gives the identity, square or rectangular.
  const Assignment same = linear_sum_assignment(std::vector<double>(9, 1.0), 3, 3);
  EXPECT_EQ(same.cols, (Ids{0, 1, 2}));
  const Assignment tall = linear_sum_assignment(std::vector<double>(8, 0.0), 4, 2);
  EXPECT_EQ(tall.rows, (Ids{0, 1}));
  EXPECT_EQ(tall.cols, (Ids{0, 1}));
  // Two optima of cost 0 ({0,2,1}, {2,1,0}): row 0 takes col 0 (of its equal free columns 0
  // and 2, the lowest index), row 1 col 1, then row 2 reroutes row 1 to col 2.
  const Assignment zeros = linear_sum_assignment({0, 1, 0, 1, 0, 0, 0, 0, 1}, 3, 3);
  EXPECT_EQ(zeros.cols, (Ids{0, 2, 1}));
  // Two optima of cost 3 ({1,2,0}, {2,0,1}): scipy returns the second.
  const Assignment ones = linear_sum_assignment({2, 1, 1, 1, 2, 1, 1, 1, 2}, 3, 3);
  EXPECT_EQ(ones.cols, (Ids{2, 0, 1}));
}

TEST(Assignment, InfiniteEntries) {
  const Assignment a = linear_sum_assignment({kInf, 1, 2, kInf}, 2, 2);
  EXPECT_EQ(a.cols, (Ids{1, 0}));
  // Row 0 has only +inf: no assignment.
  EXPECT_THROW(linear_sum_assignment({kInf, kInf, 1, 2}, 2, 2), std::invalid_argument);
  // Both rows need column 0.
  EXPECT_THROW(linear_sum_assignment({1, kInf, 2, kInf}, 2, 2), std::invalid_argument);
}

TEST(Assignment, BadInput) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(linear_sum_assignment({1, nan, 2, 3}, 2, 2), std::invalid_argument);
  EXPECT_THROW(linear_sum_assignment({1, -kInf, 2, 3}, 2, 2), std::invalid_argument);
  EXPECT_THROW(linear_sum_assignment({1, 2, 3}, 2, 2), std::invalid_argument);
  EXPECT_TRUE(linear_sum_assignment({}, 0, 3).rows.empty());
  EXPECT_TRUE(linear_sum_assignment({}, 2, 0).cols.empty());
}

}  // namespace
}  // namespace tpuaf
