// The one ground-truth recorder (visits, samples, interference, X of Eq. 2-3, faults, dwells).
#include "tpuaf_core/recorder.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace tpuaf {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
// Python's max(a, b): a unless b > a (the same number for doubles without NaN).
inline double py_max(double a, double b) { return b > a ? b : a; }
}  // namespace

// --------------------------------------------------------------------- GroundTruthRecorder

RecorderConfig recorder_config(const EngineConfig& config) {
  RecorderConfig out;
  out.robots = config.robots;
  out.sample_period_s = config.sample_period_s;
  out.refractory_s = config.refractory_s;
  out.max_substep_s = config.max_substep_s;
  out.field_merge_s = config.field_merge_s;
  out.interference_distance_m = config.interference_distance_m;
  out.sensing_peak = config.sensing_peak;
  out.sensing_radius_m = config.sensing_radius_m;
  return out;
}

GroundTruthRecorder::GroundTruthRecorder(const RecorderConfig& config, UncertaintyField field)
    : config_(config),
      n_robots_(config.robots),
      n_vertices_(field.size()),
      start_(config.start_time_s),
      period_(config.sample_period_s),
      refractory_(config.refractory_s),
      max_substep_(config.max_substep_s),
      field_merge_(config.field_merge_s),
      dif2_(config.interference_distance_m * config.interference_distance_m),
      d_if_(config.interference_distance_m),
      field_(std::move(field)),
      values_(field_.values()),
      peaks_(Eigen::VectorXd::Constant(config.robots, config.sensing_peak)),
      radii_(Eigen::VectorXd::Constant(config.robots, config.sensing_radius_m)),
      field_t_(config.start_time_s),
      alive_(static_cast<std::size_t>(std::max(config.robots, 0)), 1),
      vertex_times_(static_cast<std::size_t>(n_vertices_)),
      sample_last_(Eigen::VectorXd::Constant(n_vertices_, config.start_time_s)),
      next_sample_(config.start_time_s + config.sample_period_s) {
  if (n_robots_ <= 0) {
    throw std::invalid_argument("need at least one robot, got " + std::to_string(n_robots_));
  }
  if (!(period_ > 0)) throw std::invalid_argument("sample period must be > 0 s");
  if (!(max_substep_ > 0)) throw std::invalid_argument("max_substep_s must be > 0 s");
  verlet_skin_ = std::max(2.0 * d_if_, 1e-3);  // [m]
  // Target cells of one sensing radius over the targets' bounding box.
  const auto& targets = field_.targets();
  if (n_vertices_ > 0) {
    target_x0_ = targets.col(0).minCoeff();
    target_y0_ = targets.col(1).minCoeff();
    const double width =
        std::max(targets.col(0).maxCoeff() - target_x0_, targets.col(1).maxCoeff() - target_y0_);
    target_cell_ = std::max(config.sensing_radius_m * (1.0 + 1e-9), width / 1024.0 + 1e-9);
    target_nx_ =
        static_cast<int>(std::floor((targets.col(0).maxCoeff() - target_x0_) / target_cell_)) + 1;
    target_ny_ =
        static_cast<int>(std::floor((targets.col(1).maxCoeff() - target_y0_) / target_cell_)) + 1;
  }
  std::vector<int> count(static_cast<std::size_t>(target_nx_) * target_ny_ + 1, 0);
  std::vector<int> cell_of(static_cast<std::size_t>(n_vertices_));
  for (int j = 0; j < n_vertices_; ++j) {
    const int cx = std::min(
        target_nx_ - 1, static_cast<int>(std::floor((targets(j, 0) - target_x0_) / target_cell_)));
    const int cy = std::min(
        target_ny_ - 1, static_cast<int>(std::floor((targets(j, 1) - target_y0_) / target_cell_)));
    cell_of[static_cast<std::size_t>(j)] = cx * target_ny_ + cy;
    ++count[static_cast<std::size_t>(cell_of[static_cast<std::size_t>(j)]) + 1];
  }
  for (std::size_t c = 1; c < count.size(); ++c) count[c] += count[c - 1];
  target_start_ = count;
  target_index_.assign(static_cast<std::size_t>(n_vertices_), 0);
  for (int j = 0; j < n_vertices_; ++j) {
    target_index_[static_cast<std::size_t>(
        count[static_cast<std::size_t>(cell_of[static_cast<std::size_t>(j)])]++)] = j;
  }
  target_xy_.resize(2 * target_index_.size());  // in cell order: a cell's targets side by side
  for (std::size_t k = 0; k < target_index_.size(); ++k) {
    target_xy_[2 * k] = targets(target_index_[k], 0);
    target_xy_[2 * k + 1] = targets(target_index_[k], 1);
  }
}

