// TpuafKnowledge: the shared set Q (visits, intentions) and stale-entry dropping.
#include <gtest/gtest.h>

#include <cmath>

#include "tpuaf_core/knowledge.hpp"
#include "tpuaf_core/team_visits.hpp"

namespace tpuaf {
namespace {

TpuafKnowledge three_vertices(double intention_timeout_s = 10.0) {
  return TpuafKnowledge(Eigen::VectorXd::Constant(3, 0.01), Eigen::VectorXd::Constant(3, 0.0), {},
                        0.5, 4.0, intention_timeout_s);
}

TEST(Knowledge, NewestVisitWinsAndOlderOnesAreIgnored) {
  TpuafKnowledge k = three_vertices();
  k.record_visit(1, 20.0);
  k.record_visit(1, 10.0);
  EXPECT_DOUBLE_EQ(k.last_visit()(1), 20.0);
}

TEST(Knowledge, EstimateGrowsSinceTheLastVisit) {
  TpuafKnowledge k = three_vertices();
  k.record_visit(0, 0.0);
  const Eigen::VectorXd early = k.estimate(10.0);
  const Eigen::VectorXd late = k.estimate(100.0);
  EXPECT_GT(late(0), early(0));
  EXPECT_GE(early(0), 0.0);
}

TEST(Knowledge, IntentionIsAnnouncedThenClearedByTheVisit) {
  TpuafKnowledge k = three_vertices();
  Intention in;
  in.robot = 1;
  in.from_vertex = 0;
  in.vertex = 2;
  in.expected_arrival_s = 15.0;
  in.travel_time_s = 5.0;
  in.sent_s = 10.0;
  k.hear_intention(in);
  Eigen::VectorXd arrival, travel;
  k.announced(arrival, travel);
  EXPECT_DOUBLE_EQ(arrival(2), 15.0);
  EXPECT_DOUBLE_EQ(travel(2), 5.0);
  EXPECT_TRUE(std::isinf(arrival(1)));
  k.hear_visit(1, 2, 15.0);
  k.announced(arrival, travel);
  EXPECT_TRUE(std::isinf(arrival(2)));
  EXPECT_DOUBLE_EQ(k.last_visit()(2), 15.0);
}

TEST(Knowledge, StaleIntentionsAreDropped) {
  TpuafKnowledge k = three_vertices(10.0);
  Intention in;
  in.robot = 0;
  in.vertex = 1;
  in.expected_arrival_s = 5.0;
  in.sent_s = 0.0;
  k.hear_intention(in);
  k.drop_stale(14.0);
  EXPECT_EQ(k.intentions().size(), 1u);
  k.drop_stale(16.0);  // arrival passed by more than the 10 s timeout
  EXPECT_TRUE(k.intentions().empty());
}

TEST(Knowledge, SilenceAloneKeepsAnIntentionUntilTheRobotIsReportedLost) {
  // One liveness rule: the runtime reports a lost teammate; the knowledge has no timer of its own.
  TpuafKnowledge k = three_vertices(1000.0);
  Intention in;
  in.robot = 1;
  in.vertex = 2;
  in.expected_arrival_s = 5.0;
  k.hear_intention(in);
  k.drop_stale(900.0);
  EXPECT_EQ(k.intentions().size(), 1u);
  k.forget_intention(1);
  EXPECT_TRUE(k.intentions().empty());
}

TEST(Knowledge, UnknownVertexIsRefused) {
  TpuafKnowledge k = three_vertices();
  EXPECT_THROW(k.record_visit(7, 1.0), std::exception);
}

TEST(Knowledge, TeamKnowledgeLeavesOutTheDecidersOwnIntentionAndRefusesAnUnclosedOne) {
  TpuafKnowledge team = three_vertices();
  Intention in;
  in.robot = 1;
  in.from_vertex = 0;
  in.vertex = 2;
  in.expected_arrival_s = 15.0;
  in.travel_time_s = 5.0;
  in.sent_s = 10.0;
  ASSERT_TRUE(team.hear_team_intention(in));
  EXPECT_EQ(team.intentions().size(), 1u);
  EXPECT_TRUE(team.as_robot(1).intentions().empty());  // robot 1 never counts its own
  EXPECT_EQ(team.as_robot(0).intentions().size(), 1u);
  in.vertex = 1;
  EXPECT_FALSE(team.hear_team_intention(in));  // robot 1's intention for 2 still open
  EXPECT_FALSE(team.hear_team_visit(1, 1));    // a visit of another vertex
  EXPECT_TRUE(team.hear_team_visit(1, 2));     // closes it
  EXPECT_TRUE(team.intentions().empty());
  EXPECT_TRUE(team.hear_team_intention(in));
}

}  // namespace
}  // namespace tpuaf

namespace tpuaf {
namespace {

TEST(TeamVisits, EveryRobotKnowsWhatItsOwnKnowledgeWould) {
  // Four robots, each hearing its own interleaving of visits (old ones, repeats, the same
  // visit as a mate): the team store holds what a TpuafKnowledge per robot holds.
  TpuafKnowledge initial(Eigen::VectorXd::LinSpaced(5, 0.01, 0.05),
                         Eigen::VectorXd::LinSpaced(5, 0.0, 2.0), {}, 0.5, 4.0, 10.0);
  initial.share_visit_results();
  TeamVisits team(initial, 4);
  std::vector<TpuafKnowledge> own(4, initial);
  unsigned state = 12345;
  auto next = [&](unsigned mod) {
    state = state * 1103515245u + 12345u;
    return (state >> 16) % mod;
  };
  for (int step = 0; step < 400; ++step) {
    const int robot = static_cast<int>(next(4)), vertex = static_cast<int>(next(5));
    const double time_s = 0.5 * (step / 3) - static_cast<double>(next(3));  // some older
    team.record(robot, vertex, time_s);
    own[static_cast<std::size_t>(robot)].record_visit(vertex, time_s);
  }
  for (int r = 0; r < 4; ++r) {
    for (int v = 0; v < 5; ++v) {
      const TpuafKnowledge& k = own[static_cast<std::size_t>(r)];
      EXPECT_EQ(team.last_visit(r, v), k.last_visit()[v]);
      TpuafKnowledge lent = initial;
      team.lend(r, {v}, lent);
      EXPECT_EQ(lent.anchor_value(v), k.anchor_value(v)) << "robot " << r << " vertex " << v;
      EXPECT_EQ(lent.anchor_time(v), k.anchor_time(v));
    }
  }
  team.reset(2);
  EXPECT_EQ(team.last_visit(2, 3), 0.0);
  EXPECT_THROW(team.record(4, 0, 1.0), std::out_of_range);
  EXPECT_THROW(team.record(0, 5, 1.0), std::out_of_range);
}

}  // namespace
}  // namespace tpuaf
