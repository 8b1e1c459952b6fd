// Event loop of the graph (batch) runtime: event queue, robot motion on graph edges, team bus
// with delay and loss, and the ground-truth recorder (visits, 1 Hz samples, interference, X).
//
// It reproduces the Python graph runtime (tpuaf.runtimes.graph.BatchRun with
// tpuaf.measure.metrics.RunRecorder) operation for operation, so that a run gives the same numbers to
// the last digit for the same seed: the random streams are numpy's PCG64 with numpy's
// algorithms, and the means use numpy's pairwise summation. Times in seconds, lengths in metres,
// vertices are graph indices.
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
#include "tpuaf_core/knowledge.hpp"
#include "tpuaf_core/uncertainty.hpp"

namespace tpuaf {

// numpy's PCG64 bit generator (XSL-RR 128/64) and the Generator methods the runtimes use.
// Seeded from a numpy Generator's bit_generator.state, so both draw the same stream.
class NumpyPcg64 {
 public:
  NumpyPcg64(std::uint64_t state_hi, std::uint64_t state_lo, std::uint64_t inc_hi,
             std::uint64_t inc_lo, bool has_uint32 = false, std::uint32_t uinteger = 0);
  std::uint64_t next_uint64();
  std::uint32_t next_uint32();  // numpy's buffered half of a 64-bit draw
  double random();              // Generator.random(): [0, 1), 53 bits
  // Generator.integers(0, n) for 1 <= n <= 2^32 (Lemire's method on 32-bit draws, as numpy).
  std::int64_t integers(std::int64_t n);
  // (state_hi, state_lo, inc_hi, inc_lo, has_uint32, uinteger), to hand back to numpy.
  void get_state(std::uint64_t& state_hi, std::uint64_t& state_lo, std::uint64_t& inc_hi,
                 std::uint64_t& inc_lo, bool& has_uint32, std::uint32_t& uinteger) const;

