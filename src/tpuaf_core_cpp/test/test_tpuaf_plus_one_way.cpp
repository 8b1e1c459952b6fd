// TPUAF+'s spacing towards uneven gaps (one-way walks that pass a vertex twice).
#include <gtest/gtest.h>

#include "tpuaf_core/tpuaf_plus.hpp"

namespace tpuaf {
namespace {

TEST(TpuafPlusOneWay, EvenGapsDwellAsTheEvenRule) {
  const std::vector<MatePlace> mates{{34.0, 0.0, 1.0, 2}, {2.0, 0.0, 1.0, 1}};
  EXPECT_NEAR(spacing_dwell_gaps(mates, {40.0 / 3, 40.0 / 3, 40.0 / 3}, 0, 40.0, 1.0, 0.35, 0.5),
              spacing_dwell(mates, 40.0, 1.0, 0.35, 0.5), 1e-9);
  // gaps of the wrong count: the even rule
  EXPECT_NEAR(spacing_dwell_gaps(mates, {20.0, 20.0}, 0, 40.0, 1.0, 0.35, 0.5),
              spacing_dwell(mates, 40.0, 1.0, 0.35, 0.5), 1e-9);
}

TEST(TpuafPlusOneWay, UnevenGapsAimAtTheNearestRotation) {
  // L = 40 m, gaps 16 and 24 m. A mate 18 m ahead: the nearest rotation wants it 16 m ahead,
  // so I am late (e = -(18 - 16) / 2 < 0): no dwell, where the even rule (20 m) would dwell.
  EXPECT_EQ(spacing_dwell_gaps({{18.0, 0.0, 1.0, 1}}, {16.0, 24.0}, 0, 40.0, 1.0, 0.35, 0.5), 0.0);
  EXPECT_GT(spacing_dwell({{18.0, 0.0, 1.0, 1}}, 40.0, 1.0, 0.35, 0.5), 0.0);
  // the mate sees me 22 m ahead: its nearest rotation wants 24 m: early by 1 m, dwells
  // 2 gain e = 0.7 s (past the deadband: at least 0.6 s)
  EXPECT_NEAR(spacing_dwell_gaps({{22.0, 0.0, 1.0, 0}}, {16.0, 24.0}, 1, 40.0, 1.0, 0.35, 0.5), 0.7,
              1e-9);
  // 10 m ahead: nearest 16 m: early by 3 m, 2.1 s
  EXPECT_NEAR(spacing_dwell_gaps({{10.0, 0.0, 1.0, 1}}, {16.0, 24.0}, 0, 40.0, 1.0, 0.35, 0.5), 2.1,
              1e-9);
}

}  // namespace
}  // namespace tpuaf
