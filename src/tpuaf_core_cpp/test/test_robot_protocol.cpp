// One robot's protocol (robot_protocol.hpp) against a scripted driver: what it asks of the
// driver and the policy at each event, in order, and its teammate liveness.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "tpuaf_core/robot_protocol.hpp"

namespace tpuaf {
namespace {

// Records every call as a line; the policy's goals come from `goals` (-1: wait).
class ScriptDriver : public RobotDriver {
 public:
  double t = 0, x = 0, y = 0;
  bool on_vertex = true;
  std::vector<int> goals;
  std::size_t next = 0;
  std::vector<std::string> calls;
  RobotProtocol* protocol = nullptr;
  double wake_in_decide = -1;  // >= 0: the policy asks for a wake-up at t + this inside decide
  int redirect_in_decide = -1;

  double now() const override { return t; }
  void position(int, double& px, double& py) const override {
    px = x;
    py = y;
  }
  bool at_vertex(int, int) const override { return on_vertex; }
  void schedule_wake(int, double time_s) override { log("wake", time_s); }
  void drive(int, int from, int goal) override {
    log("drive " + std::to_string(from) + "->" + std::to_string(goal));
  }
  void dwell(int, int vertex, double s) override { log("dwell " + std::to_string(vertex), s); }
  void halt(int) override { log("halt"); }
  void policy_start(int) override { log("policy start"); }
  int policy_decide(int) override {
    log("policy decide");
    if (wake_in_decide >= 0) protocol->wake_at(t + wake_in_decide);
    if (redirect_in_decide >= 0) protocol->change_goal(redirect_in_decide);
    return next < goals.size() ? goals[next++] : -1;
  }
  void policy_goal_failed(int, int vertex) override {
    log("policy failed " + std::to_string(vertex));
  }
  void policy_teammate_lost(int, int mate) override { log("policy lost " + std::to_string(mate)); }
  void emit(int, int kind, int vertex, int from, double) override {
    static const char* names[] = {"START", "GOAL", "REACHED", "FAILED", "?", "DWELL"};
    log(std::string(names[kind]) + " " + std::to_string(vertex) + " from " + std::to_string(from));
  }

