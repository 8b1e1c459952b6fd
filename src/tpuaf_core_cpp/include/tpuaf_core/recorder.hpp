// The one ground-truth recorder of every runtime (SPEC section 6): visits, 1 Hz samples,
// interference, the uncertainty field X (Eq. 2-3), deaths, outages, stalls, dwells. The graph
// runtime's event loop feeds it in C++; the physics runtime, the fleet monitor and bag analysis
// through tpuaf.measure.metrics.RunRecorder. Times in seconds, lengths in metres.
#pragma once

#include <cstdint>
#include <deque>
#include <string>
#include <unordered_map>
#include <vector>

#include "tpuaf_core/numpy_random.hpp"
#include "tpuaf_core/run_config.hpp"
#include "tpuaf_core/uncertainty.hpp"

namespace tpuaf {

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

// A silence of a robot (the monitor's outage): from start_s [s] until end_s [s] when it was
// heard again; `ended` false: never heard again, a death.
struct OutageRecord {
  int robot;
  double start_s, end_s;
  bool ended;
  std::string cause;
};

// The recorder's settings; their one declaration (RunRecorder's keyword defaults read them, and
// the graph runtime sets EngineConfig's from those).
struct RecorderConfig {
  int robots = 1;
  double start_time_s = 0.0;     // run clock at the start [s]
  double sample_period_s = 1.0;  // 1 Hz rows [s]
  double refractory_s = 10.0;    // interference episodes of a pair closer than this merge [s]
  double max_substep_s = 0.25;   // ground-truth field substep [s]
  // Consecutive position updates closer than this [s] merge into one linear field step (0 =
  // never merge); 0.5 s changes X by < 0.3 % at 1 m/s.
  double field_merge_s = 0.5;
  double interference_distance_m = 2.0;
  double sensing_peak = 1.0;
  double sensing_radius_m = 5.0;
  // false: no field (X NaN); the 1 Hz rows then follow the visits and positions as they come.
  bool ground_truth = true;
};

// The recorder's settings of a graph-runtime run.
RecorderConfig recorder_config(const EngineConfig& config);

// Every metric of SPEC section 6 during one run. Feed it record_visit (goal arrivals, in time
// order or not), record_positions (true robot positions, any rate; motion between calls is taken
// as linear; a NaN row: robot absent) and the faults. Visits may run ahead of positions: the 1 Hz
// rows are emitted when positions reach them (or, without ground truth, by any call), so every
// row sees exactly the visits up to its time.
class GroundTruthRecorder {
 public:
  GroundTruthRecorder(const RecorderConfig& config, UncertaintyField field);
  GroundTruthRecorder(const EngineConfig& config, UncertaintyField field)
      : GroundTruthRecorder(recorder_config(config), std::move(field)) {}
  const RecorderConfig& config() const { return config_; }
  void record_visit(int robot, int vertex, double time_s);
  void record_positions(double time_s, const Points& positions);
  // Robots held at their last positions until end_s (without ground truth: the rows up to
  // end_s), then flush_field().
  void finish(double end_s);
  // The field brought to the last positions' time (a merged chunk still pending is advanced).
  void flush_field();
  // Robot `robot` died at time_s [s]: it no longer senses nor interferes (a NaN position).
  void record_robot_death(int robot, double time_s);
  // Robot `robot` went out of contact at time_s [s] (it no longer senses nor interferes): a
  // death unless record_robot_back ends the outage.
  void record_robot_outage(int robot, double time_s, const std::string& cause);
  // Robot `robot`, out of contact, was heard again at time_s [s]: alive again.
  void record_robot_back(int robot, double time_s);
  void record_robot_stall(int robot, double time_s);  // stopped moving; still senses, talks
  // Robot `robot` announced at time_s [s] that it heads to `vertex`.
  void record_announcement(int robot, int vertex, double time_s) {
    announcements_.push_back({time_s, robot, vertex});
  }
  // Robot `robot` chose goal `vertex` at time_s [s], standing at `from_vertex`.
  void record_goal(int robot, int vertex, int from_vertex, double time_s);
  // A goal of `robot` ended at `vertex` without a visit (a dwell, VisitRule) at time_s [s]:
  // counted apart, no effect on idleness; the time since its goal counts as standing when that
  // goal was the vertex it stood on.
  void record_dwell(int robot, int vertex, double time_s);
  // A dwell of stay_s [s] standing (a caller that knows how long the robot stood).
  void count_dwell(double stay_s) {
    ++dwells_;
    dwell_time_s_ += stay_s;
  }
  long long dwells() const { return dwells_; }
  double dwell_time_s() const { return dwell_time_s_; }               // [s] standing in the dwells
  const std::vector<VisitRecord>& deaths() const { return deaths_; }  // (t, robot, -1)
  const std::vector<OutageRecord>& outages() const { return outages_; }
  // (t, robot, -1) of the deaths, those recorded and the outages never ended, in (t, robot)
  // order.
  std::vector<VisitRecord> final_deaths() const;
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
  const Points& positions() const { return pos_; }  // the last ones (absent robots: NaN rows)
  double worst_idleness(double end_s) const;

