// VisitRule: arrivals after driving are visits; standing, dwelling and wobbling are not.
#include <gtest/gtest.h>

#include <stdexcept>

#include "tpuaf_core/visit_rule.hpp"

namespace tpuaf {
namespace {

// Two vertices 2 m apart on the x axis.
VisitRule pair_rule(double radius = 0.15) {
  Points p(2, 2);
  p << 0, 0, 2, 0;
  return VisitRule(p, radius);
}

TEST(VisitRule, StartIsTheFirstVisitAndStandingNeverCountsAgain) {
  VisitRule rule = pair_rule();
  rule.start(0, 0.02, 0.0);
  EXPECT_EQ(rule.visits(), 1);
  EXPECT_FALSE(rule.armed(0));
  EXPECT_TRUE(rule.armed(1));
  for (int k = 0; k < 900; ++k) EXPECT_FALSE(rule.arrive(0, 0.01 * (k % 3), 0.0));
  EXPECT_EQ(rule.visits(), 1);
}

TEST(VisitRule, DrivingThereIsAVisitOnceWithinTheRadius) {
  VisitRule rule = pair_rule();
  rule.start(0, 0.0, 0.0);
  EXPECT_FALSE(rule.arrive(1, 1.7, 0.0));  // 0.3 m short: not within 0.15 m
  EXPECT_TRUE(rule.arrive(1, 1.9, 0.0));
  EXPECT_FALSE(rule.arrive(1, 1.95, 0.0));  // a dwell on it
  EXPECT_EQ(rule.visits(), 2);
}

TEST(VisitRule, WobbleInsideTheHysteresisDoesNotRearm) {
  VisitRule rule = pair_rule();
  rule.start(0, 0.0, 0.0);
  rule.observe(0.25, 0.0);  // 0.25 m < 2 x 0.15 m: still disarmed
  EXPECT_FALSE(rule.arrive(0, 0.0, 0.0));
  rule.observe(0.31, 0.0);  // beyond the re-arm distance
  EXPECT_TRUE(rule.armed(0));
  EXPECT_TRUE(rule.arrive(0, 0.1, 0.0));
  EXPECT_EQ(rule.visits(), 2);
}

TEST(VisitRule, RefusesABadRadiusOrVertex) {
  Points p(1, 2);
  p << 0, 0;
  EXPECT_THROW(VisitRule(p, 0.0), std::invalid_argument);
  VisitRule rule(p, 0.1);
  EXPECT_THROW(rule.arrive(3, 0.0, 0.0), std::out_of_range);
}

}  // namespace
}  // namespace tpuaf
