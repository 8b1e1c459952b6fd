// The graph runtime's event loop (the only one): event queue, robot motion on graph edges, team
// bus with delay and loss, faults and liveness, feeding the ground-truth recorder. Its random
// streams are numpy's PCG64 and its means numpy's pairwise sums, so that its figures match the
// Python recorder's arithmetic. Times in seconds, lengths in metres, vertices graph indices.
#pragma once

#include <algorithm>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <queue>
#include <unordered_map>
#include <vector>

#include "tpuaf_core/graph.hpp"
#include "tpuaf_core/heartbeats.hpp"
#include "tpuaf_core/knowledge.hpp"
#include "tpuaf_core/numpy_random.hpp"
#include "tpuaf_core/recorder.hpp"
#include "tpuaf_core/robot_protocol.hpp"
#include "tpuaf_core/run_config.hpp"
#include "tpuaf_core/strategies.hpp"
#include "tpuaf_core/strategy.hpp"
#include "tpuaf_core/team_bus.hpp"
#include "tpuaf_core/team_liveness.hpp"
#include "tpuaf_core/uncertainty.hpp"
#include "tpuaf_core/visit_rule.hpp"

namespace tpuaf {

// The engine is the team's strategy host and the driver of every robot's RobotProtocol (the one
// robot state machine, robot_protocol.hpp): it moves the robots, the protocol decides.
class GraphEngine final : public StrategyHost, private RobotDriver {
 public:
  // graph: the patrol graph (kept by reference, must outlive the engine); positions: vertex
  // positions [m] used for motion; field: the ground-truth X field at its initial values;
  // bus_rng: the team bus's loss stream (tpuaf.team.bus.bus_stream: default_rng([seed, 1])).
  GraphEngine(const PatrolGraph& graph, Points positions, EngineConfig config,
              UncertaintyField field, NumpyPcg64 bus_rng);

  void set_strategy(TeamStrategy* strategy) { strategy_ = strategy; }
  // The run's faults (time order, as resolved by tpuaf.runtimes.faults) and, when there is one,
  // the heartbeat streams (numpy default_rng([seed, 4, sender]) per sender; unused without
  // loss). With faults every robot's liveness is fed and checked.
  void set_faults(std::vector<EngineFault> faults, std::vector<NumpyPcg64> heartbeat_rngs);
  bool has_faults() const { return !faults_.empty(); }
  bool alive(int robot) const { return protocol(robot).alive(); }
  bool stalled(int robot) const { return protocol(robot).stalled(); }
  // (run time [s], observer, lost teammate) of every liveness loss, in order.
  using Loss = TeamLiveness::Loss;
  const std::vector<Loss>& losses() const;
  // The team's liveness and fault steps (runs with faults; null without).
  const TeamLiveness* team() const { return team_.get(); }
  // Simulate until duration_s; progress(now) now and then (every 1/200 of the run).
  void run(const std::function<void(double)>& progress = {});
  void finish() { recorder_.finish(now_); }

  // --- what a strategy's RobotContext offers ---
  double now() const override { return now_; }
  int robots() const override { return config_.robots; }
  const PatrolGraph& graph() const override { return graph_; }
  const Points& vertex_positions() const { return positions_; }
  const EngineConfig& config() const { return config_; }
  int current_vertex(int robot) const override { return protocol(robot).current_vertex(); }
  int start_vertex(int robot) const { return protocol(robot).start_vertex(); }
  int goal(int robot) const { return protocol(robot).goal(); }
  double travelled_m(int robot) const { return robot_at(robot).travelled_m; }
  double travel_time_s(int robot) const { return robot_at(robot).travel_time_s; }
  // Vel(i) of Eq. 6 [m/s]: measured once the robot drove 1 s, nominal before.
  double average_speed(int robot) const override;
  void position(int robot, double t, double& x, double& y) const;
  void send(int robot, TeamMessage message) override;
  // No loss, no delay and no faults: every message reaches every teammate at the moment it is
  // sent (and nobody's view of the team changes apart from them).
  bool team_hears_alike() const override {
    return config_.loss == 0 && config_.delay_s == 0 && faults_.empty();
  }
  void wake_at(int robot, double time_s) override;
  bool messages_may_be_late() const override { return config_.delay_s > 0; }
  void change_goal(int robot, int vertex) override;

  const GroundTruthRecorder& recorder() const { return recorder_; }
  GroundTruthRecorder& recorder() { return recorder_; }
  const TeamBusStats& bus_stats() const { return bus_.stats(); }
  long long events() const { return events_; }
  const VisitRule& visit_rule(int robot) const { return protocol(robot).visit_rule(); }
  const RobotProtocol& protocol(int robot) const;

