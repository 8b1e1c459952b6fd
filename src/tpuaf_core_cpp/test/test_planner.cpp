// Global planner: hand-checked costmaps and paths on tiny grids (0.05 m cells, inscribed radius
// 0.2 m unless said otherwise).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>
#include <vector>

#include "tpuaf_core/planner.hpp"

namespace tpuaf {
namespace {

constexpr double kRes = 0.05;  // [m per cell]

GridMask empty_grid(int h = 80, int w = 80) { return GridMask::Constant(h, w, false); }

std::shared_ptr<Costmap> costmap(const GridMask& grid, CostmapSpec spec = {},
                                 double planning_res = 0.0) {
  return std::make_shared<Costmap>(grid, kRes, 0.0, 0.0, spec, planning_res);
}

// Exact distance [m] from p to the occupied squares and the outside of the grid, capped at cap.
double clearance(const GridMask& grid, const Eigen::Vector2d& p, double cap) {
  const int h = static_cast<int>(grid.rows()), w = static_cast<int>(grid.cols());
  double best = std::min({p.x(), p.y(), w * kRes - p.x(), h * kRes - p.y(), cap});
  const int reach = static_cast<int>(std::ceil(cap / kRes)) + 2;
  const int c = static_cast<int>(std::floor(p.x() / kRes));
  const int r = static_cast<int>(std::floor(p.y() / kRes));
  for (int rr = std::max(0, r - reach); rr <= std::min(h - 1, r + reach); ++rr)
    for (int cc = std::max(0, c - reach); cc <= std::min(w - 1, c + reach); ++cc) {
      if (!grid(rr, cc)) continue;
      const double dx = std::max({cc * kRes - p.x(), 0.0, p.x() - (cc + 1) * kRes});
      const double dy = std::max({rr * kRes - p.y(), 0.0, p.y() - (rr + 1) * kRes});
      best = std::min(best, std::hypot(dx, dy));
    }
  return best;
}

// Smallest clearance along the path from its (snapped) start, sampled every res / 4.
double path_clearance(const GridMask& grid, const Plan& plan, double cap) {
  double worst = cap;
  const std::size_t first = plan.start_snapped ? 1 : 0;
  for (std::size_t i = first + 1; i < plan.points.size(); ++i) {
    const Eigen::Vector2d a = plan.points[i - 1], b = plan.points[i];
    const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / (kRes / 4))));
    for (int k = 0; k <= n; ++k) worst = std::min(worst, clearance(grid, a + (b - a) * k / n, cap));
  }
  return worst;
}

double polyline_length(const std::vector<Eigen::Vector2d>& pts) {
  double sum = 0;
  for (std::size_t i = 1; i < pts.size(); ++i) sum += (pts[i] - pts[i - 1]).norm();
  return sum;
}

// --- costmap ------------------------------------------------------------------------------------

TEST(Costmap, DistanceTransformIsTheExactGapBetweenCells) {
  GridMask grid = empty_grid(30, 41);
  std::mt19937 rng(7);
  for (int i = 0; i < 25; ++i) {
    const int r = rng() % 30, c = rng() % 41;
    grid(r, c) = true;
  }
  const Costmap cm(grid, kRes, 0.0, 0.0);
  for (int r = 0; r < 30; ++r)
    for (int c = 0; c < 41; ++c) {
      // The outside of the grid is occupied: gap to it = cells between this one and the edge.
      double best = std::min({c, r, 40 - c, 29 - r}) * kRes;
      for (int rr = 0; rr < 30; ++rr)
        for (int cc = 0; cc < 41; ++cc)
          if (grid(rr, cc))
            best = std::min(best, kRes * std::hypot(std::max(std::abs(rr - r) - 1, 0),
                                                    std::max(std::abs(cc - c) - 1, 0)));
      ASSERT_NEAR(cm.map_distances()[r * 41 + c], best, 1e-6) << "cell " << r << ", " << c;
    }
}