 private:
  void check_robot(int robot) const;
  void apply_pending(double t);
  void apply_visit(double vt, int v);
  void emit_row(double t, double x_mean);
  void emit_until(double t);  // the rows up to t without ground truth (X NaN)
  void advance_sample();
  void advance_field(double t0, double t1, const Points& p0, const Points& p1, bool finite);
  void step_field(double dt, const Points& pa, const Points& pb);
  void interference(double t0, double t1, const Points& p0, const Points& p1, double step);
  void interference_all(double t0, double t1, const Points& p0, const Points& p1);
  void enter_pair(std::uint64_t key, int i, int j, double t0, double t1, const Points& p0,
                  double d1x, double d1y);
  void keep_fresh();
  void rebuild_verlet(const Points& p, double reach);
  long long interferences_until(double t) const;

  RecorderConfig config_;
  int n_robots_, n_vertices_;
  double start_, period_, refractory_, max_substep_, field_merge_, dif2_, d_if_;
  UncertaintyField field_;  // targets, importance and growth law of the ground truth
  Eigen::VectorXd values_;  // ground-truth X_j
  // Targets bucketed by cells of one sensing radius (the coverage of a robot only looks at
  // the 3 x 3 cells around it); cell (cx, cy) -> targets, dense over the targets' box.
  double target_cell_ = 1, target_x0_ = 0, target_y0_ = 0;
  int target_nx_ = 1, target_ny_ = 1;
  std::vector<int> target_start_, target_index_;
  std::vector<double> target_xy_;  // x, y [m] of target_index_[k] at 2 k, 2 k + 1
  // The coverage at a substep's start, middle and end (zero but at the targets listed with
  // it: those within sensing range of a robot, repeats possible); recorder_field.cpp.
  Eigen::VectorXd cover_left_, cover_mid_, cover_right_;
  std::vector<int> touched_left_, touched_mid_, touched_right_;
  std::vector<int> covered_;           // the targets some robot covers during a substep
  std::vector<char> covered_mark_;     // per target: listed in covered_
  std::vector<double> covered_value_;  // their new X, in covered_'s order
  int uniform_importance_ = -1;        // every target's C is the same: 1, not: 0, unknown: -1
  Points cover_at_;
  void coverage(const Points& start, const Points& end, double fraction, Eigen::VectorXd& out,
                std::vector<int>& touched);
  void advance_linear(double dt, const Points& start, const Points& end);
  void gather_covered();
  Eigen::VectorXd peaks_, radii_;
  double field_t_ = 0;
  Points field_p_;
  bool has_field_p_ = false;
  bool field_finite_ = true;  // no robot absent at field_p_
  std::vector<char> alive_;
  bool all_alive_ = true;
  Points masked_;  // positions with the dead robots' rows NaN
  std::vector<VisitRecord> deaths_, stalls_, announcements_;
  std::vector<OutageRecord> outages_;
  struct Goal {
    double time_s;
    int vertex, from_vertex;
  };
  std::unordered_map<int, Goal> goals_;  // robot -> its latest goal
  long long dwells_ = 0;
  double dwell_time_s_ = 0;

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
  bool pos_finite_ = true;            // no NaN in pos_
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

}  // namespace tpuaf