 private:
  // Event kinds, in the order ties resolve (tpuaf.runtimes.graph); a message in flight (the
  // bus's) is a kDeliver event at its due time.
  static constexpr int kArrive = 0, kWake = 1, kDeliver = 2, kFault = 3, kGiveUp = 4, kLiveness = 5;
  // A robot's motion (its protocol state is in protocols_).
  struct Robot {
    std::vector<int> route;  // the vertices still to reach from route_k on
    std::size_t route_k = 0;
    double travelled_m = 0, travel_time_s = 0;
    double p0x = 0, p0y = 0, vx = 0, vy = 0, t0 = 0, t1 = 0;  // current straight segment
    std::uint64_t pending = 0;  // seq of its one awaited ARRIVE or GIVE_UP (0: none)
    int held_short_of = -1;     // the narrow vertex it waits short of (-1: none)
    int came_from = -1;         // the vertex its last edge started from (-1: none yet)
  };
  struct Event {
    double time;
    int kind;
    std::uint64_t seq;
    int payload;  // robot or fault index
    bool operator>(const Event& o) const {
      if (time != o.time) return time > o.time;
      if (kind != o.kind) return kind > o.kind;
      return seq > o.seq;
    }
  };

  const Robot& robot_at(int robot) const;
  RobotProtocol& protocol_of(int robot) { return protocols_[static_cast<std::size_t>(robot)]; }
  std::uint64_t push(double time, int kind, int payload);
  void deliver_ready();
  void deliver_heard();
  void move(int robot);  // along its route (a stalled robot gives up later)
  void give_up_later(int robot);
  void give_up(int robot);
  void freeze(int robot);
  void after_stall(int robot);
  void deliver_batch_by_robot();
  const TeamMessage& message_of(const BusDelivery& d) const {
    return messages_[static_cast<std::size_t>(d.message)];
  }
  void free_message(std::int64_t id);  // its message is delivered: the id is free
  void plan_route(Robot& r, int from, int goal);
  void start_segment(int robot);
  void arrive(int robot);
  double turn_s(int from, int at, int to) const;  // [s] added to at -> to after from -> at
  // --- aisles one robot wide (EngineConfig::narrow_vertices) ---
  bool narrow(int vertex) const {
    return !narrow_.empty() && narrow_[static_cast<std::size_t>(vertex)];
  }
  double take_slot(int vertex, double earliest_s);  // the first passing time >= earliest_s
  void hold_short(int robot, int vertex);           // another robot stands on it: wait short of it
  void stop_holding(int robot);                     // no longer waiting for a narrow vertex
  void leave(int robot, int vertex);                // it drives off: the next held robot comes
  bool blocks(int robot, int vertex) const;         // another live robot stands on vertex
  // --- RobotDriver: what the robots' protocols ask of the loop ---
  void position(int robot, double& x, double& y) const override { position(robot, now_, x, y); }
  bool at_vertex(int robot, int vertex) const override;
  void schedule_wake(int robot, double time_s) override { push(time_s, kWake, robot); }
  void drive(int robot, int from_vertex, int goal) override;
  void dwell(int robot, int vertex, double duration_s) override;
  void halt(int /*robot*/) override {}  // it stands still: waiting or dead, it was stopped
  void policy_start(int robot) override { strategy_->start(*this, robot); }
  int policy_decide(int robot) override;
  void policy_goal_failed(int robot, int vertex) override {
    strategy_->on_goal_failed(*this, robot, vertex);
  }
  void policy_teammate_lost(int robot, int teammate) override {
    strategy_->on_teammate_lost(*this, robot, teammate);
  }
  void emit(int robot, int kind, int vertex, int from_vertex, double t) override;

  void record_positions(double t);
  void positions(double t, Points& out) const;

  const PatrolGraph& graph_;
  Points positions_;
  EngineConfig config_;
  GroundTruthRecorder recorder_;
  TeamBus bus_;
  TeamStrategy* strategy_ = nullptr;
  std::vector<Robot> robots_;
  std::vector<RobotProtocol> protocols_;  // one per robot: its state machine
  double now_ = 0;
  double last_positions_time_ = -1.0;
  std::priority_queue<Event, std::vector<Event>, std::greater<Event>> events_queue_;
  std::uint64_t seq_ = 0;
  long long events_ = 0;
  // The messages on the bus, by id (a deque: a strategy's sends during a delivery keep the
  // delivered message where it is); ids are reused once delivered.
  std::deque<TeamMessage> messages_;
  std::vector<std::int64_t> free_messages_;
  std::vector<BusDelivery> batch_;
  std::vector<std::size_t> batch_cursor_;
  Points scratch_;
  std::vector<EngineFault> faults_;
  std::unique_ptr<TeamLiveness> team_;  // with faults: heartbeats, checks, a fault's steps
  std::vector<char> narrow_;            // per vertex: one robot wide (empty: none)
  std::unordered_map<std::int64_t, double> turns_;  // (w, u, v) key -> [s] (turn_times)
  std::vector<int> standing_;               // per vertex: the robot standing on it (-1: none)
  std::vector<std::vector<double>> slots_;  // per vertex: passing times taken [s], ascending
  std::vector<std::deque<int>> held_;       // per vertex: robots held short of it, first first
};

}  // namespace tpuaf