 private:
  unsigned __int128 state_, inc_;
  bool has_uint32_;
  std::uint32_t uinteger_;
};

// np.sum of a contiguous double array bit for bit: pairwise summation over chunks of numpy's
// 8192-element buffer, added in order.
double numpy_pairwise_sum(const double* a, std::size_t n);
double numpy_sum(const double* a, std::size_t n);
inline double numpy_mean(const double* a, std::size_t n) {
  return numpy_sum(a, n) / static_cast<double>(n);
}

// A team message (tpuaf.team.messages). `opaque` carries a message of a Python strategy unchanged.
struct TeamMessage {
  enum class Kind { kVisit, kIntention, kIdlenessEstimate, kOpaque };
  Kind kind = Kind::kOpaque;
  int robot = -1;
  int vertex = -1;
  double time_s = 0;
  int next_vertex = -1;  // Visit, IdlenessEstimate
  int from_vertex = -1;  // Intention
  double expected_arrival_s = 0;
  double travel_time_s = 0;
  std::shared_ptr<const std::vector<double>> estimate;  // IdlenessEstimate E[v] [s]
  std::shared_ptr<void> opaque;
  // The destination an opaque message announces (tpuaf.robot.machine.announced_vertex; -1:
  // none); the other kinds announce their next_vertex (Visit, IdlenessEstimate) or vertex.
  int announced = -1;
};

class GraphEngine;

// A team strategy: one decision maker per robot, called only at its decisions (the Policy
// contract of tpuaf.policies.base). decide() returns the next goal vertex or -1 to wait.
class TeamStrategy {
 public:
  virtual ~TeamStrategy() = default;
  virtual void start(GraphEngine& engine, int robot) = 0;
  virtual int decide(GraphEngine& engine, int robot) = 0;
  virtual void on_message(GraphEngine& engine, int robot, const TeamMessage& message) = 0;
  // The motion gave up on goal `vertex` (a stalled robot); decide() is called next.
  virtual void on_goal_failed(GraphEngine& /*engine*/, int /*robot*/, int /*vertex*/) {}
  // Teammate `lost` went silent for the liveness timeout (runs with faults).
  virtual void on_teammate_lost(GraphEngine& /*engine*/, int /*robot*/, int /*lost*/) {}
  // True if the strategy never calls back into Python (the run may release the GIL).
  virtual bool is_native() const { return true; }
  // True if on_message only changes the recipient's own state and never sends: the engine may
  // then hand a batch of deliveries out robot by robot (each robot still gets them in order),
  // which keeps one robot's state in cache.
  virtual bool messages_are_local() const { return false; }
  // A message that every teammate of `sender` receives now (GraphEngine::team_hears_alike()):
  // the strategy may take it once for the whole team instead of once per recipient; true if it
  // did (the engine then delivers it to nobody and counts it delivered to all).
  virtual bool on_team_message(GraphEngine& /*engine*/, int /*sender*/,
                               const TeamMessage& /*message*/) {
    return false;
  }
};

struct EngineConfig {
  int robots = 1;
  double duration_s = 3600;
  double delay_s = 0;  // team message delay [s]
  double loss = 0;     // probability that one recipient loses one message
  double sample_period_s = 1.0;
  double nominal_speed_mps = 1.0;
  double stay_s = 1.0;          // dwell when the goal is the current vertex [s]
  double retry_s = 1.0;         // a waiting strategy without a wake-up decides again after [s]
  double refractory_s = 10.0;   // interference episodes of a pair closer than this merge [s]
  double max_substep_s = 0.25;  // ground-truth field substep [s]
  double field_merge_s = 0.5;   // position updates closer than this merge into one field step
  double interference_distance_m = 2.0;
  double sensing_peak = 1.0;
  double sensing_radius_m = 5.0;
  std::vector<int> start_vertices;
  // Runs with faults (GraphEngine::set_faults):
  double goal_tolerance_m = 0.0;     // a stalled robot dwells only within this of its goal
  double stall_give_up_s = 60.0;     // a stalled robot's navigator gives up a drive after [s]
  double teammate_timeout_s = 10.0;  // a teammate silent this long is lost [s]
  double heartbeat_period_s = 1.0;   // every live robot sends a heartbeat this often [s]
};

// A robot fault at time_s [s] (tpuaf.runtimes.faults): death, or stall (stops moving for good).
struct EngineFault {
  double time_s = 0;
  int robot = 0;
  bool death = true;
};

// Heartbeats of a run with faults (tpuaf.team.liveness.HeartbeatLinks, step for step): robot j
// sends heartbeat k at k * period [s] while alive (k * period <= its death time) and within the
// run; robot i hears it delay [s] later unless lost, one draw per (sender, recipient, heartbeat)
// from the sender's stream numpy default_rng([seed, 4, sender]).random((n, count)).
class HeartbeatLinks {
 public:
  // rngs: one stream per sender (unused, and may be empty, without loss).
  HeartbeatLinks(int robots, double duration_s, double timeout_s, double delay_s, double loss,
                 double period_s, std::vector<NumpyPcg64> rngs);
  void died(int robot, double t);  // its heartbeats stop after run time t [s]
  // [s] when `recipient` last heard `sender` by run time t (-inf: never).
  double last_arrival_s(int recipient, int sender, double t);
  // [s] the next time recipient's view of sender can change from heartbeats alone (+inf: never).
  double next_check_s(int recipient, int sender, double last_heard, bool lost, double now);