TEST(Costmap, LethalBandAndExponentialCost) {
  GridMask grid = empty_grid(81, 81);
  grid(40, 40) = true;
  const Costmap cm(grid, kRes, 0.0, 0.0);  // inscribed 0.2, inflation 0.6, 5 / m
  auto at = [](int r, int c) { return Eigen::Vector2d((c + 0.5) * kRes, (r + 0.5) * kRes); };
  auto p = at(40, 45);  // gap 4 cells = 0.2 m: the first non-lethal cell, cost 1
  EXPECT_NEAR(cm.distance_to_obstacle(p.x(), p.y()), 0.2, 1e-6);
  EXPECT_FALSE(cm.is_lethal(p.x(), p.y()));
  EXPECT_NEAR(cm.cost(p.x(), p.y()), 1.0, 1e-6);
  p = at(40, 44);  // 0.15 m
  EXPECT_TRUE(cm.is_lethal(p.x(), p.y()));
  p = at(43, 44);  // gap hypot(2, 3) cells = 0.18 m
  EXPECT_TRUE(cm.is_lethal(p.x(), p.y()));
  p = at(40, 46);  // 0.25 m
  EXPECT_NEAR(cm.cost(p.x(), p.y()), std::exp(-5.0 * 0.05), 1e-6);
  p = at(40, 52);  // 0.55 m
  EXPECT_NEAR(cm.cost(p.x(), p.y()), std::exp(-5.0 * 0.35), 1e-6);
  p = at(40, 53);  // 0.6 m: the inflation radius
  EXPECT_EQ(cm.cost(p.x(), p.y()), 0.0);
  EXPECT_TRUE(cm.is_lethal(-0.1, 1.0));                // outside the map
  EXPECT_EQ(cm.distance_to_obstacle(0.01, 2.0), 0.0);  // next to the map edge
}

TEST(Costmap, CoarseCellIsLethalIfAnyOfItsCellsIs) {
  GridMask grid = empty_grid(31, 45);
  std::mt19937 rng(3);
  for (int i = 0; i < 6; ++i) {
    const int r = rng() % 31, c = rng() % 45;
    grid(r, c) = true;
  }
  const CostmapSpec spec{0.1, 0.4, 5.0, 1.0};
  const Costmap fine(grid, kRes, 0.0, 0.0, spec);
  const Costmap coarse(grid, kRes, 0.0, 0.0, spec, 0.1);
  ASSERT_EQ(coarse.downsample(), 2);
  ASSERT_EQ(coarse.width(), 23);
  ASSERT_EQ(coarse.height(), 16);
  EXPECT_DOUBLE_EQ(coarse.resolution(), 0.1);
  int lethal = 0;
  for (int R = 0; R < 16; ++R)
    for (int C = 0; C < 23; ++C) {
      bool any = (2 * R + 2 > 31) || (2 * C + 2 > 45);  // overhangs the map
      double worst = 0;
      for (int r = 2 * R; r < std::min(2 * R + 2, 31); ++r)
        for (int c = 2 * C; c < std::min(2 * C + 2, 45); ++c) {
          any = any || fine.lethal()[r * 45 + c];
          worst = std::max(worst, static_cast<double>(fine.costs()[r * 45 + c]));
        }
      EXPECT_EQ(coarse.lethal()[R * 23 + C] != 0, any) << R << ", " << C;
      if (!any) EXPECT_NEAR(coarse.costs()[R * 23 + C], worst, 1e-6);
      lethal += any;
    }
  EXPECT_GT(lethal, 0);
  EXPECT_LT(lethal, 16 * 23);
}

TEST(Costmap, RejectsInvalidArguments) {
  const GridMask grid = empty_grid(10, 10);
  EXPECT_THROW(Costmap(grid, 0.0, 0.0, 0.0), std::invalid_argument);
  EXPECT_THROW(Costmap(grid, kRes, NAN, 0.0), std::invalid_argument);
  EXPECT_THROW(Costmap(grid, kRes, 0.0, 0.0, CostmapSpec{0.3, 0.2, 5.0, 1.0}),
               std::invalid_argument);
  EXPECT_THROW(Costmap(grid, kRes, 0.0, 0.0, CostmapSpec{0.2, 0.6, -1.0, 1.0}),
               std::invalid_argument);
  EXPECT_THROW(Costmap(GridMask(0, 0), kRes, 0.0, 0.0), std::invalid_argument);
}

// --- planner ------------------------------------------------------------------------------------

TEST(Planner, StraightLineInOpenSpace) {
  GridPlanner planner(costmap(empty_grid()));
  const Plan plan = planner.plan({1.0, 1.0}, {3.0, 2.5});
  ASSERT_TRUE(plan.ok());
  ASSERT_EQ(plan.points.size(), 2u);
  EXPECT_NEAR(plan.length_m, std::hypot(2.0, 1.5), 1e-9);
  EXPECT_EQ(plan.points.front(), Eigen::Vector2d(1.0, 1.0));
  EXPECT_EQ(plan.points.back(), Eigen::Vector2d(3.0, 2.5));
  EXPECT_FALSE(plan.start_snapped);
  EXPECT_FALSE(plan.goal_snapped);
}

