// The one ground-truth recorder (recorder.hpp) fed directly: start time, rows without ground
// truth, outages ended or not, dwells, absent robots.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>

#include "tpuaf_core/recorder.hpp"

namespace tpuaf {
namespace {

// Three targets 10 m apart on a line, X growing at 0.01 /s from 1.
UncertaintyField line_field() {
  Points p(3, 2);
  p << 0, 0, 10, 0, 20, 0;
  return UncertaintyField(p, Eigen::VectorXd::Constant(3, 0.01), Eigen::VectorXd::Ones(3));
}

RecorderConfig two_robots(double start_s, bool ground_truth) {
  RecorderConfig c;
  c.robots = 2;
  c.start_time_s = start_s;
  c.ground_truth = ground_truth;
  return c;
}

TEST(Recorder, RowsWithoutGroundTruthFollowTheVisitsFromTheStartTime) {
  GroundTruthRecorder rec(two_robots(100.0, false), line_field());
  rec.record_visit(0, 1, 103.5);  // rows at 101, 102, 103 s: vertex 1 not yet visited
  ASSERT_EQ(rec.row_count(), 3u);
  EXPECT_DOUBLE_EQ(rec.timeseries()[0].time_s, 101.0);
  EXPECT_DOUBLE_EQ(rec.timeseries()[2].idleness_ins_s, 3.0);  // every vertex idle since 100 s
  EXPECT_TRUE(std::isnan(rec.timeseries()[2].uncertainty_mean));
  EXPECT_EQ(rec.timeseries()[2].visits, 0);
  rec.finish(105.0);
  ASSERT_EQ(rec.row_count(), 5u);
  EXPECT_EQ(rec.timeseries()[3].visits, 1);          // the 104 s row sees the visit at 103.5 s
  EXPECT_DOUBLE_EQ(rec.worst_idleness(105.0), 5.0);  // from the start, not from 0 s
  EXPECT_EQ(rec.x_count(), 0);
}

TEST(Recorder, AnOutageEndedIsNoDeathOneNeverEndedIs) {
  GroundTruthRecorder rec(two_robots(0.0, true), line_field());
  Points p(2, 2);
  p << 0, 0, 20, 0;
  rec.record_positions(0.0, p);
  rec.record_robot_outage(1, 5.0, "silent");
  rec.record_positions(10.0, p);
  rec.record_robot_back(1, 12.0);
  rec.record_positions(20.0, p);  // robot 1 seen again
  rec.record_robot_outage(0, 30.0, "silent");
  rec.record_robot_death(0, 31.0);  // out of contact already: not recorded again
  rec.finish(40.0);
  ASSERT_EQ(rec.outages().size(), 2u);
  EXPECT_TRUE(rec.outages()[0].ended);
  EXPECT_DOUBLE_EQ(rec.outages()[0].end_s, 12.0);
  EXPECT_FALSE(rec.outages()[1].ended);
  const auto deaths = rec.final_deaths();
  ASSERT_EQ(deaths.size(), 1u);
  EXPECT_EQ(deaths[0].robot, 0);
  EXPECT_DOUBLE_EQ(deaths[0].time_s, 30.0);
  EXPECT_TRUE(rec.deaths().empty());
  EXPECT_TRUE(std::isnan(rec.positions()(0, 0)));   // robot 0 is absent now
  EXPECT_FALSE(std::isnan(rec.positions()(1, 0)));  // robot 1 is back since 20 s
  EXPECT_THROW(rec.record_robot_back(2, 1.0), std::out_of_range);
}

TEST(Recorder, AnAbsentRobotNeitherSensesNorInterferes) {
  GroundTruthRecorder rec(two_robots(0.0, true), line_field());
  Points p(2, 2);
  p << 0, 0, NAN, NAN;  // robot 1 not seen yet
  rec.record_positions(0.0, p);
  p << 0, 0, 0, 0;  // robot 1 appears on robot 0: not an entry (it did not come close)
  rec.record_positions(1.0, p);
  EXPECT_TRUE(rec.interferences().empty());
  p << 0, 0, 20, 0;
  rec.record_positions(2.0, p);
  p << 0, 0, 1, 0;  // robot 1 drives back within d_if = 2 m: an entry
  rec.record_positions(3.0, p);
  ASSERT_EQ(rec.interferences().size(), 1u);
  EXPECT_NEAR(rec.interferences()[0].time_s, 2.0 + 18.0 / 19.0, 1e-12);
}

// The recorder's field against UncertaintyField::advance_linear on a 12 x 12 grid of targets
// 1 m apart, two robots driving across it for 1 s (4 substeps; sensing radius 2 m, so most
// targets are uncovered): equal bit for bit, with one importance for all targets (the
// recorder's shared-rate loop) and with a different one per target (the general loop).
void expect_field_as_uncertainty_field(bool one_importance) {
  Points targets(144, 2);
  Eigen::VectorXd importance(144);
  for (int j = 0; j < 144; ++j) {
    targets.row(j) << j % 12, j / 12;
    importance[j] = one_importance ? 0.01 : 0.01 + 0.001 * (j % 7);
  }
  const Eigen::VectorXd initial = Eigen::VectorXd::LinSpaced(144, 0.5, 2.0);
  UncertaintyField reference(targets, importance, initial);
  RecorderConfig config = two_robots(0.0, true);
  config.sensing_radius_m = 2.0;
  GroundTruthRecorder rec(config, UncertaintyField(targets, importance, initial));
  Points start(2, 2), end(2, 2);
  start << 1, 1, 10, 3;
  end << 3, 2, 9, 5;  // integers: start + (end - start) is end exactly
  rec.record_positions(0.0, start);
  rec.record_positions(1.0, end);  // the 1 s row: the field advanced over [0, 1] s
  reference.advance_linear(1.0, start, end, Eigen::VectorXd::Ones(2),
                           Eigen::VectorXd::Constant(2, 2.0), config.max_substep_s);
  int covered = 0;
  for (int j = 0; j < 144; ++j) {
    const double want = reference.values()[j], got = rec.field_values()[j];
    std::uint64_t a, b;
    std::memcpy(&a, &want, sizeof a);
    std::memcpy(&b, &got, sizeof b);
    EXPECT_EQ(a, b) << "target " << j << ": " << want << " vs " << got;
    const double uncovered = UncertaintyField(targets, importance, initial)
                                 .model()
                                 .evolve(initial[j], importance[j], 1.0);
    covered += want < uncovered - 1e-9;  // (one step of 1 s, not 4: rounding apart)
  }
  EXPECT_GT(covered, 10);  // both kinds of target were stepped
  EXPECT_LT(covered, 100);
}

TEST(Recorder, TheFieldOfOneImportanceIsUncertaintyFieldsBitForBit) {
  expect_field_as_uncertainty_field(true);
}

TEST(Recorder, TheFieldOfManyImportancesIsUncertaintyFieldsBitForBit) {
  expect_field_as_uncertainty_field(false);
}

TEST(Recorder, DwellsCountTheTimeStandingOnTheGoalStoodOn) {
  GroundTruthRecorder rec(two_robots(0.0, false), line_field());
  rec.record_goal(0, 2, 2, 10.0);
  rec.record_dwell(0, 2, 11.0);
  rec.record_goal(1, 2, 1, 10.0);  // a drive ended without a visit: no standing time
  rec.record_dwell(1, 2, 20.0);
  rec.count_dwell(0.5);  // the event loop knows how long its robot stood
  EXPECT_EQ(rec.dwells(), 3);
  EXPECT_DOUBLE_EQ(rec.dwell_time_s(), 1.5);
}

}  // namespace
}  // namespace tpuaf