void GroundTruthRecorder::record_visit(int robot, int vertex, double time) {
  if (vertex < 0 || vertex >= n_vertices_) {
    throw std::out_of_range("vertex index " + std::to_string(vertex) + " out of range (map has " +
                            std::to_string(n_vertices_) + ")");
  }
  auto& times = vertex_times_[static_cast<std::size_t>(vertex)];
  double prev;
  if (times.empty() || time >= times.back()) {
    prev = times.empty() ? kNaN : times.back();
    times.push_back(time);
  } else {
    auto it = std::upper_bound(times.begin(), times.end(), time);
    prev = it == times.begin() ? kNaN : *(it - 1);
    times.insert(it, time);
  }
  visit_idleness_.push_back(time - prev);
  visits_.push_back({time, robot, vertex});
  if (time <= next_sample_ - period_) {  // its row is already out
    apply_visit(time, vertex);
  } else if (pending_.empty() || time >= pending_.back().first) {
    pending_.emplace_back(time, vertex);
  } else {
    auto it =
        std::upper_bound(pending_.begin(), pending_.end(), time,
                         [](double t, const std::pair<double, int>& p) { return t < p.first; });
    pending_.insert(it, {time, vertex});
  }
  if (!config_.ground_truth) emit_until(time);
}

void GroundTruthRecorder::emit_until(double t) {
  while (next_sample_ <= t + 1e-9) {
    emit_row(next_sample_, kNaN);
    advance_sample();
  }
}

void GroundTruthRecorder::advance_sample() {
  ++sample_k_;
  next_sample_ = start_ + static_cast<double>(sample_k_) * period_;
}

void GroundTruthRecorder::apply_pending(double t) {
  while (!pending_.empty() && pending_.front().first <= t) {
    const auto [vt, v] = pending_.front();
    pending_.pop_front();
    apply_visit(vt, v);
  }
}

void GroundTruthRecorder::apply_visit(double vt, int v) {
  sample_worst_ = py_max(sample_worst_, vt - sample_last_[v]);
  sample_last_[v] = py_max(sample_last_[v], vt);
  ++sample_visits_;
}

long long GroundTruthRecorder::interferences_until(double t) const {
  auto it =
      std::upper_bound(interferences_.begin(), interferences_.end(), t,
                       [](double time, const InterferenceRecord& r) { return time < r.time_s; });
  return static_cast<long long>(it - interferences_.begin());
}

void GroundTruthRecorder::emit_row(double t, double x_mean) {
  apply_pending(t);
  const double mean_last = numpy_mean(sample_last_.data(), static_cast<std::size_t>(n_vertices_));
  const double ins = t - mean_last;
  const double worst = py_max(sample_worst_, t - sample_last_.minCoeff());
  ins_sum_ += ins;
  if (!std::isnan(x_mean)) {
    x_sum_ += x_mean;
    ++x_count_;
  }
  rows_.push_back({t, ins, worst, x_mean, sample_visits_, interferences_until(t)});
}

void GroundTruthRecorder::check_robot(int robot) const {
  if (robot < 0 || robot >= n_robots_) {
    throw std::out_of_range("unknown robot " + std::to_string(robot) + " (team of " +
                            std::to_string(n_robots_) + ")");
  }
}