TEST(Planner, GoesThroughTheGapAtTheExpectedLength) {
  // Wall x in [2.0, 2.05) m with a gap y in [3.0, 3.6) m.
  GridMask grid = empty_grid();
  grid.col(40).setConstant(true);
  grid.block(60, 40, 12, 1).setConstant(false);
  CostmapSpec spec;
  spec.cost_weight = 0.0;  // pure length: the taut string around the inflated wall end
  GridPlanner planner(costmap(grid, spec));
  const Eigen::Vector2d s(1.0, 1.0), g(3.05, 1.0);
  const Plan plan = planner.plan(s, g);
  ASSERT_TRUE(plan.ok());
  // Continuous optimum with clearance r: tangents to circles r around the wall's top corners
  // (2, 3) and (2.05, 3), the arcs over them, and the 0.05 m top.
  auto optimum = [](double r) {
    const double d = std::hypot(1.0, 2.0), tangent = std::sqrt(d * d - r * r);
    const double arc = r * (std::atan2(-2.0, -1.0) + 2 * M_PI - std::acos(r / d) - M_PI / 2);
    return 2 * (tangent + arc) + 0.05;
  };
  // Lethal cells are conservative by at most a cell diagonal: every point with clearance
  // >= r + sqrt(2) res lies on a non-lethal cell.
  EXPECT_GE(plan.length_m, optimum(0.2) - 1e-9);
  EXPECT_LE(plan.length_m, optimum(0.2 + std::sqrt(2.0) * kRes) + 0.02);
  EXPECT_NEAR(plan.length_m - (g - s).norm(), optimum(0.2) - 2.05, 0.2);
  double top = 0;
  for (const auto& p : plan.points) top = std::max(top, p.y());
  EXPECT_GT(top, 3.2);  // over the wall end, through the gap
  EXPECT_LT(top, 3.4);
  EXPECT_GE(path_clearance(grid, plan, 0.5), 0.2 - 1e-9);
  EXPECT_NEAR(plan.length_m, polyline_length(plan.points), 1e-9);
}

GridMask wall_with_door(int door_cells) {  // wall x in [2.0, 2.05), door centred on y = 2 m
  GridMask grid = empty_grid();
  grid.col(40).setConstant(true);
  grid.block(40 - door_cells / 2, 40, door_cells, 1).setConstant(false);
  return grid;
}

TEST(Planner, DoorNarrowerThanTheRobotIsClosedAndAWiderOneOpen) {
  const Eigen::Vector2d s(1.0, 2.0), g(3.0, 2.0);
  for (int cells : {7, 8}) {  // 0.35 m, 0.40 m = 2 x inscribed
    GridPlanner planner(costmap(wall_with_door(cells)));
    const Plan plan = planner.plan(s, g);
    EXPECT_EQ(plan.status, PlanStatus::no_path) << cells;
    EXPECT_TRUE(plan.points.empty());
    EXPECT_EQ(plan.length_m, 0.0);
    EXPECT_GT(plan.expanded, 0);
  }
  const GridMask grid = wall_with_door(9);  // 0.45 m: one cell more than 2 x inscribed
  GridPlanner planner(costmap(grid));
  const Plan plan = planner.plan(s, g);
  ASSERT_TRUE(plan.ok());
  EXPECT_NEAR(plan.length_m, 2.0, 0.1);
  EXPECT_GE(path_clearance(grid, plan, 0.5), 0.2 - 1e-9);
}

TEST(Planner, EnclosedGoalHasNoPath) {
  GridMask grid = empty_grid();
  grid.block(44, 44, 1, 33).setConstant(true);
  grid.block(76, 44, 1, 33).setConstant(true);
  grid.block(44, 44, 33, 1).setConstant(true);
  grid.block(44, 76, 33, 1).setConstant(true);
  GridPlanner planner(costmap(grid));
  const Plan plan = planner.plan({1.0, 1.0}, {3.0, 3.0});
  EXPECT_EQ(plan.status, PlanStatus::no_path);
  EXPECT_TRUE(plan.points.empty());
  EXPECT_TRUE(planner.plan({2.8, 3.0}, {3.0, 3.3}).ok());  // inside the box
  EXPECT_TRUE(std::isinf(planner.path_length({1.0, 1.0}, {3.0, 3.0})));
}