 private:
  struct Link {
    std::vector<std::int32_t> received;  // heartbeat indices heard, ascending
    std::vector<std::int32_t> silences;  // positions p: received[p + 1] comes after a timeout
  };
  double arrival(std::int64_t k) const { return static_cast<double>(k) * period_s_ + delay_s_; }
  const Link& link(int recipient, int sender);
  std::int64_t heard_by(const Link& l, int sender, double t) const;
  void silences_of(Link& l) const;
  int n_;
  double period_s_, delay_s_, timeout_s_, loss_;
  std::int64_t count_;
  std::vector<std::int64_t> last_sent_;
  std::vector<NumpyPcg64> rngs_;
  std::vector<std::vector<Link>> links_;  // [sender][recipient], drawn when first asked
  Link every_;                            // without loss: every heartbeat on every link
};

struct VisitRecord {
  double time_s;
  int robot;
  int vertex;
};

struct SampleRow {
  double time_s, idleness_ins_s, worst_idleness_s, uncertainty_mean;
  long long visits, interferences;
};

struct InterferenceRecord {
  double time_s;
  int a, b;
};

struct BusStats {
  long long sent = 0, delivered = 0, lost = 0;
};

// Ground truth of one run (tpuaf.measure.metrics.RunRecorder with ground truth, all robots alive).
class GroundTruthRecorder {
 public:
  GroundTruthRecorder(const EngineConfig& config, UncertaintyField field);
  void record_visit(int robot, int vertex, double time_s);
  void record_positions(double time_s, const Points& positions);
  void finish(double end_s);  // robots held at their last positions until end_s
  // Robot `robot` died at time_s [s]: it no longer senses nor interferes (a NaN position, as
  // RunRecorder.record_robot_death).
  void record_robot_death(int robot, double time_s);
  void record_robot_stall(int robot, double time_s) { stalls_.push_back({time_s, robot, -1}); }
  void record_announcement(int robot, int vertex, double time_s) {
    announcements_.push_back({time_s, robot, vertex});
  }
  const std::vector<VisitRecord>& deaths() const { return deaths_; }  // (t, robot, -1)
  const std::vector<VisitRecord>& stalls() const { return stalls_; }
  const std::vector<VisitRecord>& announcements() const { return announcements_; }

  // The visits still kept (and their interval idleness [s]): visits visits_forgotten() ..
  // visit_count() - 1 (see forget_visits_before).
  const std::vector<VisitRecord>& visits() const { return visits_; }
  const std::vector<double>& visit_idleness() const { return visit_idleness_; }
  std::size_t visit_count() const { return visits_forgotten_ + visits_.size(); }
  std::size_t visits_forgotten() const { return visits_forgotten_; }
  // Visits before index `first` are dropped (a results writer has them on disk): memory of a
  // long run stays bounded; visit indices, the per-vertex times (vertex_times: intervals,
  // counts, first visits, worst idleness) and the 1 Hz visit counts are unchanged.
  void forget_visits_before(std::size_t first) {
    const std::size_t drop = std::min(first, visit_count()) - std::min(first, visits_forgotten_);
    visits_.erase(visits_.begin(), visits_.begin() + static_cast<std::ptrdiff_t>(drop));
    visit_idleness_.erase(visit_idleness_.begin(),
                          visit_idleness_.begin() + static_cast<std::ptrdiff_t>(drop));
    visits_forgotten_ += drop;
  }
  // The 1 Hz rows still kept: rows rows_forgotten() .. row_count() - 1 (see forget_rows_before).
  const std::vector<SampleRow>& timeseries() const { return rows_; }
  std::size_t row_count() const { return rows_forgotten_ + rows_.size(); }
  std::size_t rows_forgotten() const { return rows_forgotten_; }
  // Rows before index `first` are dropped (a results writer has them on disk): memory of a
  // long run stays bounded; row indices and the sums (ins_sum) are unchanged.
  void forget_rows_before(std::size_t first) {
    const std::size_t drop = std::min(first, row_count()) - std::min(first, rows_forgotten_);
    rows_.erase(rows_.begin(), rows_.begin() + static_cast<std::ptrdiff_t>(drop));
    rows_forgotten_ += drop;
  }
  const std::vector<InterferenceRecord>& interferences() const { return interferences_; }
  const std::vector<std::vector<double>>& vertex_times() const { return vertex_times_; }
  const Eigen::VectorXd& field_values() const { return values_; }
  double ins_sum() const { return ins_sum_; }
  double x_sum() const { return x_sum_; }
  long long x_count() const { return x_count_; }
  bool has_positions() const { return has_pos_; }
  double positions_time() const { return pos_time_; }
  double worst_idleness(double end_s) const;