void GroundTruthRecorder::record_robot_death(int robot, double time_s) {
  check_robot(robot);
  if (!alive_[static_cast<std::size_t>(robot)]) return;
  alive_[static_cast<std::size_t>(robot)] = 0;
  all_alive_ = false;
  deaths_.push_back({time_s, robot, -1});
}

void GroundTruthRecorder::record_robot_outage(int robot, double time_s, const std::string& cause) {
  check_robot(robot);
  if (!alive_[static_cast<std::size_t>(robot)]) return;
  alive_[static_cast<std::size_t>(robot)] = 0;
  all_alive_ = false;
  outages_.push_back({robot, time_s, kNaN, false, cause});
}

void GroundTruthRecorder::record_robot_back(int robot, double time_s) {
  check_robot(robot);
  for (auto it = outages_.rbegin(); it != outages_.rend(); ++it) {
    if (it->robot != robot) continue;
    if (!it->ended && !alive_[static_cast<std::size_t>(robot)]) {
      it->ended = true;
      it->end_s = time_s;
      alive_[static_cast<std::size_t>(robot)] = 1;
      all_alive_ = std::all_of(alive_.begin(), alive_.end(), [](char a) { return a != 0; });
    }
    return;
  }
}

void GroundTruthRecorder::record_robot_stall(int robot, double time_s) {
  check_robot(robot);
  stalls_.push_back({time_s, robot, -1});
}

std::vector<VisitRecord> GroundTruthRecorder::final_deaths() const {
  std::vector<VisitRecord> out = deaths_;
  for (const OutageRecord& o : outages_) {
    if (!o.ended) out.push_back({o.start_s, o.robot, -1});
  }
  std::sort(out.begin(), out.end(), [](const VisitRecord& a, const VisitRecord& b) {
    if (a.time_s != b.time_s) return a.time_s < b.time_s;
    return a.robot < b.robot;
  });
  return out;
}

void GroundTruthRecorder::record_goal(int robot, int vertex, int from_vertex, double time_s) {
  goals_[robot] = {time_s, vertex, from_vertex};
}

void GroundTruthRecorder::record_dwell(int robot, int vertex, double time_s) {
  double stay_s = 0.0;
  auto it = goals_.find(robot);
  if (it != goals_.end() && it->second.vertex == vertex && it->second.from_vertex == vertex) {
    stay_s = py_max(time_s - it->second.time_s, 0.0);
  }
  count_dwell(stay_s);
}

void GroundTruthRecorder::record_positions(double t1, const Points& given) {
  if (given.rows() != n_robots_) throw std::invalid_argument("need one position per robot");
  // A dead robot's row is NaN (absent): it neither senses nor interferes.
  const Points* rows = &given;
  if (!all_alive_) {
    masked_ = given;
    for (int i = 0; i < n_robots_; ++i) {
      if (!alive_[static_cast<std::size_t>(i)]) masked_.row(i).setConstant(kNaN);
    }
    rows = &masked_;
  }
  const Points& p1 = *rows;
  const bool p1_finite = !p1.hasNaN();
  // No robot absent at either end of the interval.
  const bool finite = p1_finite && (!has_pos_ || pos_finite_);
  if (!has_pos_) {
    // Pairs already close at the start are not counted (they did not come close).
    close_.clear();
    for (int i = 0; i < n_robots_; ++i) {
      for (int j = i + 1; j < n_robots_; ++j) {
        const double dx = p1(i, 0) - p1(j, 0), dy = p1(i, 1) - p1(j, 1);
        if (dx * dx + dy * dy <= dif2_) {  // NaN compares false
          close_.push_back(static_cast<std::uint64_t>(i) * n_robots_ + j);
        }
      }
    }
  } else {
    const double t0 = pos_time_;
    if (t1 < t0) {
      throw std::invalid_argument("positions at " + std::to_string(t1) +
                                  " s are earlier than the previous ones (" + std::to_string(t0) +
                                  " s)");
    }
    if (n_robots_ > 1) {
      if (finite) {
        const double step = (p1 - pos_).cwiseAbs().maxCoeff();
        interference(t0, t1, pos_, p1, step);
      } else {
        interference_all(t0, t1, pos_, p1);
      }
    }
  }
  if (config_.ground_truth) {
    // The field advances over chunks of >= field_merge_s (the chord of the chunk), at every
    // sample time and whenever a robot is absent.
    if (!finite || next_sample_ <= t1 + 1e-9 || t1 - field_t_ >= field_merge_ || !has_field_p_) {
      const Points& from = has_field_p_ ? field_p_ : (has_pos_ ? pos_ : p1);
      advance_field(field_t_, t1, from, p1, finite && field_finite_);
      field_t_ = t1;
      field_p_ = p1;
      has_field_p_ = true;
      field_finite_ = finite;
    }
  } else if (next_sample_ <= t1 + 1e-9) {
    emit_until(t1);
  }
  pos_time_ = t1;
  pos_ = p1;
  pos_finite_ = p1_finite;
  has_pos_ = true;
}