TEST(Planner, StartAndGoalInTheInflatedZoneSnap) {
  GridMask grid = empty_grid();
  grid.col(40).setConstant(true);  // wall x in [2.0, 2.05)
  GridPlanner planner(costmap(grid));
  const Eigen::Vector2d s(1.9, 2.01), g(1.0, 2.0);
  Plan plan = planner.plan(s, g);
  ASSERT_TRUE(plan.ok());
  EXPECT_TRUE(plan.start_snapped);
  EXPECT_FALSE(plan.goal_snapped);
  EXPECT_EQ(plan.points.front(), s);  // where the robot is
  EXPECT_EQ(plan.points[1], plan.start);
  EXPECT_NEAR(plan.start.x(), 1.775, 1e-9);  // column 35: the first at 0.2 m from the wall
  EXPECT_NEAR(plan.start.y(), 2.025, 1e-9);
  EXPECT_GE(path_clearance(grid, plan, 0.5), 0.2 - 1e-9);

  plan = planner.plan(g, s);  // the goal snaps: the path ends at the snapped goal
  ASSERT_TRUE(plan.ok());
  EXPECT_TRUE(plan.goal_snapped);
  EXPECT_EQ(plan.points.back(), plan.goal);
  EXPECT_NEAR(plan.goal.x(), 1.775, 1e-9);

  PlannerOptions tight;
  tight.snap_radius_m = 0.1;
  planner.set_options(tight);
  EXPECT_EQ(planner.plan(s, g).status, PlanStatus::start_blocked);
  EXPECT_EQ(planner.plan(g, s).status, PlanStatus::goal_blocked);
}

TEST(Planner, SnapNeverJumpsThroughAWall) {
  // A 0.25 m pocket (all lethal) between a thick wall and a one-cell wall; the free side of the
  // thin wall is within the snap radius but behind it.
  GridMask grid = empty_grid();
  grid.block(0, 25, 80, 10).setConstant(true);  // x in [1.25, 1.75)
  grid.col(40).setConstant(true);               // x in [2.0, 2.05)
  GridPlanner planner(costmap(grid));
  EXPECT_EQ(planner.plan({1.9, 2.01}, {3.0, 2.0}).status, PlanStatus::start_blocked);
  grid.col(40).setConstant(false);  // without the thin wall it snaps to its right
  GridPlanner open(costmap(grid));
  const Plan plan = open.plan({1.9, 2.01}, {3.0, 2.0});
  ASSERT_TRUE(plan.ok());
  EXPECT_TRUE(plan.start_snapped);
  EXPECT_GT(plan.start.x(), 1.9);
}

TEST(Planner, TemporaryDiscBlocksACorridorForOnePlan) {
  GridMask grid = empty_grid();
  grid.topRows(30).setConstant(true);     // y < 1.5 m (row 0 is the bottom)
  grid.bottomRows(30).setConstant(true);  // y >= 2.5 m
  GridPlanner planner(costmap(grid));
  const Eigen::Vector2d s(0.5, 2.0), g(3.5, 2.0);
  Plan plan = planner.plan(s, g);
  ASSERT_TRUE(plan.ok());
  EXPECT_NEAR(plan.length_m, 3.0, 0.06);
  const Plan blocked = planner.plan(s, g, {Disc{2.0, 2.0, 0.3}});
  EXPECT_EQ(blocked.status, PlanStatus::no_path);
  const Plan again = planner.plan(s, g);  // the disc is gone
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again.points, plan.points);
}

TEST(Planner, TemporaryDiscCausesADetour) {
  const GridMask grid = empty_grid();
  CostmapSpec spec;
  spec.cost_weight = 0.0;  // pure length: tangents to the circle of 0.3 + 0.2 m and its arc
  GridPlanner planner(costmap(grid, spec));
  const Disc disc{2.0, 2.0, 0.3};
  const Plan plan = planner.plan({1.0, 2.0}, {3.0, 2.0}, {disc});
  ASSERT_TRUE(plan.ok());
  const double optimum = 2 * (std::sqrt(1.0 - 0.25) + 0.5 * (M_PI / 2 - std::acos(0.5)));
  EXPECT_GE(plan.length_m, optimum - 1e-9);
  EXPECT_LE(plan.length_m, optimum + 0.1);
  for (std::size_t i = 1; i < plan.points.size(); ++i) {
    const Eigen::Vector2d a = plan.points[i - 1], b = plan.points[i];
    for (int k = 0; k <= 100; ++k) {
      const Eigen::Vector2d p = a + (b - a) * (k / 100.0);
      EXPECT_GE((p - Eigen::Vector2d(disc.x_m, disc.y_m)).norm(), 0.3 + 0.2 - 1e-9);
    }
  }
  EXPECT_THROW(planner.plan({1.0, 2.0}, {3.0, 2.0}, {Disc{2.0, 2.0, 0.0}}), std::invalid_argument);
  EXPECT_TRUE(planner.plan({1.0, 2.0}, {3.0, 2.0}).points.size() == 2u);  // restored
}

