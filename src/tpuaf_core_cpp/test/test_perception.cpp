// Perception model (Eq. 1) against its closed form.
#include <gtest/gtest.h>

#include "tpuaf_core/perception.hpp"

namespace tpuaf {
namespace {

TEST(Perception, PeakAtTheRobotZeroAtTheRadius) {
  EXPECT_DOUBLE_EQ(perception(0.0, 1.0, 5.0), 1.0);
  EXPECT_DOUBLE_EQ(perception(5.0, 1.0, 5.0), 0.0);
  EXPECT_DOUBLE_EQ(perception(7.0, 1.0, 5.0), 0.0);
}

TEST(Perception, HalfRadiusIsNineSixteenthsOfThePeak) {
  // (s^2 - r^2)^2 / r^4 at s = r/2: (1/4 - 1)^2 = 9/16.
  EXPECT_NEAR(perception(2.5, 2.0, 5.0), 2.0 * 0.5625, 1e-12);
}

TEST(Perception, MatrixIsTargetsByRobotsAndSumsOverRobots) {
  Points targets(2, 2);
  targets << 0, 0, 10, 0;
  Points robots(2, 2);
  robots << 0, 0, 10, 2.5;
  Eigen::VectorXd peaks = Eigen::VectorXd::Constant(2, 1.0);
  Eigen::VectorXd radii = Eigen::VectorXd::Constant(2, 5.0);
  Eigen::MatrixXd m = perception_matrix(targets, robots, peaks, radii);
  ASSERT_EQ(m.rows(), 2);
  ASSERT_EQ(m.cols(), 2);
  EXPECT_DOUBLE_EQ(m(0, 0), 1.0);
  EXPECT_DOUBLE_EQ(m(0, 1), 0.0);
  EXPECT_NEAR(m(1, 1), 0.5625, 1e-12);
  Eigen::VectorXd total = total_perception(targets, robots, peaks, radii);
  EXPECT_NEAR(total(0), 1.0, 1e-12);
  EXPECT_NEAR(total(1), 0.5625, 1e-12);
}

}  // namespace
}  // namespace tpuaf