 private:
  void apply_pending(double t);
  void apply_visit(double vt, int v);
  void emit_row(double t, double x_mean);
  void advance_field(double t0, double t1, const Points& p0, const Points& p1, bool finite);
  void step_field(double dt, const Points& pa, const Points& pb);
  void interference(double t0, double t1, const Points& p0, const Points& p1, double step);
  void interference_all(double t0, double t1, const Points& p0, const Points& p1);
  void enter_pair(std::uint64_t key, int i, int j, double t0, double t1, const Points& p0,
                  double d1x, double d1y);
  void keep_fresh();
  void rebuild_verlet(const Points& p, double reach);
  long long interferences_until(double t) const;

  int n_robots_, n_vertices_;
  double period_, refractory_, max_substep_, field_merge_, dif2_, d_if_;
  UncertaintyField field_;  // targets, importance and growth law of the ground truth
  Eigen::VectorXd values_;  // ground-truth X_j
  // Targets bucketed by cells of one sensing radius (the coverage of a robot only looks at
  // the 3 x 3 cells around it); cell (cx, cy) -> targets, dense over the targets' box.
  double target_cell_ = 1, target_x0_ = 0, target_y0_ = 0;
  int target_nx_ = 1, target_ny_ = 1;
  std::vector<int> target_start_, target_index_;
  Eigen::VectorXd cover_left_, cover_mid_, cover_right_;
  Points cover_at_;
  void coverage(const Points& start, const Points& end, double fraction, Eigen::VectorXd& out);
  void advance_linear(double dt, const Points& start, const Points& end);
  Eigen::VectorXd peaks_, radii_;
  double field_t_ = 0;
  Points field_p_;
  bool has_field_p_ = false;
  bool field_finite_ = true;  // no robot absent at field_p_
  std::vector<char> alive_;
  bool all_alive_ = true;
  Points masked_;  // positions with the dead robots' rows NaN
  std::vector<VisitRecord> deaths_, stalls_, announcements_;

  std::vector<VisitRecord> visits_;
  std::vector<double> visit_idleness_;
  std::size_t visits_forgotten_ = 0;
  std::vector<std::vector<double>> vertex_times_;
  std::deque<std::pair<double, int>> pending_;
  Eigen::VectorXd sample_last_;
  long long sample_visits_ = 0;
  double sample_worst_ = 0;
  double next_sample_;
  long long sample_k_ = 1;
  std::vector<SampleRow> rows_;
  std::size_t rows_forgotten_ = 0;
  double ins_sum_ = 0, x_sum_ = 0;
  long long x_count_ = 0;

  bool has_pos_ = false;
  double pos_time_ = 0;
  Points pos_;
  std::vector<std::uint64_t> close_;  // sorted pair keys i * n + j (i < j) within d_if
  std::unordered_map<std::uint64_t, double> last_count_;  // pair -> last counted entry [s]
  std::vector<InterferenceRecord> interferences_;
  // Verlet list of candidate pairs, built through a spatial hash (see interference()).
  static constexpr std::int64_t kCellStride = std::int64_t{1} << 32;
  double verlet_skin_;
  bool verlet_valid_ = false;
  Points verlet_ref_;
  double verlet_half_skin2_ = 0;
  std::vector<std::uint64_t> verlet_pairs_;  // sorted keys i * n + j
  std::vector<std::pair<std::int64_t, int>> cells_, sorted_cells_;
  std::vector<std::uint64_t> close_end_;
  std::vector<InterferenceRecord> fresh_;
};

class GraphEngine {
 public:
  // graph: the patrol graph (kept by reference, must outlive the engine); positions: vertex
  // positions [m] used for motion; field: the ground-truth X field at its initial values;
  // bus_rng: numpy default_rng([seed, 1]).
  GraphEngine(const PatrolGraph& graph, Points positions, EngineConfig config,
              UncertaintyField field, NumpyPcg64 bus_rng);

