// A team strategy and what it sees of a run (StrategyHost): the one decision path of each
// strategy, used by the graph runtime's event loop (GraphEngine) and, through PolicyHost, by
// one robot on a live clock (physics runtime, ROS agents). Times in seconds, vertices are graph
// indices.
#pragma once

#include <memory>
#include <utility>
#include <vector>

#include "tpuaf_core/graph.hpp"

namespace tpuaf {

// A team message (tpuaf.team.messages). `opaque` carries a message of a Python strategy unchanged.
struct TeamMessage {
  enum class Kind { kVisit, kIntention, kOpaque };
  // A Visit: `robot` at `vertex` at time_s [s], heading to next_vertex (-1: undecided).
  static TeamMessage visit(int robot, int vertex, double time_s, int next_vertex);
  // An Intention: `robot` leaves from_vertex for `vertex`, due at expected_arrival_s [s] after
  // travel_time_s [s] of driving; sent at time_s [s].
  static TeamMessage intention(int robot, int from_vertex, int vertex, double expected_arrival_s,
                               double travel_time_s, double time_s);
  Kind kind = Kind::kOpaque;
  int robot = -1;
  int vertex = -1;
  double time_s = 0;
  int next_vertex = -1;  // Visit
  int from_vertex = -1;  // Intention
  double expected_arrival_s = 0;
  double travel_time_s = 0;
  std::shared_ptr<void> opaque;
  // The destination an opaque message announces (tpuaf.robot.machine.announced_vertex; -1:
  // none); a Visit announces its next_vertex, an Intention its vertex.
  int announced = -1;
};

// What a strategy sees of the run and how it acts on it. GraphEngine is the host of the graph
// runtime (every robot); PolicyHost is the host of one robot on a live clock.
class StrategyHost {
 public:
  virtual ~StrategyHost() = default;
  virtual double now() const = 0;  // run time [s]
  virtual int robots() const = 0;  // team size N
  virtual const PatrolGraph& graph() const = 0;
  virtual int current_vertex(int robot) const = 0;
  // Vel(i) of Eq. 6 [m/s]: measured once the robot drove 1 s, nominal before.
  virtual double average_speed(int robot) const = 0;
  // Broadcast a team message of `robot` (may be delayed or lost).
  virtual void send(int robot, TeamMessage message) = 0;
  // No loss, no delay and no faults: every message reaches every teammate when it is sent.
  virtual bool team_hears_alike() const = 0;
  // A message can arrive after its send time (a delayed bus, a network).
  virtual bool messages_may_be_late() const = 0;
  // Ask for decide() at time_s [s] while the robot has no goal.
  virtual void wake_at(int robot, double time_s) = 0;
  // Redirect a driving robot: it finishes its current edge, then heads to `vertex`.
  virtual void change_goal(int robot, int vertex) = 0;
};

// The host of one robot's strategy on a live clock (physics runtime, ROS agents): the runtime
// sets the clock and the robot's state before each call and collects what the strategy did
// (messages sent, wake-up asked, goal changed) after it.
class PolicyHost final : public StrategyHost {
 public:
  // graph: kept by reference, must outlive the host.
  PolicyHost(const PatrolGraph& graph, int robots, int robot);
  double now() const override { return now_; }
  int robots() const override { return robots_; }
  const PatrolGraph& graph() const override { return *graph_; }
  int current_vertex(int robot) const override;
  double average_speed(int robot) const override;
  void send(int robot, TeamMessage message) override;
  bool team_hears_alike() const override { return false; }
  bool messages_may_be_late() const override { return true; }
  void wake_at(int robot, double time_s) override;
  void change_goal(int robot, int vertex) override;

  int robot() const { return robot_; }
  // Re-timed edges (learned travel durations): strategies that read graph() at each call use
  // `graph` from now on. Kept by reference, must outlive the host.
  void set_graph(const PatrolGraph& graph);
  // The robot's state at the next call: run time [s], vertex, Vel(i) [m/s].
  void set_state(double now_s, int current_vertex, double average_speed_mps);
  // What the strategy did since the last take_*(): its messages, the wake-up time asked (NaN:
  // none) and the new goal (-1: none).
  std::vector<TeamMessage> take_messages();
  double take_wake_time();
  int take_goal_change();

 private:
  void check_robot(int robot) const;
  const PatrolGraph* graph_;
  int robots_, robot_;
  double now_ = 0, speed_mps_ = 0;
  int current_ = 0;
  std::vector<TeamMessage> outbox_;
  double wake_s_;
  int goal_change_ = -1;
};

// A team strategy: one decision maker per robot, called only at its decisions (the Policy
// contract of tpuaf.policies.base). decide() returns the next goal vertex or -1 to wait.
class TeamStrategy {
 public:
  virtual ~TeamStrategy() = default;
  virtual void start(StrategyHost& host, int robot) = 0;
  virtual int decide(StrategyHost& host, int robot) = 0;
  virtual void on_message(StrategyHost& host, int robot, const TeamMessage& message) = 0;
  // The motion gave up on goal `vertex` (a stalled robot); decide() is called next.
  virtual void on_goal_failed(StrategyHost& /*host*/, int /*robot*/, int /*vertex*/) {}
  // Teammate `lost` went silent for the liveness timeout (runs with faults).
  virtual void on_teammate_lost(StrategyHost& /*host*/, int /*robot*/, int /*lost*/) {}
  // host.graph() now holds learned edge travel times (PolicyHost::set_graph; lengths = plan
  // speed x learned duration): a strategy that keeps timings from the graph re-times them here.
  virtual void retime(StrategyHost& /*host*/, int /*robot*/) {}
  // True if the strategy never calls back into Python (the run may release the GIL).
  virtual bool is_native() const { return true; }
  // True if on_message only changes the recipient's own state and never sends: the engine may
  // then hand a batch of deliveries out robot by robot (each robot still gets them in order),
  // which keeps one robot's state in cache.
  virtual bool messages_are_local() const { return false; }
  // A message that every teammate of `sender` receives now (StrategyHost::team_hears_alike()):
  // the strategy may take it once for the whole team instead of once per recipient; true if it
  // did (the engine then delivers it to nobody and counts it delivered to all).
  virtual bool on_team_message(StrategyHost& /*host*/, int /*sender*/,
                               const TeamMessage& /*message*/) {
    return false;
  }
};

}  // namespace tpuaf