GridMask cluttered(int h, int w, unsigned seed) {
  GridMask grid = GridMask::Constant(h, w, false);
  std::mt19937 rng(seed);
  for (int i = 0; i < 30; ++i) {
    const int bh = 2 + rng() % 8, bw = 2 + rng() % 8;
    const int r = rng() % (h - bh), c = rng() % (w - bw);
    grid.block(r, c, bh, bw).setConstant(true);
  }
  return grid;
}

TEST(Planner, SmoothedPathsKeepTheInscribedClearance) {
  const GridMask grid = cluttered(100, 140, 11);
  for (double planning_res : {0.0, 0.1, 0.15}) {
    GridPlanner planner(costmap(grid, CostmapSpec{}, planning_res));
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> x(0.1, 6.9), y(0.1, 4.9);
    int ok = 0;
    for (int i = 0; i < 40; ++i) {
      const Plan plan = planner.plan({x(rng), y(rng)}, {x(rng), y(rng)});
      if (!plan.ok()) continue;
      ++ok;
      EXPECT_GE(path_clearance(grid, plan, 0.3), 0.2 - 1e-9) << planning_res << " plan " << i;
      PlannerOptions raw;
      raw.smooth = false;
      planner.set_options(raw);
      const Plan unsmoothed = planner.plan(plan.points.front(), plan.goal);
      planner.set_options(PlannerOptions{});
      ASSERT_TRUE(unsmoothed.ok());
      EXPECT_LE(plan.cost_m, unsmoothed.cost_m + 1e-6);  // shortcuts never cost more
      EXPECT_LE(plan.points.size(), unsmoothed.points.size());
    }
    EXPECT_GE(ok, 15) << planning_res;
  }
}

TEST(Planner, KeepsToTheMiddleOfAWideCorridor) {
  GridMask grid = empty_grid(60, 120);
  grid.topRows(20).setConstant(true);     // y < 1.0
  grid.bottomRows(20).setConstant(true);  // y >= 2.0: corridor 1 m wide, centre y = 1.5
  GridPlanner planner(costmap(grid));
  // Start and goal 0.25 m from the lower wall: the path goes to the middle in between.
  const Plan plan = planner.plan({0.5, 1.25}, {5.5, 1.25});
  ASSERT_TRUE(plan.ok());
  double top = 0;
  for (const auto& p : plan.points) top = std::max(top, p.y());
  EXPECT_GT(top, 1.4);
}

TEST(Planner, IsDeterministicAndReusesItsBuffers) {
  const GridMask grid = cluttered(100, 140, 4);
  const auto cm = costmap(grid);
  GridPlanner a(cm), b(cm);
  const Eigen::Vector2d s(0.3, 0.3), g(6.7, 4.7);
  const Plan first = a.plan(s, g);
  for (int i = 0; i < 5; ++i) a.plan({1.0 + i, 1.0}, {5.0 - i, 4.0});
  const Plan second = a.plan(s, g);
  const Plan fresh = b.plan(s, g);
  EXPECT_EQ(first.status, second.status);
  EXPECT_EQ(first.points, second.points);
  EXPECT_EQ(first.points, fresh.points);
  EXPECT_EQ(first.expanded, fresh.expanded);
}