  void set_strategy(TeamStrategy* strategy) { strategy_ = strategy; }
  // The run's faults (time order, as resolved by tpuaf.runtimes.faults) and, when there is one,
  // the heartbeat streams (numpy default_rng([seed, 4, sender]) per sender; unused without
  // loss). With faults every robot's liveness is fed and checked as in BatchRun.
  void set_faults(std::vector<EngineFault> faults, std::vector<NumpyPcg64> heartbeat_rngs);
  bool has_faults() const { return !faults_.empty(); }
  bool alive(int robot) const { return robot_at(robot).alive; }
  bool stalled(int robot) const { return robot_at(robot).stalled; }
  // (run time [s], observer, lost teammate) of every liveness loss, in order.
  struct Loss {
    double time_s;
    int observer, lost;
  };
  const std::vector<Loss>& losses() const { return losses_; }
  // Simulate until duration_s; progress(now) now and then (every 1/200 of the run).
  void run(const std::function<void(double)>& progress = {});
  void finish() { recorder_.finish(now_); }

  // --- what a strategy's RobotContext offers ---
  double now() const { return now_; }
  int robots() const { return config_.robots; }
  const PatrolGraph& graph() const { return graph_; }
  const Points& vertex_positions() const { return positions_; }
  const EngineConfig& config() const { return config_; }
  int current_vertex(int robot) const { return robot_at(robot).current; }
  int start_vertex(int robot) const { return robot_at(robot).start; }
  int goal(int robot) const { return robot_at(robot).goal; }
  double travelled_m(int robot) const { return robot_at(robot).travelled_m; }
  double travel_time_s(int robot) const { return robot_at(robot).travel_time_s; }
  // Vel(i) of Eq. 6 [m/s]: measured once the robot drove 1 s, nominal before.
  double average_speed(int robot) const;
  void position(int robot, double t, double& x, double& y) const;
  void send(int robot, TeamMessage message);
  // No loss, no delay and no faults: every message reaches every teammate at the moment it is
  // sent (and nobody's view of the team changes apart from them).
  bool team_hears_alike() const {
    return config_.loss == 0 && config_.delay_s == 0 && faults_.empty();
  }
  void wake_at(int robot, double time_s);
  void change_goal(int robot, int vertex);

  const GroundTruthRecorder& recorder() const { return recorder_; }
  GroundTruthRecorder& recorder() { return recorder_; }
  const BusStats& bus_stats() const { return bus_; }
  long long events() const { return events_; }

 private:
  struct Robot {
    int current = 0, start = 0, goal = -1, redirect = -1;
    std::vector<int> route;
    std::size_t route_k = 0;
    double travelled_m = 0, travel_time_s = 0;
    bool wake_pending = false;
    bool alive = true, stalled = false, dwelling = false;
    double p0x = 0, p0y = 0, vx = 0, vy = 0, t0 = 0, t1 = 0;  // current straight segment
    std::uint64_t pending = 0;       // seq of its one awaited ARRIVE or GIVE_UP (0: none)
    std::uint64_t liveness = 0;      // seq of its one pending liveness check (0: none)
    std::vector<double> last_heard;  // [s] per teammate (TeammateLiveness), runs with faults
    std::vector<char> lost;          // per teammate: reported lost
  };
  struct Event {
    double time;
    int kind;
    std::uint64_t seq;
    int payload;  // robot, delivery slot or fault index
    bool operator>(const Event& o) const {
      if (time != o.time) return time > o.time;
      if (kind != o.kind) return kind > o.kind;
      return seq > o.seq;
    }
  };
  struct Delivery {
    TeamMessage message;
    int sender = -1;
    bool all_but_sender = false;  // recipients = every robot but the sender
    std::vector<int> recipients;
  };