 private:
  void log(const std::string& s, double v = std::numeric_limits<double>::quiet_NaN()) {
    calls.push_back(std::isnan(v) ? s : s + " @" + std::to_string(v).substr(0, 4));
  }
};

// Vertices 0 (0, 0), 1 (10, 0), 2 (20, 0).
Points line() {
  Points p(3, 2);
  p << 0, 0, 10, 0, 20, 0;
  return p;
}

ProtocolConfig config() {
  ProtocolConfig c;
  c.robot = 0;
  c.robots = 3;
  c.stay_s = 1.0;
  c.retry_s = 2.0;
  c.teammate_timeout_s = 5.0;
  c.visit_radius_m = 0.5;
  return c;
}

using Calls = std::vector<std::string>;

TEST(RobotProtocol, DrivesPassesThroughAndVisitsThenDecidesAgain) {
  ScriptDriver d;
  d.goals = {2, 0};
  RobotProtocol p(d, line(), config());
  d.protocol = &p;
  p.place(0);
  p.start();
  p.decide();
  EXPECT_EQ(d.calls, (Calls{"START 0 from -1", "policy start", "policy decide", "GOAL 2 from 0",
                            "drive 0->2"}));
  d.calls.clear();
  d.t = 10;
  d.x = 10;
  p.observe(10, 0);
  EXPECT_TRUE(p.on_vertex(1, false));  // pass-through: go on, no event
  EXPECT_TRUE(d.calls.empty());
  d.t = 20;
  d.x = 20;
  p.observe(20, 0);
  EXPECT_FALSE(p.on_vertex(2, true));
  EXPECT_EQ(d.calls, (Calls{"REACHED 2 from 2", "policy decide", "GOAL 0 from 2", "drive 2->0"}));
  EXPECT_EQ(p.visits(), 1);
  EXPECT_EQ(p.current_vertex(), 2);
  EXPECT_EQ(p.leg_from(), 2);
  EXPECT_EQ(p.leg_start_s(), 20);
}

TEST(RobotProtocol, GoalOnItsOwnVertexIsADwellNotAVisit) {
  ScriptDriver d;
  d.goals = {0};
  RobotProtocol p(d, line(), config());
  d.protocol = &p;
  p.place(0);
  p.start();
  p.decide();
  EXPECT_TRUE(p.dwelling());
  EXPECT_EQ(d.calls.back(), "dwell 0 @1.00");
  d.calls.clear();
  d.t = 1.0;
  EXPECT_FALSE(p.on_vertex(0, true));
  // No goal left: the robot halts and asks to decide again after retry_s.
  EXPECT_EQ(d.calls, (Calls{"DWELL 0 from 0", "policy decide", "halt", "wake @3.00"}));
  EXPECT_EQ(p.dwells(), 1);
  EXPECT_EQ(p.last_dwell_s(), 1.0);
  EXPECT_EQ(p.dwell_time_s(), 1.0);
  EXPECT_EQ(p.goal(), -1);
  EXPECT_TRUE(p.wake_pending());
}

TEST(RobotProtocol, AWakeUpAskedInsideDecideReplacesTheRetry) {
  ScriptDriver d;
  d.wake_in_decide = 7.0;
  RobotProtocol p(d, line(), config());
  d.protocol = &p;
  p.place(1);
  p.start();
  d.calls.clear();
  p.decide();
  EXPECT_EQ(d.calls, (Calls{"policy decide", "wake @7.00", "halt"}));
  d.calls.clear();
  d.goals = {2};
  d.wake_in_decide = -1;
  p.on_wake();
  EXPECT_EQ(d.calls, (Calls{"policy decide", "GOAL 2 from 1", "drive 1->2"}));
  d.calls.clear();
  p.on_wake();  // it has a goal: ignored
  EXPECT_TRUE(d.calls.empty());
}

TEST(RobotProtocol, ARedirectTakesEffectAtTheNextVertex) {
  ScriptDriver d;
  d.goals = {2};
  d.redirect_in_decide = 0;  // asked inside decide: dropped, the decision stands
  RobotProtocol p(d, line(), config());
  d.protocol = &p;
  p.place(0);
  p.start();
  p.decide();
  EXPECT_EQ(p.redirect(), -1);
  p.change_goal(0);
  d.calls.clear();
  d.t = 10;
  EXPECT_FALSE(p.on_vertex(1, false));
  EXPECT_EQ(d.calls, (Calls{"GOAL 0 from 1", "drive 1->0"}));
  EXPECT_EQ(p.goal(), 0);
  EXPECT_THROW(p.change_goal(3), std::out_of_range);
}

TEST(RobotProtocol, AFailedGoalMovesTheRobotToTheNearestVertexAndDecides) {
  ScriptDriver d;
  d.goals = {2, 1};
  RobotProtocol p(d, line(), config());
  d.protocol = &p;
  p.place(0);
  p.start();
  p.decide();
  p.stall();
  d.calls.clear();
  d.on_vertex = false;
  p.on_goal_failed(2, 1);
  EXPECT_EQ(d.calls, (Calls{"FAILED 2 from 0", "policy failed 2", "policy decide", "GOAL 1 from 1",
                            "drive 1->1"}));  // not on it: a drive
  EXPECT_EQ(p.failures(), 1);
  EXPECT_EQ(p.current_vertex(), 1);
  EXPECT_TRUE(p.stalled());
}

TEST(RobotProtocol, ADeadRobotStopsAndIgnoresEverything) {
  ScriptDriver d;
  d.goals = {2, 1};
  RobotProtocol p(d, line(), config());
  d.protocol = &p;
  p.place(0);
  p.start();
  p.decide();
  d.calls.clear();
  p.die();
  EXPECT_EQ(d.calls, (Calls{"halt"}));
  EXPECT_FALSE(p.alive());
  EXPECT_EQ(p.goal(), -1);
  d.calls.clear();
  p.decide();
  p.on_wake();
  EXPECT_FALSE(p.on_vertex(2, true));
  p.on_goal_failed(2, 2);
  EXPECT_FALSE(p.hear(1, 3.0));
  EXPECT_TRUE(p.check_liveness(100).empty());
  EXPECT_TRUE(d.calls.empty());
}

TEST(RobotProtocol, TeammatesSilentForTheTimeoutAreLostOnceAndComeBack) {
  ScriptDriver d;
  RobotProtocol p(d, line(), config());
  p.place(0);
  p.start();
  d.calls.clear();
  EXPECT_FALSE(p.hear(1, 1.0));
  EXPECT_FALSE(p.hear(2, 2.0));
  EXPECT_FALSE(p.hear(0, 2.0));  // itself: ignored
  EXPECT_FALSE(p.hear(7, 2.0));  // not a teammate: ignored
  EXPECT_TRUE(p.check_liveness(5.9).empty());
  EXPECT_EQ(p.check_liveness(6.0), std::vector<int>{1});
  EXPECT_EQ(p.check_liveness(7.0), std::vector<int>{2});
  EXPECT_TRUE(p.check_liveness(9.0).empty());  // each reported once
  EXPECT_EQ(d.calls, (Calls{"policy lost 1", "policy lost 2"}));
  EXPECT_FALSE(p.hear(1, 1.0));  // nothing newer: still lost
  EXPECT_TRUE(p.liveness().lost(1));
  EXPECT_TRUE(p.hear(1, 8.0));
  EXPECT_FALSE(p.liveness().lost(1));
  EXPECT_EQ(p.liveness().last_heard(1), 8.0);
  EXPECT_THROW(TeammateLiveness(3, 0, 0.0), std::invalid_argument);
}

}  // namespace
}  // namespace tpuaf