void GroundTruthRecorder::enter_pair(std::uint64_t key, int i, int j, double t0, double t1,
                                     const Points& p0, double d1x, double d1y) {
  // Pair (i, j), d1 = p1_i - p1_j [m], moving linearly from t0 to t1 [s]: the exact time it
  // comes within d_if, counted when the refractory time has passed since its last entry.
  const double x0 = p0(i, 0) - p0(j, 0), y0 = p0(i, 1) - p0(j, 1);
  if (x0 != x0 || y0 != y0) return;  // absent at t0: appears now, not an entry
  const double vx = d1x - x0, vy = d1y - y0;
  const double a = vx * vx + vy * vy;
  const double b = x0 * vx + y0 * vy;  // half the linear coefficient
  const double c0 = x0 * x0 + y0 * y0;
  double s_in;
  if (c0 <= dif2_) {
    s_in = 0.0;
  } else {
    const double s_star = a > 0 ? std::min(py_max(-b / a, 0.0), 1.0) : 0.0;
    if (a * s_star * s_star + 2 * b * s_star + c0 > dif2_) return;  // never within d_if
    // smallest root of a s^2 + 2 b s + (c0 - d^2) = 0
    s_in = (-b - std::sqrt(py_max(b * b - a * (c0 - dif2_), 0.0))) / a;
  }
  const double t_in = t0 + std::min(py_max(s_in, 0.0), 1.0) * (t1 - t0);
  auto it = last_count_.find(key);
  const double last = it == last_count_.end() ? -kInf : it->second;
  if (t_in - last >= refractory_) {
    last_count_[key] = t_in;
    fresh_.push_back({t_in, i, j});
  }
}

void GroundTruthRecorder::keep_fresh() {
  // This interval's entries, in (time, a, b) order, after the earlier ones.
  if (fresh_.empty()) return;
  std::sort(fresh_.begin(), fresh_.end(),
            [](const InterferenceRecord& x, const InterferenceRecord& y) {
              if (x.time_s != y.time_s) return x.time_s < y.time_s;
              if (x.a != y.a) return x.a < y.a;
              return x.b < y.b;
            });
  interferences_.insert(interferences_.end(), fresh_.begin(), fresh_.end());
}

void GroundTruthRecorder::interference_all(double t0, double t1, const Points& p0,
                                           const Points& p1) {
  // RunRecorder._interference when a robot is absent: every pair of live robots is a
  // candidate (reach = inf), with the same arithmetic as interference().
  const int n = n_robots_;
  const std::uint64_t un = static_cast<std::uint64_t>(n);
  close_end_.clear();
  fresh_.clear();
  for (int i = 0; i < n; ++i) {
    if (std::isnan(p1(i, 0)) || std::isnan(p1(i, 1))) continue;
    for (int j = i + 1; j < n; ++j) {
      const double d1x = p1(i, 0) - p1(j, 0), d1y = p1(i, 1) - p1(j, 1);
      const double c1 = d1x * d1x + d1y * d1y;
      if (!(c1 <= kInf)) continue;  // an absent robot (NaN) is never near
      const std::uint64_t key = static_cast<std::uint64_t>(i) * un + j;
      if (c1 <= dif2_) close_end_.push_back(key);
      if (std::binary_search(close_.begin(), close_.end(), key)) continue;
      enter_pair(key, i, j, t0, t1, p0, d1x, d1y);
    }
  }
  keep_fresh();
  close_.swap(close_end_);  // keys ascending
  verlet_valid_ = false;
}