  const Robot& robot_at(int robot) const;
  std::uint64_t push(double time, int kind, int payload);
  void deliver_ready();
  void deliver_heard();
  void drive(int robot);
  void give_up_later(int robot);
  void give_up(int robot);
  void freeze(int robot);
  void inject(const EngineFault& fault);
  bool at_vertex(int robot, int vertex) const;
  int nearest_vertex(double x, double y) const;
  bool hear(int robot, int sender, double t);
  void feed_heartbeats(int robot);
  void plan_liveness(int robot);
  void liveness_due(int robot);
  void deliver_batch_by_robot();
  void decide(int robot);
  void plan_route(Robot& r, int goal);
  void start_segment(int robot);
  void arrive(int robot);
  void record_positions(double t);
  void positions(double t, Points& out) const;

  const PatrolGraph& graph_;
  Points positions_;
  EngineConfig config_;
  GroundTruthRecorder recorder_;
  NumpyPcg64 bus_rng_;
  TeamStrategy* strategy_ = nullptr;
  std::vector<Robot> robots_;
  double now_ = 0;
  double last_positions_time_ = -1.0;
  std::priority_queue<Event, std::vector<Event>, std::greater<Event>> events_queue_;
  std::uint64_t seq_ = 0;
  long long events_ = 0;
  std::vector<Delivery> slots_;
  std::vector<int> free_slots_;
  std::deque<Delivery> ready_;
  std::vector<Delivery> batch_;
  std::vector<std::size_t> batch_cursor_;
  BusStats bus_;
  Points scratch_;
  std::vector<double> lost_scratch_;
  std::vector<EngineFault> faults_;
  std::unique_ptr<HeartbeatLinks> links_;
  std::vector<Loss> losses_;
  std::vector<int> lost_now_;
  std::vector<int> lost_by_;  // per robot: how many teammates hold it for lost now
};

// ------------------------------------------------------------------ C++ decision paths

// TPUAF (tpuaf.policies.tpuaf.Tpuaf, and TpuafAnyVertex with any_vertex): every robot holds
// a copy of `knowledge` (built as the Python policy builds it) and its own random stream
// (numpy default_rng([seed, 2, robot])) for the tie-break. On a bus without loss and delay the
// copies would stay equal but for each robot's own intention: the team then holds one
// knowledge (TpuafKnowledge::hear_team_*), so a message costs O(1), not O(robots).
class TpuafStrategy : public TeamStrategy {
 public:
  // colocation: the Python policy's `colocation` parameter (robots that arrive together
  // before late messages tell resolve by index, tpuaf/policies/tpuaf.py).
  TpuafStrategy(const TpuafKnowledge& knowledge, UtilityForm form, bool any_vertex,
                std::vector<NumpyPcg64> rngs, bool colocation = true);
  void start(GraphEngine& engine, int robot) override;
  int decide(GraphEngine& engine, int robot) override;
  void on_message(GraphEngine& engine, int robot, const TeamMessage& message) override;
  // As Tpuaf.on_teammate_lost: forget its intention, it is no longer my shadow.
  void on_teammate_lost(GraphEngine& engine, int robot, int lost) override;
  bool messages_are_local() const override { return true; }
  bool on_team_message(GraphEngine& engine, int sender, const TeamMessage& message) override;
  // What robot `robot` knows (a copy; the team's knowledge without its own intention when
  // the team shares one).
  TpuafKnowledge knowledge(int robot) const;
  bool shares_knowledge() const { return shared_; }

