// TPUAF+'s spacing rule (phase error, measured pace), its mates' placement and its transition
// entries, hand-checked on the 40 m square 0-1-2-3-0 (10 m edges, 1 m/s). The plans are the
// ones tpuaf_plus.make_plan gives for these starts (a cycle over the square, its start schedule).
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <memory>
#include <vector>

#include "tpuaf_core/strategy.hpp"
#include "tpuaf_core/tpuaf_plus.hpp"

namespace tpuaf {

// Reaches the strategy's private state and steps (a friend of TpuafPlusStrategy).
class TpuafPlusProbe {
 public:
  using Heard = TpuafPlusStrategy::Heard;
  static TpuafPlusStrategy::Robot& robot(TpuafPlusStrategy& s, int i) { return s.state(i); }
  static double spacing_wait(TpuafPlusStrategy& s, int i, double now) {
    return s.spacing_wait(s.state(i), i, now);
  }
  static double mate_arc(TpuafPlusStrategy& s, int i, int k, double now) {
    double arc = -1;
    EXPECT_TRUE(s.mate_arc(s.state(i), k, now, arc));
    return arc;
  }
  static void hear(TpuafPlusStrategy& s, int i, int k, Heard h) {
    auto& r = s.state(i);
    r.heard[static_cast<std::size_t>(k)] = h;
    r.has_heard[static_cast<std::size_t>(k)] = 1;
  }
  static double pace(TpuafPlusStrategy& s, int i, int k) {
    return s.state(i).pace[static_cast<std::size_t>(k)];
  }
  static std::map<int, int> transition_entries(TpuafPlusStrategy& s, int i) {
    return s.transition_entries(s.state(i), i);
  }
  static TpuafPlusStrategy::Recent& history(TpuafPlusStrategy& s, int i, int k) {
    return s.history(s.state(i), k);
  }
  static void record_visit(TpuafPlusStrategy& s, int i, int vertex, double time_s) {
    s.visits_.record(i, vertex, time_s);
  }
};

namespace {

PatrolGraph square() {
  Points p(4, 2);
  p << 0, 0, 10, 0, 10, 10, 0, 10;
  return PatrolGraph(p, {{0, 1, 10.0}, {1, 2, 10.0}, {2, 3, 10.0}, {3, 0, 10.0}});
}

PlusRoute square_walk(std::vector<int> robots) {
  return PlusRoute{{0, 1, 2, 3}, {0.0, 10.0, 20.0, 30.0}, 40.0, std::move(robots)};
}

// One cycle for the team, with this start schedule (entry walk index, departure [s]).
std::unique_ptr<TpuafPlusStrategy> strategy(std::vector<std::pair<int, double>> schedule) {
  const auto n = static_cast<int>(schedule.size());
  std::vector<int> team;
  for (int k = 0; k < n; ++k) team.push_back(k);
  auto plan = std::make_shared<PlusPlan>();
  plan->routes = {square_walk(team)};
  plan->route_of.assign(static_cast<std::size_t>(n), 0);
  plan->schedule = std::move(schedule);
  TpuafKnowledge knowledge(Eigen::VectorXd::Ones(4), Eigen::VectorXd::Ones(4), {}, 8.0 / 15.0, 10.0,
                           30.0);
  return std::make_unique<TpuafPlusStrategy>(
      knowledge, TpuafPlusParams{},
      [plan](const std::vector<int>&, const PatrolGraph*) {
        return std::shared_ptr<const PlusPlan>(plan);
      });
}

TEST(TpuafPlus, PaceIsARunningAverageClampedToThePlanSpeed) {
  EXPECT_DOUBLE_EQ(update_pace(1.0, 0.6, 0.25, 1.0), 0.9);          // 1 + 0.25 (0.6 - 1)
  EXPECT_DOUBLE_EQ(update_pace(0.9, 3.0, 0.25, 1.0), 0.925);        // a sample above v counts as v
  EXPECT_DOUBLE_EQ(update_pace(0.5, 0.0, 1.0, 2.0), 0.2);           // below 0.1 v counts as 0.1 v
  EXPECT_DOUBLE_EQ(update_pace(1.0, 1.0 - 1e-12, 0.25, 1.0), 1.0);  // rounding: v exactly
}

TEST(TpuafPlus, PhaseErrorIsAgainstTheTeamsMeanEvenSpacing) {
  // L = 40 m, m = 2: a mate 10 m ahead -> e = (L / 2 - 10) / 2 = 5 m early
  EXPECT_DOUBLE_EQ(phase_error({10.0}, 40.0), 5.0);
  EXPECT_DOUBLE_EQ(phase_error({30.0}, 40.0), -5.0);  // the mate 10 m behind: I am late
  EXPECT_DOUBLE_EQ(phase_error({20.0}, 40.0), 0.0);
  // m = 4, targets 0, 10, 20, 30 m: mates at 10, 20, 30 -> on phase; a convoy 1, 2 m ahead
  // and one at 22 m: e = -((1 - 10) + (2 - 20) + (22 - 30)) / 4 = 8.75 m early
  EXPECT_DOUBLE_EQ(phase_error({10.0, 20.0, 30.0}, 40.0), 0.0);
  EXPECT_DOUBLE_EQ(phase_error({1.0, 2.0, 22.0}, 40.0), 8.75);
  // the errors of a team sum to zero: the robots at 1, 2 and 22 m (seen from each)
  const double sum = phase_error({1.0, 2.0, 22.0}, 40.0) + phase_error({1.0, 21.0, 39.0}, 40.0) +
                     phase_error({20.0, 38.0, 39.0}, 40.0) + phase_error({18.0, 19.0, 20.0}, 40.0);
  EXPECT_NEAR(sum, 0.0, 1e-12);
}

TEST(TpuafPlus, SpacingDwellKeepsTheOrderAndNeverBlocksTheMateBehind) {
  // L = 40 m, u = 1 m/s, gain 0.35, deadband 0.5 s. A mate 20 m ahead: on phase, no dwell.
  EXPECT_EQ(spacing_dwell({{20.0, 0.0, 1.0}}, 40.0, 1.0, 0.35, 0.5), 0.0);
  // a mate 4 m ahead dwelling 12 s more at its vertex: its phase is 8 m behind me, I am early
  // by e = (20 + 8) / 2 = 14 m and dwell 2 gain e = 9.8 s (I do not run into it)
  EXPECT_NEAR(spacing_dwell({{4.0, 12.0, 1.0}}, 40.0, 1.0, 0.35, 0.5), 9.8, 1e-9);
  // m = 3: mates 2 m ahead and 6 m behind me (34 m ahead): early by
  // e = -((2 - 40 / 3) + (34 - 80 / 3)) / 3, I dwell 2 gain e (the mate behind needs 6 s)
  const double e = -((2.0 - 40.0 / 3) + (34.0 - 80.0 / 3)) / 3;
  EXPECT_NEAR(spacing_dwell({{34.0, 0.0, 1.0}, {2.0, 0.0, 1.0}}, 40.0, 1.0, 0.35, 0.5), 0.7 * e,
              1e-9);
  // m = 4: mates 1 m and 2 m ahead and 1 m behind: e = 4.5 m asks for 3.15 s, but the mate
  // behind reaches my vertex in 1 s: I leave 0.5 s before it (at 0.5 m/s, in 2 s: 1.5 s)
  EXPECT_NEAR(
      spacing_dwell({{1.0, 0.0, 1.0}, {2.0, 0.0, 1.0}, {39.0, 0.0, 1.0}}, 40.0, 1.0, 0.35, 0.5),
      0.5, 1e-9);
  EXPECT_NEAR(
      spacing_dwell({{1.0, 0.0, 1.0}, {2.0, 0.0, 1.0}, {39.0, 0.0, 0.5}}, 40.0, 1.0, 0.35, 0.5),
      1.5, 1e-9);
  // late: no dwell
  EXPECT_EQ(spacing_dwell({{30.0, 0.0, 1.0}}, 40.0, 1.0, 0.35, 0.5), 0.0);
}

TEST(TpuafPlus, SpacingRuleExact) {
  const PatrolGraph graph = square();
  auto s = strategy({{0, 0.0}, {2, 0.0}});  // starts (0, 2): already evenly spaced
  PolicyHost host(graph, 2, 0);
  host.set_state(0.0, 0, 1.0);
  s->start(host, 0);
  TpuafPlusProbe::robot(*s, 0).idx = 0;  // on my walk at vertex 0
  // the mate left the vertex 10 m ahead of me at t = 0: I am early by e = (20 - 10) / 2 = 5 m
  // and dwell 2 gain e / v (gain 0.35)
  s->on_message(host, 0, TeamMessage::intention(1, 1, 2, 10.0, 10.0, 0.0));
  EXPECT_NEAR(TpuafPlusProbe::spacing_wait(*s, 0, 0.0), 2 * 0.35 * 5.0, 1e-9);
  // seen 4 s later (the message keeps the sender's clock) it is 14 m ahead: e = 3 m
  EXPECT_NEAR(TpuafPlusProbe::spacing_wait(*s, 0, 4.0), 2 * 0.35 * 3.0, 1e-9);
  // a mate 10 m behind me: gap ahead 30 > behind 10, I never wait (the one ahead does)
  host.set_state(5.0, 0, 1.0);
  s->on_message(host, 0, TeamMessage::visit(1, 3, 5.0, 0));
  s->on_message(host, 0, TeamMessage::intention(1, 3, 0, 15.0, 10.0, 5.0));
  EXPECT_EQ(TpuafPlusProbe::spacing_wait(*s, 0, 5.0), 0.0);
}

// Two robots on the square whose plan source re-times the walk on a timing graph (as
// tpuaf_plus.retimed_routes does): arcs and L from its edge lengths.
std::unique_ptr<TpuafPlusStrategy> retiming_strategy(bool retime) {
  TpuafKnowledge knowledge(Eigen::VectorXd::Ones(4), Eigen::VectorXd::Ones(4), {}, 8.0 / 15.0, 10.0,
                           30.0);
  TpuafPlusParams params;
  params.retime = retime;
  return std::make_unique<TpuafPlusStrategy>(
      knowledge, params, [](const std::vector<int>&, const PatrolGraph* timing) {
        auto plan = std::make_shared<PlusPlan>();
        PlusRoute route = square_walk({0, 1});
        if (timing != nullptr) {
          double s = 0;
          for (std::size_t i = 0; i < route.walk.size(); ++i) {
            route.arc[i] = s;
            s += timing->edge_length(route.walk[i], route.walk[(i + 1) % route.walk.size()]);
          }
          route.length = s;
        }
        plan->routes = {route};
        plan->route_of = {0, 0};
        plan->schedule = {{0, 0.0}, {2, 0.0}};
        return std::shared_ptr<const PlusPlan>(plan);
      });
}

TEST(TpuafPlus, RetimedSpacingFollowsTheLearnedDurations) {
  // Edge 0-1 learned twice as slow: 20 m of plan travel. The mate left vertex 1 at t = 0: on the
  // model it is 10 m ahead of L / 2 = 20 m (e = 5 m, dwell 2 gain e = 3.5 s); re-timed it is
  // 20 m ahead of L' / 2 = 25 m (e = 2.5 m, dwell 1.75 s). Without re-timing: 3.5 s still.
  const PatrolGraph graph = square();
  Points p(4, 2);
  p << 0, 0, 10, 0, 10, 10, 0, 10;
  const PatrolGraph slow(p, {{0, 1, 20.0}, {1, 2, 10.0}, {2, 3, 10.0}, {3, 0, 10.0}});
  EXPECT_NEAR(retime_gap_change(square_walk({0, 1}),
                                PlusRoute{{0, 1, 2, 3}, {0.0, 20.0, 30.0, 40.0}, 50.0, {0, 1}}),
              0.2, 1e-12);  // robots 20 m apart from vertex 0: 30 m, 20 m against 25 m
  for (const bool retime : {true, false}) {
    auto s = retiming_strategy(retime);
    PolicyHost host(graph, 2, 0);
    host.set_state(0.0, 0, 1.0);
    s->start(host, 0);
    TpuafPlusProbe::robot(*s, 0).idx = 0;
    s->on_message(host, 0, TeamMessage::intention(1, 1, 2, 10.0, 10.0, 0.0));
    EXPECT_NEAR(TpuafPlusProbe::spacing_wait(*s, 0, 0.0), 3.5, 1e-9);
    host.set_graph(slow);
    s->retime(host, 0);
    EXPECT_EQ(s->walk(0), (std::vector<int>{0, 1, 2, 3}));  // the tour stays
    EXPECT_DOUBLE_EQ(s->route(0).length, retime ? 50.0 : 40.0);
    EXPECT_NEAR(TpuafPlusProbe::spacing_wait(*s, 0, 0.0), retime ? 1.75 : 3.5, 1e-9);
  }
}

TEST(TpuafPlus, MatesAreExtrapolatedAtTheirMeasuredPace) {
  // The mate drove 1 -> 2 (10 m) in 20 s: pace sample 0.5 m/s, its average 1 + 0.25 (0.5 - 1)
  // = 0.875 m/s. Placed from its next departure at that pace, not at v.
  const PatrolGraph graph = square();
  auto s = strategy({{0, 0.0}, {2, 0.0}});
  PolicyHost host(graph, 2, 0);
  host.set_state(0.0, 0, 1.0);
  s->start(host, 0);
  s->on_message(host, 0, TeamMessage::intention(1, 1, 2, 10.0, 10.0, 0.0));  // leaves 1 at 0 s
  s->on_message(host, 0, TeamMessage::visit(1, 2, 20.0, 3));                 // at 2 at 20 s
  EXPECT_DOUBLE_EQ(TpuafPlusProbe::pace(*s, 0, 1), 0.875);
  s->on_message(host, 0, TeamMessage::intention(1, 2, 3, 30.0, 10.0, 20.0));  // leaves 2 now
  EXPECT_NEAR(TpuafPlusProbe::mate_arc(*s, 0, 1, 24.0), 20.0 + 0.875 * 4.0, 1e-9);
  // a dwell is not driving: from its visit at 3 (32 s) after leaving 2 at 28 s, 10 m / 4 s
  // counts as v; the running average rises toward v
  s->on_message(host, 0, TeamMessage::intention(1, 2, 3, 38.0, 10.0, 28.0));
  s->on_message(host, 0, TeamMessage::visit(1, 3, 32.0, 0));
  EXPECT_DOUBLE_EQ(TpuafPlusProbe::pace(*s, 0, 1), 0.875 + 0.25 * (1.0 - 0.875));
  // my own pace is measured from my own drives: I leave vertex 0 at 0 s, reach 1 at 12.5 s
  EXPECT_DOUBLE_EQ(TpuafPlusProbe::pace(*s, 0, 0), 1.0);
  auto mine = strategy({{0, 0.0}, {2, 0.0}});
  host.set_state(0.0, 0, 1.0);
  mine->start(host, 0);
  EXPECT_EQ(mine->decide(host, 0), 1);
  host.set_state(12.5, 1, 1.0);
  mine->decide(host, 0);
  EXPECT_DOUBLE_EQ(TpuafPlusProbe::pace(*mine, 0, 0), 1.0 + 0.25 * (0.8 - 1.0));
}

TEST(TpuafPlus, AnEarlyRobotDwellsALateOneDoesNot) {
  // m = 3 on the 40 m square: mates 2 m and 4 m ahead (a convoy). The one at the back is early
  // (e = -((2 - 40 / 3) + (4 - 80 / 3)) / 3 = 11.33 m) and dwells, capped at L / (m u); the
  // convoy's leader, seen with its mates 36 and 38 m ahead, is late and never dwells.
  const PatrolGraph graph = square();
  auto s = strategy({{0, 0.0}, {0, 0.0}, {0, 0.0}});
  PolicyHost host(graph, 3, 2);
  host.set_state(0.0, 0, 1.0);
  s->start(host, 2);
  TpuafPlusProbe::robot(*s, 2).idx = 0;              // robot 2 at vertex 0 (arc 0)
  TpuafPlusProbe::hear(*s, 2, 0, {0, 1, 6.0, 6.0});  // 4 m ahead at 10 s
  TpuafPlusProbe::hear(*s, 2, 1, {0, 1, 8.0, 8.0});  // 2 m ahead at 10 s
  const double e = -((2.0 - 40.0 / 3) + (4.0 - 80.0 / 3)) / 3;
  EXPECT_NEAR(phase_error({2.0, 4.0}, 40.0), e, 1e-12);
  EXPECT_NEAR(TpuafPlusProbe::spacing_wait(*s, 2, 10.0), std::min(2 * 0.35 * e, 40.0 / 3), 1e-9);
  // robot 0, the convoy's leader, at vertex 1 (arc 10) at 14 s; its mates left vertex 0 at
  // 6 s and 8 s: at 8 m and 6 m, i.e. 38 m and 36 m ahead of it. It is late: no dwell.
  PolicyHost lead(graph, 3, 0);
  lead.set_state(14.0, 1, 1.0);
  s->start(lead, 0);
  TpuafPlusProbe::robot(*s, 0).idx = 1;
  TpuafPlusProbe::hear(*s, 0, 1, {0, 1, 6.0, 6.0});
  TpuafPlusProbe::hear(*s, 0, 2, {0, 1, 8.0, 8.0});
  EXPECT_LT(phase_error({36.0, 38.0}, 40.0), 0.0);
  EXPECT_EQ(TpuafPlusProbe::spacing_wait(*s, 0, 14.0), 0.0);
}

TEST(TpuafPlus, AMateNotHeardSinceItLeftItsStartSlotIsOnItsSlot) {
  // Starts (0, 0): robot 1 drives to walk index 3 (vertex 3) and leaves with its slot at 10 s.
  // When the message telling that it left is delayed or lost, it is placed on its slot (at its
  // entry at its departure, moving at v), not nowhere; a message from after it left places it.
  const PatrolGraph graph = square();
  auto s = strategy({{0, 0.0}, {3, 10.0}});
  PolicyHost host(graph, 2, 0);
  host.set_state(0.0, 0, 1.0);
  s->start(host, 0);
  const double later = 13.0, slot = 33.0;                              // arc 30 + 1 m/s x 3 s
  EXPECT_NEAR(TpuafPlusProbe::mate_arc(*s, 0, 1, later), slot, 1e-9);  // never heard
  // heard only from its drive to its entry: an edge against the walk's direction
  TpuafPlusProbe::hear(*s, 0, 1, {0, 3, 0.0, 0.0});
  EXPECT_NEAR(TpuafPlusProbe::mate_arc(*s, 0, 1, later), slot, 1e-9);
  // from the walk edge 2 -> 3 into its entry: due there in time, on its slot; due after its
  // departure (late), placed from that message
  TpuafPlusProbe::hear(*s, 0, 1, {2, 3, -1.0, -1.0});
  EXPECT_NEAR(TpuafPlusProbe::mate_arc(*s, 0, 1, later), slot, 1e-9);
  TpuafPlusProbe::hear(*s, 0, 1, {2, 3, 2.0, 2.0});
  EXPECT_NEAR(TpuafPlusProbe::mate_arc(*s, 0, 1, later), 20.0 + (later - 2.0), 1e-9);
  // heard after it left, from the next walk vertex: placed from that message
  TpuafPlusProbe::hear(*s, 0, 1, {0, 1, later - 1.0, later - 1.0});
  EXPECT_NEAR(TpuafPlusProbe::mate_arc(*s, 0, 1, later), 1.0, 1e-9);
}

TEST(TpuafPlus, TransitionToANewSharedWalkSpreadsTheEntries) {
  // Two robots heading for vertex 0 when the team changed (one there, one 1 s behind) and
  // vertex 2 long unvisited: one of them enters on the far side (2 or 3), not both at 0.
  const PatrolGraph graph = square();
  auto s = strategy({{0, 0.0}, {0, 40.0 / 3.0}, {3, 50.0 / 3.0}});  // starts (0, 0, 0)
  PolicyHost host(graph, 3, 0);
  host.set_state(0.0, 0, 1.0);
  s->start(host, 0);
  auto& r = TpuafPlusProbe::robot(*s, 0);
  auto plan = std::make_shared<PlusPlan>(*r.plan);
  plan->routes[0].robots = {0, 1};
  r.plan = plan;
  r.changed_at = 100.0;
  TpuafPlusProbe::record_visit(*s, 0, 0, 99.0);
  TpuafPlusProbe::record_visit(*s, 0, 1, 95.0);
  TpuafPlusProbe::record_visit(*s, 0, 3, 95.0);  // vertex 2: never visited (idle 100 s)
  // robot 1's later message (after the change) is not used: where it stood at the change
  TpuafPlusProbe::history(*s, 0, 0) = {{1, 0, 90.0, 90.0}};
  TpuafPlusProbe::history(*s, 0, 1) = {{1, 0, 91.0, 91.0}, {0, 3, 120.0, 120.0}};
  const std::map<int, int> entries = TpuafPlusProbe::transition_entries(*s, 0);
  ASSERT_EQ(entries.size(), 2u);
  ASSERT_TRUE(entries.count(0) && entries.count(1));
  std::vector<int> vertices{entries.at(0), entries.at(1)};  // walk index = vertex here
  std::sort(vertices.begin(), vertices.end());
  EXPECT_EQ(vertices[0], 0);
  EXPECT_TRUE(vertices[1] == 2 || vertices[1] == 3) << vertices[1];
  EXPECT_DOUBLE_EQ(graph.distance(0, 2), 20.0);
  // a robot never heard before the change: no entries (nearest vertex instead)
  TpuafPlusProbe::history(*s, 0, 1) = {{0, 3, 120.0, 120.0}};
  EXPECT_TRUE(TpuafPlusProbe::transition_entries(*s, 0).empty());
}

}  // namespace
}  // namespace tpuaf