void GroundTruthRecorder::interference(double t0, double t1, const Points& p0, const Points& p1,
                                       double step) {
  // Exact episode entries for linear motion p0 (t0) -> p1 (t1), as RunRecorder._interference.
  // Candidate pairs come from a Verlet list (pairs within reach + skin when it was built, found
  // through a spatial hash): a pair outside it stays farther than d_if until some robot has
  // moved skin / 2 from where the list was built, which rebuilds it. So every pair that can
  // come within d_if is examined, with the same arithmetic as the all-pairs Python code.
  const double reach = d_if_ + 2.8285 * step;
  const double reach2 = reach * reach;
  const int n = n_robots_;
  bool valid = verlet_valid_;
  if (valid) {
    for (int i = 0; i < n && valid; ++i) {
      const double dx = p1(i, 0) - verlet_ref_(i, 0), dy = p1(i, 1) - verlet_ref_(i, 1);
      valid = dx * dx + dy * dy <= verlet_half_skin2_;
    }
  }
  if (!valid) rebuild_verlet(p1, reach);
  close_end_.clear();
  fresh_.clear();
  const std::uint64_t un = static_cast<std::uint64_t>(n);
  for (const std::uint64_t key : verlet_pairs_) {
    const int i = static_cast<int>(key / un), j = static_cast<int>(key % un);
    const double d1x = p1(i, 0) - p1(j, 0), d1y = p1(i, 1) - p1(j, 1);
    const double c1 = d1x * d1x + d1y * d1y;
    if (!(c1 <= reach2)) continue;  // not near
    if (c1 <= dif2_) close_end_.push_back(key);
    // A pair close at both ends is close throughout; it enters at most once per interval.
    if (std::binary_search(close_.begin(), close_.end(), key)) continue;
    enter_pair(key, i, j, t0, t1, p0, d1x, d1y);
  }
  keep_fresh();
  close_.swap(close_end_);  // sorted: the Verlet list is
}

void GroundTruthRecorder::rebuild_verlet(const Points& p, double reach) {
  const int n = n_robots_;
  const double skin = verlet_skin_;
  const double radius = (reach + skin) * (1.0 + 1e-9);
  const double radius2 = radius * radius;
  double extent = 1.0;
  for (int i = 0; i < n; ++i) extent = std::max({extent, std::abs(p(i, 0)), std::abs(p(i, 1))});
  const double cell = std::max(radius, extent * 1e-6);
  // Spatial hash: robots sorted by cell; each robot looks at its own and the 8 cells around.
  cells_.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const auto cx = static_cast<std::int64_t>(std::floor(p(i, 0) / cell));
    const auto cy = static_cast<std::int64_t>(std::floor(p(i, 1) / cell));
    cells_[static_cast<std::size_t>(i)] = {cx * kCellStride + cy, i};
  }
  sorted_cells_ = cells_;
  std::sort(sorted_cells_.begin(), sorted_cells_.end());
  verlet_pairs_.clear();
  const std::uint64_t un = static_cast<std::uint64_t>(n);
  for (int i = 0; i < n; ++i) {
    const std::int64_t key = cells_[static_cast<std::size_t>(i)].first;
    for (std::int64_t dx = -1; dx <= 1; ++dx) {
      for (std::int64_t dy = -1; dy <= 1; ++dy) {
        const std::int64_t neighbour = key + dx * kCellStride + dy;
        auto it = std::lower_bound(sorted_cells_.begin(), sorted_cells_.end(),
                                   std::make_pair(neighbour, -1));
        for (; it != sorted_cells_.end() && it->first == neighbour; ++it) {
          const int j = it->second;
          if (j <= i) continue;
          const double ex = p(i, 0) - p(j, 0), ey = p(i, 1) - p(j, 1);
          if (ex * ex + ey * ey <= radius2)
            verlet_pairs_.push_back(static_cast<std::uint64_t>(i) * un + j);
        }
      }
    }
  }
  std::sort(verlet_pairs_.begin(), verlet_pairs_.end());
  verlet_ref_ = p;
  const double half = 0.5 * skin * (1.0 - 1e-6);
  verlet_half_skin2_ = half * half;
  verlet_valid_ = true;
}