TEST(Planner, PlanEdgesAgreesWithSinglePlans) {
  GridMask grid = empty_grid();
  grid.col(40).setConstant(true);
  grid.block(60, 40, 12, 1).setConstant(false);
  const auto cm = costmap(grid);
  GridPlanner planner(cm);
  Points vertices(5, 2);
  vertices << 1.0, 1.0, 3.05, 1.0, 1.0, 3.5, 3.05, 3.5, -1.0, 1.0;  // the last one is outside
  Eigen::Matrix<int, Eigen::Dynamic, 2, Eigen::RowMajor> edges(6, 2);
  edges << 0, 1, 0, 2, 3, 1, 2, 3, 3, 0, 4, 0;
  const std::vector<Plan> plans = planner.plan_edges(vertices, edges);
  ASSERT_EQ(plans.size(), 6u);
  for (int e = 0; e < 5; ++e) {
    const Eigen::Vector2d a = vertices.row(edges(e, 0)).transpose();
    const Eigen::Vector2d b = vertices.row(edges(e, 1)).transpose();
    const Plan single = planner.plan(a, b);
    ASSERT_TRUE(plans[e].ok()) << e;
    EXPECT_EQ(plans[e].points.front(), a);
    EXPECT_EQ(plans[e].points.back(), b);
    EXPECT_NEAR(plans[e].length_m, single.length_m, 2 * kRes) << e;
    EXPECT_NEAR(plans[e].cost_m, single.cost_m, 2 * kRes) << e;
    EXPECT_GE(path_clearance(grid, plans[e], 0.5), 0.2 - 1e-9);
  }
  EXPECT_EQ(plans[5].status, PlanStatus::start_blocked);
  Eigen::Matrix<int, Eigen::Dynamic, 2, Eigen::RowMajor> bad(1, 2);
  bad << 0, 5;
  EXPECT_THROW(planner.plan_edges(vertices, bad), std::invalid_argument);
}

TEST(Planner, RejectsInvalidArguments) {
  GridPlanner planner(costmap(empty_grid()));
  EXPECT_THROW(planner.plan({NAN, 1.0}, {2.0, 2.0}), std::invalid_argument);
  EXPECT_THROW(planner.plan({1.0, 1.0}, {INFINITY, 2.0}), std::invalid_argument);
  EXPECT_THROW(planner.plan({1.0, 1.0}, {2.0, 2.0}, {Disc{1.5, 1.5, -1.0}}), std::invalid_argument);
  PlannerOptions bad;
  bad.snap_radius_m = -0.1;
  EXPECT_THROW(planner.set_options(bad), std::invalid_argument);
  EXPECT_THROW(GridPlanner(nullptr), std::invalid_argument);
  // Outside the map is occupied: blocked, not an exception.
  EXPECT_EQ(planner.plan({-5.0, 1.0}, {2.0, 2.0}).status, PlanStatus::start_blocked);
}

// The seams: a planner built from another search or smoother uses it.
TEST(PlannerSeams, DijkstraFindsPathsAsCheapAsAStarWithMoreExpansions) {
  const GridMask grid = cluttered(100, 140, 4);
  const auto cm = costmap(grid);
  PlannerOptions raw;
  raw.smooth = false;  // compare the searches' cell paths
  GridPlanner astar(cm, raw), dijkstra(cm, raw, std::make_unique<AStarSearch>(false));
  const Eigen::Vector2d s(0.3, 0.3), g(6.7, 4.7);
  const Plan a = astar.plan(s, g), d = dijkstra.plan(s, g);
  ASSERT_TRUE(a.ok());
  ASSERT_TRUE(d.ok());
  EXPECT_NEAR(a.cost_m, d.cost_m, 1e-6);  // both optimal on the same step costs
  EXPECT_GT(d.expanded, a.expanded);      // the heuristic prunes
}

class CountingSmoother final : public PathSmoother {
 public:
  explicit CountingSmoother(int* calls) : calls_(calls) {}
  void smooth(const PlanningGrid&, std::vector<Eigen::Vector2d>& pts,
              std::size_t first) const override {
    ++*calls_;
    pts.erase(pts.begin() + static_cast<std::ptrdiff_t>(first) + 1, pts.end() - 1);  // a chord
  }

 private:
  int* calls_;
};

TEST(PlannerSeams, ACustomSmootherIsCalledUnlessSmoothingIsOff) {
  const auto cm = costmap(empty_grid());
  int calls = 0;
  GridPlanner planner(cm, {}, nullptr, std::make_unique<CountingSmoother>(&calls));
  const Plan p = planner.plan({0.5, 0.5}, {3.5, 2.5});
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(p.points.size(), 2u);  // the chord it left
  PlannerOptions off;
  off.smooth = false;
  planner.set_options(off);
  EXPECT_GT(planner.plan({0.5, 0.5}, {3.5, 2.5}).points.size(), 2u);
  EXPECT_EQ(calls, 1);
}

}  // namespace
}  // namespace tpuaf
