// 2-D world: hand-checkable laser ranges, the exact arc, contacts that stop robots.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tpuaf_core/world.hpp"

namespace tpuaf {
namespace {

constexpr double kRes = 0.1;  // [m per cell]

GridMask wall_at_x3() {
  GridMask grid = GridMask::Constant(40, 60, false);
  grid.col(30).setConstant(true);  // cells x in [3.0, 3.1) m
  return grid;
}

LaserSpec one_beam(double angle) {
  LaserSpec laser;
  laser.beams = 1;
  laser.angle_min_rad = angle;
  laser.range_min_m = 0.0;
  laser.range_max_m = 10.0;
  return laser;
}

TEST(World, LaserSeesTheWallAtItsDistance) {
  World world(wall_at_x3(), kRes, 0.0, 0.0);
  world.add_robot(RobotSpec{}, one_beam(0.0), 1.0, 1.05, 0.0);
  float range = 0;
  world.scan(0, &range);
  EXPECT_NEAR(range, 2.0, 1e-5);
}

TEST(World, MapEdgeIsAWall) {
  World world(wall_at_x3(), kRes, 0.0, 0.0);
  world.add_robot(RobotSpec{}, one_beam(M_PI), 1.0, 1.05, 0.0);
  float range = 0;
  world.scan(0, &range);
  EXPECT_NEAR(range, 1.0, 1e-5);
}

TEST(World, ArcIntegrationIsExact) {
  // Quarter circle of radius v/w = 1 m from the origin heading +x ends at (1, 1, pi/2).
  Eigen::Vector3d end = integrate_arc(Eigen::Vector3d(0, 0, 0), 1.0, 1.0, M_PI / 2);
  EXPECT_NEAR(end(0), 1.0, 1e-12);
  EXPECT_NEAR(end(1), 1.0, 1e-12);
  EXPECT_NEAR(end(2), M_PI / 2, 1e-12);
}

TEST(World, DrivingIntoAWallStopsBeforeContactAndFlagsStall) {
  World world(wall_at_x3(), kRes, 0.0, 0.0);
  RobotSpec robot;
  robot.max_linear_speed = 1.0;
  robot.max_linear_accel = std::numeric_limits<double>::infinity();
  world.add_robot(robot, one_beam(0.0), 2.0, 1.05, 0.0);
  world.set_command(0, 1.0, 0.0);
  bool stalled = false;
  for (int k = 0; k < 200; ++k) {
    world.step(0.01);
    stalled = stalled || world.stalled()[0];
  }
  EXPECT_TRUE(stalled);
  EXPECT_LE(world.poses()(0, 0) + robot.radius_m, 3.0 + 1e-6);  // never inside the wall
  EXPECT_GT(world.contact_counts()[0], 0);
}

TEST(World, RobotOnAWallIsRefused) {
  World world(wall_at_x3(), kRes, 0.0, 0.0);
  EXPECT_THROW(world.add_robot(RobotSpec{}, one_beam(0.0), 3.05, 1.0, 0.0), std::invalid_argument);
}

TEST(World, SameSeedSameNoisyScans) {
  LaserSpec noisy = one_beam(0.0);
  noisy.noise_std_m = 0.05;
  std::vector<float> a(5), b(5);
  for (auto* out : {&a, &b}) {
    World world(wall_at_x3(), kRes, 0.0, 0.0, 42);
    world.add_robot(RobotSpec{}, noisy, 1.0, 1.05, 0.0);
    for (float& r : *out) world.scan(0, &r);
  }
  EXPECT_EQ(a, b);
  EXPECT_NE(a[0], a[1]);
}

}  // namespace
}  // namespace tpuaf
