// The team around the protocols in runs with faults (team_liveness.hpp): a death's steps in
// their one order, stale checks, losses from heartbeats, and delivery feeding liveness.
#include <gtest/gtest.h>

#include <algorithm>
#include <queue>
#include <string>
#include <tuple>
#include <vector>

#include "tpuaf_core/team_liveness.hpp"

namespace tpuaf {
namespace {

// Robots that stand still and wait; the calls that matter here are the team's hooks.
class StillDriver : public RobotDriver {
 public:
  double now() const override { return 0.0; }
  void position(int, double& x, double& y) const override { x = y = 0.0; }
  bool at_vertex(int, int) const override { return true; }
  void schedule_wake(int, double) override {}
  void drive(int, int, int) override {}
  void dwell(int, int, double) override {}
  void halt(int) override {}
  void policy_start(int) override {}
  int policy_decide(int) override { return -1; }
  void policy_goal_failed(int, int) override {}
  void policy_teammate_lost(int, int) override {}
  void emit(int, int, int, int, double) override {}
};

Points three_vertices() {
  Points p(3, 2);
  p << 0, 0, 10, 0, 20, 0;
  return p;
}

RecorderConfig three_robots() {
  RecorderConfig c;
  c.robots = 3;
  c.ground_truth = false;
  return c;
}

// A team of three robots without loss or delay, 5 s timeout, heartbeats every 1 s; the
// runtime's hooks log what they are asked, and checks go to a queue (time, robot, token).
struct Team {
  using Check = std::tuple<double, int, std::uint64_t>;
  StillDriver driver;
  Points positions = three_vertices();
  std::vector<RobotProtocol> protocols;
  TeamBus bus{3, 0.0, 0.0, NumpyPcg64(0, 0, 0, 1)};
  GroundTruthRecorder recorder{
      three_robots(), UncertaintyField(three_vertices(), Eigen::VectorXd::Constant(3, 0.01),
                                       Eigen::VectorXd::Ones(3))};
  std::vector<std::string> log;
  std::priority_queue<Check, std::vector<Check>, std::greater<Check>> checks;
  std::uint64_t tokens = 0;
  std::unique_ptr<TeamLiveness> team;

  Team() {
    protocols.reserve(3);
    std::vector<RobotProtocol*> pointers;
    for (int i = 0; i < 3; ++i) {
      ProtocolConfig c;
      c.robot = i;
      c.robots = 3;
      c.teammate_timeout_s = 5.0;
      protocols.emplace_back(driver, positions, c);
      protocols.back().place(i);
      pointers.push_back(&protocols.back());
    }
    TeamHooks hooks;
    hooks.schedule_check = [this](int robot, double t) {
      log.push_back("check " + std::to_string(robot));
      checks.emplace(t, robot, ++tokens);
      return tokens;
    };
    hooks.stop_motion = [this](int robot) {
      // The first step: the robot is still alive for its protocol and the bus.
      log.push_back("stop " + std::to_string(robot) + (protocols[robot].alive() ? " alive" : "") +
                    (bus.alive(robot) ? " on bus" : ""));
    };
    hooks.after_stall = [this](int robot) { log.push_back("stalled " + std::to_string(robot)); };
    team = std::make_unique<TeamLiveness>(pointers, bus, recorder,
                                          HeartbeatLinks(3, 100.0, 5.0, 0.0, 0.0, 1.0, {}),
                                          std::move(hooks));
  }
  // Run the checks due by `until` [s], in time order.
  void run_checks(double until) {
    while (!checks.empty() && std::get<0>(checks.top()) <= until) {
      const auto [t, robot, token] = checks.top();
      checks.pop();
      team->check_due(robot, token, t);
    }
  }
};

TEST(TeamLiveness, ADeathTakesItsStepsInOneOrder) {
  Team t;
  t.team->start(0.0);
  t.log.clear();
  t.team->inject(1, /*death=*/true, 3.0);
  // Motion stopped first (still alive), then every survivor's check planned again.
  EXPECT_EQ(t.log, (std::vector<std::string>{"stop 1 alive on bus", "check 0", "check 2"}));
  EXPECT_FALSE(t.protocols[1].alive());
  EXPECT_FALSE(t.bus.alive(1));
  ASSERT_EQ(t.recorder.deaths().size(), 1u);
  EXPECT_EQ(t.recorder.deaths()[0].time_s, 3.0);
  t.team->check_due(1, t.team->pending_check(1), 50.0);  // the dead check nothing
  EXPECT_TRUE(t.team->losses().empty());
  t.log.clear();
  t.team->inject(1, true, 4.0);  // dead: nothing more
  t.team->inject(1, false, 4.0);
  EXPECT_TRUE(t.log.empty());
  EXPECT_EQ(t.recorder.deaths().size(), 1u);
}

TEST(TeamLiveness, AStallKeepsTheRobotInTheTeam) {
  Team t;
  t.team->start(0.0);
  t.log.clear();
  t.team->inject(2, /*death=*/false, 2.0);
  EXPECT_EQ(t.log, (std::vector<std::string>{"stalled 2"}));
  EXPECT_TRUE(t.protocols[2].alive() && t.protocols[2].stalled() && t.bus.alive(2));
  t.run_checks(100.0);
  EXPECT_TRUE(t.team->losses().empty());  // its heartbeats go on
}

TEST(TeamLiveness, SurvivorsLoseTheDeadOnceItsSilenceReachesTheTimeout) {
  Team t;
  t.team->start(0.0);
  t.run_checks(3.0);
  t.team->inject(1, true, 3.0);  // its last heartbeat: 3 s (sent at its death's instant)
  t.run_checks(100.0);
  ASSERT_EQ(t.team->losses().size(), 2u);
  for (const auto& loss : t.team->losses()) {
    EXPECT_EQ(loss.lost, 1);
    EXPECT_DOUBLE_EQ(loss.time_s, 8.0);
  }
  EXPECT_EQ(t.team->losses()[0].observer, 0);
  EXPECT_EQ(t.team->losses()[1].observer, 2);
  EXPECT_EQ(t.team->lost_by(1), 2);
}

TEST(TeamLiveness, AStaleCheckDoesNothing) {
  Team t;
  t.team->start(0.0);
  t.team->inject(1, true, 3.0);  // moves the survivors' checks: the first tokens are stale
  t.team->check_due(0, 1, 9.0);  // robot 0's first token
  EXPECT_TRUE(t.team->losses().empty());
  t.team->check_due(0, t.team->pending_check(0), 9.0);
  EXPECT_EQ(t.team->losses().size(), 1u);
}

TEST(TeamLiveness, DeliveryFeedsTheLiveRecipientsAndSkipsTheDead) {
  Team t;
  t.team->start(0.0);
  t.team->inject(2, true, 1.0);
  ASSERT_TRUE(t.bus.send(0, 7, 1.5));
  std::vector<int> got;
  std::vector<std::int64_t> done;
  t.team->deliver_ready(
      1.5, [](const BusDelivery& d) { return d.sender; },
      [&](int r, const BusDelivery& d) {
        got.push_back(r);
        EXPECT_EQ(d.message, 7);
      },
      [&](const BusDelivery& d) { done.push_back(d.message); });
  EXPECT_EQ(got, std::vector<int>{1});
  EXPECT_EQ(done, std::vector<std::int64_t>{7});
  EXPECT_EQ(t.bus.stats().delivered, 1);
  EXPECT_EQ(t.protocols[1].liveness().last_heard(0), 1.5);  // heard before it got the message
  EXPECT_TRUE(t.bus.ready().empty());
}

}  // namespace
}  // namespace tpuaf