 private:
  TpuafKnowledge& knowledge_of(int robot) {
    return knowledge_[shared_ ? 0 : static_cast<std::size_t>(robot)];
  }
  struct Colocation {
    double latency_s = 0;  // largest message latency seen (receive - send) [s]
    std::unordered_map<int, std::deque<std::pair<double, int>>> my_visits;  // v -> (t, next)
    std::vector<char> shadows;                                              // per teammate
  };
  void presume_choice(GraphEngine& engine, int robot, int mate);
  void track_shadow(int robot, const TeamMessage& visit);
  TpuafKnowledge prototype_;
  UtilityForm form_;
  bool any_vertex_;
  std::vector<NumpyPcg64> rngs_;
  bool colocation_;
  bool shared_ = false;                    // one knowledge for the team (knowledge_[0])
  std::vector<TpuafKnowledge> knowledge_;  // per robot, or the team's
  std::vector<Colocation> colocated_;
  std::vector<int> candidates_;
};

// Candidate of largest score, ties (within tol * max(1, |max|)) at random with rng.integers:
// tpuaf.policies.common.pick_max. Returns an index into scores.
int pick_max_index(const std::vector<double>& scores, NumpyPcg64& rng, double tol = 1e-9);

// GBS (tpuaf.policies.bayesian.GreedyBayesian): argmax over the neighbours of
// P = G1 exp(ln(1/G1) gain / G2), gain = shared idleness / max(edge, edge_min). G2 and edge_min
// come resolved from the Python policy. exp is the C library's, where numpy uses its own SIMD
// exp (both within 1 ulp); the decision compares P with a 1e-9 tolerance, so the runs agree
// unless a P falls within 1 ulp of that threshold (tests/test_engine_golden.py checks).
class GbsStrategy : public TeamStrategy {
 public:
  GbsStrategy(double g1, double g2, double edge_min_m, std::vector<NumpyPcg64> rngs);
  void start(GraphEngine& engine, int robot) override;
  int decide(GraphEngine& engine, int robot) override;
  void on_message(GraphEngine& engine, int robot, const TeamMessage& message) override;
  bool messages_are_local() const override { return true; }

 private:
  double g1_, g2_, edge_min_m_, log_inv_g1_;
  std::vector<NumpyPcg64> rngs_;
  std::vector<std::vector<double>> last_visit_;  // per robot, per vertex [s]
  std::vector<int> candidates_;
  std::vector<double> scores_;
};

// DTAG (tpuaf.policies.dtag): argmax over all vertices of w_idleness E[v] - w_path path(cv, v)
// - w_origin |pos(v) - origin|; estimates shared (min-merge), the next vertex reserved, the
// higher-id robot of a clash re-plans once per decision (change_goal). origin_distance_m:
// per robot, |pos(v) - start position| computed by numpy (np.hypot) on the Python side.
class DtagStrategy : public TeamStrategy {
 public:
  DtagStrategy(double initial_estimate_s, double w_idleness, double w_path, double w_origin,
               std::vector<std::vector<double>> origin_distance_m, std::vector<NumpyPcg64> rngs);
  void start(GraphEngine& engine, int robot) override;
  int decide(GraphEngine& engine, int robot) override;
  void on_message(GraphEngine& engine, int robot, const TeamMessage& message) override;
  long long replans(int robot) const;

 private:
  struct State {
    std::vector<double> values;  // E[v] [s]
    double updated = 0;
    int next = -1;
    bool replanned = false;
    long long replans = 0;
  };
  void advance(State& s, double now);
  int choose(GraphEngine& engine, int robot, int here, int exclude_a, int exclude_b);
  void announce(GraphEngine& engine, int robot, int next);
  double initial_, w_idleness_, w_path_, w_origin_;
  std::vector<std::vector<double>> origin_distance_m_;
  std::vector<NumpyPcg64> rngs_;
  std::vector<State> states_;
  std::vector<int> candidates_;
  std::vector<double> scores_;
};

}  // namespace tpuaf