void GroundTruthRecorder::advance_field(double t0, double t1, const Points& p0_all,
                                        const Points& p1_all, bool finite) {
  // Not finite: only the robots present at both ends sense (RunRecorder._advance_field).
  Points live0, live1;
  if (!finite) {
    std::vector<Eigen::Index> live;
    for (Eigen::Index i = 0; i < p0_all.rows(); ++i) {
      if (!std::isnan(p0_all(i, 0)) && !std::isnan(p1_all(i, 0))) live.push_back(i);
    }
    live0.resize(static_cast<Eigen::Index>(live.size()), 2);
    live1.resize(static_cast<Eigen::Index>(live.size()), 2);
    for (std::size_t k = 0; k < live.size(); ++k) {
      live0.row(static_cast<Eigen::Index>(k)) = p0_all.row(live[k]);
      live1.row(static_cast<Eigen::Index>(k)) = p1_all.row(live[k]);
    }
  }
  const Points& p0 = finite ? p0_all : live0;
  const Points& p1 = finite ? p1_all : live1;
  double ta = t0;
  Points pa = p0;
  const double span = t1 - t0;
  while (next_sample_ <= t1 + 1e-9) {
    const double ts = next_sample_;
    Points pb = span > 0 ? Points(p0 + (p1 - p0) * ((ts - t0) / span)) : p1;
    step_field(ts - ta, pa, pb);
    emit_row(ts, numpy_mean(values_.data(), static_cast<std::size_t>(n_vertices_)));
    advance_sample();
    ta = ts;
    pa = pb;
  }
  if (t1 > ta) step_field(t1 - ta, pa, p1);
}

void GroundTruthRecorder::step_field(double dt, const Points& pa, const Points& pb) {
  if (dt <= 0) return;
  if (pa.rows() == 0) {  // UncertaintyField::advance_uncovered: no coverage, one step
    const UncertaintyModel& model = field_.model();
    const Eigen::VectorXd& importance = field_.importance();
    for (Eigen::Index j = 0; j < values_.size(); ++j) {
      values_[j] = model.evolve(values_[j], importance[j] - 0.0, dt);
    }
    return;
  }
  advance_linear(dt, pa, pb);
}

double GroundTruthRecorder::worst_idleness(double end_s) const {
  double worst = 0.0;
  for (const auto& times : vertex_times_) {
    double prev = start_;
    for (double t : times) {
      worst = py_max(worst, t - prev);
      prev = t;
    }
    worst = py_max(worst, end_s - prev);
  }
  return worst;
}

void GroundTruthRecorder::finish(double end_s) {
  if (!config_.ground_truth) {
    emit_until(end_s);
  } else if (!has_pos_) {  // no positions ever: no robot covered anything
    const Points absent = Points::Constant(n_robots_, 2, kNaN);
    record_positions(end_s, absent);
  } else if (end_s > pos_time_) {
    const Points held = pos_;
    record_positions(end_s, held);
  }
  flush_field();
}

void GroundTruthRecorder::flush_field() {
  if (config_.ground_truth && has_pos_ && field_t_ < pos_time_) {  // a merged chunk pending
    const bool finite = field_finite_ && pos_finite_;
    advance_field(field_t_, pos_time_, field_p_, pos_, finite);
    field_t_ = pos_time_;
    field_p_ = pos_;
    field_finite_ = finite;
  }
}

}  // namespace tpuaf
