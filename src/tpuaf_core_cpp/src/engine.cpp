#include "tpuaf_core/engine.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace tpuaf {

namespace {
// Event kinds, in the order ties resolve (tpuaf.runtimes.graph).
constexpr int kArrive = 0, kWake = 1, kDeliver = 2, kFault = 3, kGiveUp = 4, kLiveness = 5;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
// Python's max(a, b): a unless b > a (the same number for doubles without NaN).
inline double py_max(double a, double b) { return b > a ? b : a; }
}  // namespace

// ------------------------------------------------------------------------------ NumpyPcg64

NumpyPcg64::NumpyPcg64(std::uint64_t state_hi, std::uint64_t state_lo, std::uint64_t inc_hi,
                       std::uint64_t inc_lo, bool has_uint32, std::uint32_t uinteger)
    : state_((static_cast<unsigned __int128>(state_hi) << 64) | state_lo),
      inc_((static_cast<unsigned __int128>(inc_hi) << 64) | inc_lo),
      has_uint32_(has_uint32),
      uinteger_(uinteger) {}

std::uint64_t NumpyPcg64::next_uint64() {
  // PCG XSL-RR 128/64 (numpy's PCG64): advance the LCG, then output from the new state.
  const unsigned __int128 mult =
      (static_cast<unsigned __int128>(0x2360ED051FC65DA4ULL) << 64) | 0x4385DF649FCCF645ULL;
  state_ = state_ * mult + inc_;
  const std::uint64_t hi = static_cast<std::uint64_t>(state_ >> 64);
  const std::uint64_t lo = static_cast<std::uint64_t>(state_);
  const std::uint64_t x = hi ^ lo;
  const unsigned rot = static_cast<unsigned>(hi >> 58);
  return (x >> rot) | (x << ((64u - rot) & 63u));
}

std::uint32_t NumpyPcg64::next_uint32() {
  if (has_uint32_) {
    has_uint32_ = false;
    return uinteger_;
  }
  const std::uint64_t next = next_uint64();
  has_uint32_ = true;
  uinteger_ = static_cast<std::uint32_t>(next >> 32);
  return static_cast<std::uint32_t>(next & 0xffffffffULL);
}

double NumpyPcg64::random() {
  return static_cast<double>(next_uint64() >> 11) * (1.0 / 9007199254740992.0);
}

std::int64_t NumpyPcg64::integers(std::int64_t n) {
  if (n < 1 || n > (std::int64_t{1} << 32)) {
    throw std::invalid_argument("integers(0, n) needs 1 <= n <= 2^32, got " + std::to_string(n));
  }
  const std::uint64_t rng = static_cast<std::uint64_t>(n - 1);
  if (rng == 0) return 0;
  if (rng == 0xffffffffULL) return next_uint32();
  // numpy's buffered_bounded_lemire_uint32
  const std::uint32_t rng_excl = static_cast<std::uint32_t>(rng) + 1u;
  std::uint64_t m = static_cast<std::uint64_t>(next_uint32()) * rng_excl;
  std::uint32_t leftover = static_cast<std::uint32_t>(m & 0xffffffffULL);
  if (leftover < rng_excl) {
    const std::uint32_t threshold =
        (std::numeric_limits<std::uint32_t>::max() - static_cast<std::uint32_t>(rng)) % rng_excl;
    while (leftover < threshold) {
      m = static_cast<std::uint64_t>(next_uint32()) * rng_excl;
      leftover = static_cast<std::uint32_t>(m & 0xffffffffULL);
    }
  }
  return static_cast<std::int64_t>(m >> 32);
}

void NumpyPcg64::get_state(std::uint64_t& state_hi, std::uint64_t& state_lo, std::uint64_t& inc_hi,
                           std::uint64_t& inc_lo, bool& has_uint32, std::uint32_t& uinteger) const {
  state_hi = static_cast<std::uint64_t>(state_ >> 64);
  state_lo = static_cast<std::uint64_t>(state_);
  inc_hi = static_cast<std::uint64_t>(inc_ >> 64);
  inc_lo = static_cast<std::uint64_t>(inc_);
  has_uint32 = has_uint32_;
  uinteger = uinteger_;
}

double numpy_pairwise_sum(const double* a, std::size_t n) {
  // numpy's DOUBLE_pairwise_sum: 8 accumulators up to 128 elements, halves above.
  if (n < 8) {
    double res = 0.;
    for (std::size_t i = 0; i < n; ++i) res += a[i];
    return res;
  }
  if (n <= 128) {
    double r[8];
    for (int j = 0; j < 8; ++j) r[j] = a[j];
    std::size_t i = 8;
    for (; i < n - (n % 8); i += 8) {
      for (int j = 0; j < 8; ++j) r[j] += a[i + j];
    }
    double res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
    for (; i < n; ++i) res += a[i];
    return res;
  }
  std::size_t n2 = n / 2;
  n2 -= n2 % 8;
  return numpy_pairwise_sum(a, n2) + numpy_pairwise_sum(a + n2, n - n2);
}

double numpy_sum(const double* a, std::size_t n) {
  constexpr std::size_t kBuffer = 8192;  // numpy's default ufunc buffer size
  double res = 0.0;
  for (std::size_t i = 0; i < n; i += kBuffer)
    res += numpy_pairwise_sum(a + i, std::min(kBuffer, n - i));
  return res;
}

// --------------------------------------------------------------------- GroundTruthRecorder

GroundTruthRecorder::GroundTruthRecorder(const EngineConfig& config, UncertaintyField field)
    : n_robots_(config.robots),
      n_vertices_(field.size()),
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
      vertex_times_(static_cast<std::size_t>(n_vertices_)),
      sample_last_(Eigen::VectorXd::Zero(n_vertices_)),
      next_sample_(0.0 + config.sample_period_s) {
  if (!(period_ > 0)) throw std::invalid_argument("sample period must be > 0 s");
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

void GroundTruthRecorder::record_robot_death(int robot, double time_s) {
  if (robot < 0 || robot >= n_robots_) {
    throw std::out_of_range("unknown robot " + std::to_string(robot));
  }
  if (alive_.empty()) alive_.assign(static_cast<std::size_t>(n_robots_), 1);
  if (!alive_[static_cast<std::size_t>(robot)]) return;
  alive_[static_cast<std::size_t>(robot)] = 0;
  all_alive_ = false;
  deaths_.push_back({time_s, robot, -1});
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
  // No NaN in p1 (nor in the previous positions: deaths are for good) while all are alive.
  const bool finite = all_alive_;
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
    if (!finite || next_sample_ <= t1 + 1e-9 || t1 - field_t_ >= field_merge_ || !has_field_p_) {
      advance_field(field_t_, t1, p1, p1, finite && field_finite_);
      field_t_ = t1;
      field_p_ = p1;
      has_field_p_ = true;
      field_finite_ = finite;
    }
  } else {
    const double t0 = pos_time_;
    if (t1 < t0) {
      throw std::invalid_argument("positions at " + std::to_string(t1) +
                                  " s are earlier than the previous ones");
    }
    if (n_robots_ > 1) {
      if (finite) {
        const double step = (p1 - pos_).cwiseAbs().maxCoeff();
        interference(t0, t1, pos_, p1, step);
      } else {
        interference_all(t0, t1, pos_, p1);
      }
    }
    // The field advances over chunks of >= field_merge_s, at every sample time and whenever a
    // robot is absent.
    if (!finite || next_sample_ <= t1 + 1e-9 || t1 - field_t_ >= field_merge_ || !has_field_p_) {
      advance_field(field_t_, t1, has_field_p_ ? field_p_ : pos_, p1, finite && field_finite_);
      field_t_ = t1;
      field_p_ = p1;
      has_field_p_ = true;
      field_finite_ = finite;
    }
  }
  pos_time_ = t1;
  pos_ = p1;
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
    ++sample_k_;
    next_sample_ = 0.0 + static_cast<double>(sample_k_) * period_;
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

void GroundTruthRecorder::coverage(const Points& start, const Points& end, double fraction,
                                   Eigen::VectorXd& out) {
  // total_perception (Eq. 1 summed over robots) at start + fraction (end - start), robot by
  // robot in index order as there, over the targets within one cell of the robot only.
  cover_at_ = start + fraction * (end - start);
  out.setZero(n_vertices_);
  const auto& targets = field_.targets();
  for (Eigen::Index i = 0; i < cover_at_.rows(); ++i) {
    const double r2 = radii_[i] * radii_[i];
    const double scale = peaks_[i] / (r2 * r2);
    const double qx = cover_at_(i, 0), qy = cover_at_(i, 1);
    const double fx = std::floor((qx - target_x0_) / target_cell_);
    const double fy = std::floor((qy - target_y0_) / target_cell_);
    if (!(fx >= -1 && fx <= target_nx_ && fy >= -1 && fy <= target_ny_)) continue;  // far away
    const int cx = static_cast<int>(fx), cy = static_cast<int>(fy);
    for (int gx = std::max(cx - 1, 0); gx <= std::min(cx + 1, target_nx_ - 1); ++gx) {
      for (int gy = std::max(cy - 1, 0); gy <= std::min(cy + 1, target_ny_ - 1); ++gy) {
        const int c = gx * target_ny_ + gy;
        for (int k = target_start_[c]; k < target_start_[c + 1]; ++k) {
          const int j = target_index_[k];
          const double dx = targets(j, 0) - qx;
          const double dy = targets(j, 1) - qy;
          const double s2 = dx * dx + dy * dy;
          if (s2 <= r2) {
            const double d = s2 - r2;
            out[j] += scale * d * d;
          }
        }
      }
    }
  }
}

void GroundTruthRecorder::advance_linear(double dt, const Points& start, const Points& end) {
  // UncertaintyField::advance_linear, step for step (Simpson's rule per substep, exact
  // constant-coverage solution), with the coverage through the target cells.
  const int steps = std::max(1, static_cast<int>(std::ceil(dt / max_substep_)));
  const double h = dt / steps;
  const UncertaintyModel& model = field_.model();
  const Eigen::VectorXd& importance = field_.importance();
  const bool affine = model.is_affine();
  const double a0 = model.growth_coefficients[0];
  const double a1 = model.growth_coefficients.size() > 1 ? model.growth_coefficients[1] : 0.0;
  coverage(start, end, 0.0, cover_left_);
  for (int k = 0; k < steps; ++k) {
    coverage(start, end, (k + 0.5) / steps, cover_mid_);
    coverage(start, end, (k + 1.0) / steps, cover_right_);
    // One exp pair per distinct rate: the uncovered targets of a uniform map share theirs.
    double cached_rate = kNaN, growth = 0, offset = 0;
    bool saturated = false;
    for (Eigen::Index j = 0; j < values_.size(); ++j) {
      const double mean = (cover_left_[j] + 4.0 * cover_mid_[j] + cover_right_[j]) / 6.0;
      const double rate = importance[j] - mean;
      if (!affine || !(h > 0)) {
        values_[j] = model.evolve(values_[j], rate, h);
        continue;
      }
      if (!(rate == cached_rate)) {  // UncertaintyModel::evolve, affine branch
        cached_rate = rate;
        const double z = a1 * rate * h;
        saturated = z > 700;
        if (!saturated) {
          growth = std::exp(z);
          const double ratio = std::abs(z) < 1e-12 ? 1.0 + 0.5 * z : std::expm1(z) / z;
          offset = a0 * rate * h * ratio;
        }
      }
      if (saturated) {
        values_[j] = model.max_value;
        continue;
      }
      const double x = values_[j] * growth + offset;
      values_[j] = !(x > 0) ? 0.0 : std::min(x, model.max_value);
    }
    cover_left_.swap(cover_right_);
  }
}

double GroundTruthRecorder::worst_idleness(double end_s) const {
  double worst = 0.0;
  for (const auto& times : vertex_times_) {
    double prev = 0.0;
    for (double t : times) {
      worst = py_max(worst, t - prev);
      prev = t;
    }
    worst = py_max(worst, end_s - prev);
  }
  return worst;
}

void GroundTruthRecorder::finish(double end_s) {
  if (has_pos_ && end_s > pos_time_) {
    const Points held = pos_;
    record_positions(end_s, held);
  }
  if (has_pos_ && field_t_ < pos_time_) {  // a merged chunk still pending
    const bool finite = field_finite_ && all_alive_;
    advance_field(field_t_, pos_time_, field_p_, pos_, finite);
    field_t_ = pos_time_;
    field_p_ = pos_;
    field_finite_ = finite;
  }
}

// -------------------------------------------------------------------------- HeartbeatLinks

HeartbeatLinks::HeartbeatLinks(int robots, double duration_s, double timeout_s, double delay_s,
                               double loss, double period_s, std::vector<NumpyPcg64> rngs)
    : n_(robots),
      period_s_(period_s),
      delay_s_(delay_s),
      timeout_s_(timeout_s),
      loss_(loss),
      rngs_(std::move(rngs)) {
  if (!(period_s > 0) || !std::isfinite(period_s)) {
    throw std::invalid_argument("heartbeat period must be a finite number > 0 s");
  }
  if (!(timeout_s > 0)) throw std::invalid_argument("teammate timeout must be > 0 s");
  if (!(loss >= 0 && loss <= 1)) {
    throw std::invalid_argument("heartbeat loss probability must be in [0, 1]");
  }
  if (loss > 0 && static_cast<int>(rngs_.size()) != robots) {
    throw std::invalid_argument("heartbeats with loss need one random stream per robot");
  }
  count_ = static_cast<std::int64_t>(std::floor(duration_s / period_s + 1e-9)) + 1;
  if (count_ > std::numeric_limits<std::int32_t>::max()) {
    throw std::invalid_argument("too many heartbeats in the run");
  }
  last_sent_.assign(static_cast<std::size_t>(n_), count_ - 1);
  links_.resize(static_cast<std::size_t>(n_));
}

void HeartbeatLinks::silences_of(Link& l) const {
  l.silences.clear();
  for (std::size_t p = 0; p + 1 < l.received.size(); ++p) {
    if (arrival(l.received[p + 1]) > arrival(l.received[p]) + timeout_s_) {
      l.silences.push_back(static_cast<std::int32_t>(p));
    }
  }
}

const HeartbeatLinks::Link& HeartbeatLinks::link(int recipient, int sender) {
  if (loss_ == 0) {  // every heartbeat heard: one link for all
    if (every_.received.empty()) {
      every_.received.resize(static_cast<std::size_t>(count_));
      for (std::int64_t k = 0; k < count_; ++k) {
        every_.received[static_cast<std::size_t>(k)] = static_cast<std::int32_t>(k);
      }
      silences_of(every_);
    }
    return every_;
  }
  auto& of_sender = links_[static_cast<std::size_t>(sender)];
  if (of_sender.empty()) {
    // numpy: rng.random((n, count)) >= loss, row = recipient.
    of_sender.resize(static_cast<std::size_t>(n_));
    NumpyPcg64& rng = rngs_[static_cast<std::size_t>(sender)];
    for (auto& l : of_sender) {
      for (std::int64_t k = 0; k < count_; ++k) {
        if (rng.random() >= loss_) l.received.push_back(static_cast<std::int32_t>(k));
      }
      silences_of(l);
    }
  }
  return of_sender[static_cast<std::size_t>(recipient)];
}

void HeartbeatLinks::died(int robot, double t) {
  auto k = static_cast<std::int64_t>(std::floor(t / period_s_ + 1e-9));
  if (static_cast<double>(k) * period_s_ > t) --k;
  auto& last = last_sent_[static_cast<std::size_t>(robot)];
  last = std::min(last, k);
}

std::int64_t HeartbeatLinks::heard_by(const Link& l, int sender, double t) const {
  const std::int64_t k =
      std::min(last_sent_[static_cast<std::size_t>(sender)],
               static_cast<std::int64_t>(std::floor((t - delay_s_) / period_s_ + 1e-9)));
  auto it = std::upper_bound(l.received.begin(), l.received.end(), k,
                             [](std::int64_t v, std::int32_t r) { return v < r; });
  std::int64_t pos = (it - l.received.begin()) - 1;
  if (pos >= 0 && arrival(l.received[static_cast<std::size_t>(pos)]) > t) --pos;  // rounding
  return pos;
}

double HeartbeatLinks::last_arrival_s(int recipient, int sender, double t) {
  if (recipient == sender) return -kInf;
  const Link& l = link(recipient, sender);
  const std::int64_t pos = heard_by(l, sender, t);
  return pos >= 0 ? arrival(l.received[static_cast<std::size_t>(pos)]) : -kInf;
}

double HeartbeatLinks::next_check_s(int recipient, int sender, double last_heard, bool lost,
                                    double now) {
  if (recipient == sender) return kInf;
  const Link& l = link(recipient, sender);
  const std::int64_t pos = heard_by(l, sender, now);
  const std::int64_t sent = last_sent_[static_cast<std::size_t>(sender)];
  auto it = std::upper_bound(l.received.begin(), l.received.end(), sent,
                             [](std::int64_t v, std::int32_t r) { return v < r; });
  const std::int64_t last = (it - l.received.begin()) - 1;
  const std::int64_t nxt = pos + 1 <= last ? pos + 1 : -1;  // the next heartbeat heard, if any
  auto at = [&](std::int64_t p) { return arrival(l.received[static_cast<std::size_t>(p)]); };
  if (lost) return nxt >= 0 ? at(nxt) : kInf;  // back at the next heartbeat heard
  if (std::isfinite(last_heard)) {
    const double due = last_heard + timeout_s_;
    if (nxt < 0 || at(nxt) > due) return due;  // silent from last_heard on
  } else if (nxt < 0) {
    return kInf;  // never heard, and never will be
  }
  // The first silence after the next heartbeat, or the sender's last heartbeat.
  auto s = std::lower_bound(l.silences.begin(), l.silences.end(), nxt,
                            [](std::int32_t v, std::int64_t x) { return v < x; });
  const std::int64_t end = s != l.silences.end() && *s < last ? *s : last;
  return at(end) + timeout_s_;
}

// ----------------------------------------------------------------------------- GraphEngine

GraphEngine::GraphEngine(const PatrolGraph& graph, Points positions, EngineConfig config,
                         UncertaintyField field, NumpyPcg64 bus_rng)
    : graph_(graph),
      positions_(std::move(positions)),
      config_(std::move(config)),
      recorder_(config_, std::move(field)),
      bus_rng_(bus_rng) {
  const int n = config_.robots;
  if (n < 1) throw std::invalid_argument("need at least one robot");
  if (positions_.rows() != graph_.num_vertices()) {
    throw std::invalid_argument("need one position per graph vertex");
  }
  if (static_cast<int>(config_.start_vertices.size()) != n) {
    throw std::invalid_argument("need one start vertex per robot");
  }
  if (!(config_.delay_s >= 0) || !std::isfinite(config_.delay_s)) {
    throw std::invalid_argument("message delay must be a finite number >= 0 s");
  }
  if (!(config_.loss >= 0 && config_.loss <= 1)) {
    throw std::invalid_argument("message loss probability must be in [0, 1]");
  }
  if (!(config_.nominal_speed_mps > 0)) throw std::invalid_argument("nominal speed must be > 0");
  robots_.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    Robot& r = robots_[static_cast<std::size_t>(i)];
    const int v = config_.start_vertices[static_cast<std::size_t>(i)];
    graph_.check_vertex(v);
    r.current = r.start = v;
    r.p0x = positions_(v, 0);
    r.p0y = positions_(v, 1);
  }
  scratch_.resize(n, 2);
}

const GraphEngine::Robot& GraphEngine::robot_at(int robot) const {
  if (robot < 0 || robot >= config_.robots) {
    throw std::out_of_range("unknown robot " + std::to_string(robot) + " (team of " +
                            std::to_string(config_.robots) + ")");
  }
  return robots_[static_cast<std::size_t>(robot)];
}

double GraphEngine::average_speed(int robot) const {
  const Robot& r = robot_at(robot);
  if (r.travel_time_s > 1.0 && r.travelled_m > 0) return r.travelled_m / r.travel_time_s;
  return config_.nominal_speed_mps;
}

void GraphEngine::position(int robot, double t, double& x, double& y) const {
  const Robot& r = robot_at(robot);
  const double elapsed = std::min(py_max(t - r.t0, 0.0), r.t1 - r.t0);
  x = r.p0x + r.vx * elapsed;
  y = r.p0y + r.vy * elapsed;
}

void GraphEngine::positions(double t, Points& out) const {
  for (std::size_t i = 0; i < robots_.size(); ++i) {
    const Robot& r = robots_[i];
    // numpy: minimum(maximum(t - t0, 0), t1 - t0), then p0 + v * elapsed
    double elapsed = t - r.t0;
    if (!(elapsed >= 0.0)) elapsed = 0.0;
    const double span = r.t1 - r.t0;
    if (!(elapsed <= span)) elapsed = span;
    out(static_cast<Eigen::Index>(i), 0) = r.p0x + r.vx * elapsed;
    out(static_cast<Eigen::Index>(i), 1) = r.p0y + r.vy * elapsed;
  }
}

std::uint64_t GraphEngine::push(double time, int kind, int payload) {
  ++seq_;
  events_queue_.push({time, kind, seq_, payload});
  return seq_;
}

void GraphEngine::set_faults(std::vector<EngineFault> faults,
                             std::vector<NumpyPcg64> heartbeat_rngs) {
  const int n = config_.robots;
  for (std::size_t k = 0; k < faults.size(); ++k) {
    const EngineFault& f = faults[k];
    robot_at(f.robot);
    if (!(f.time_s >= 0) || !std::isfinite(f.time_s)) {
      throw std::invalid_argument("a fault time must be a finite number >= 0 s");
    }
    if (k > 0 && f.time_s < faults[k - 1].time_s) {
      throw std::invalid_argument("faults must be in time order");
    }
  }
  if (!(config_.stall_give_up_s > 0)) throw std::invalid_argument("stall give-up must be > 0 s");
  faults_ = std::move(faults);
  links_.reset();
  if (faults_.empty()) return;
  links_ = std::make_unique<HeartbeatLinks>(n, config_.duration_s, config_.teammate_timeout_s,
                                            config_.delay_s, config_.loss,
                                            config_.heartbeat_period_s, std::move(heartbeat_rngs));
  for (Robot& r : robots_) {
    r.last_heard.assign(static_cast<std::size_t>(n), -kInf);
    r.lost.assign(static_cast<std::size_t>(n), 0);
  }
  lost_by_.assign(static_cast<std::size_t>(n), 0);
}

void GraphEngine::send(int robot, TeamMessage message) {
  const bool faults = !faults_.empty();
  if (faults) {
    if (!robot_at(robot).alive) return;  // a dead robot sends nothing
    // The destination announced (RobotMachine.send: on_announce), for the recovery metrics.
    int announced = message.announced;
    if (message.kind == TeamMessage::Kind::kIntention) {
      announced = message.vertex;
    } else if (message.kind != TeamMessage::Kind::kOpaque) {
      announced = message.next_vertex;
    }
    if (announced >= 0) recorder_.record_announcement(robot, announced, now_);
  } else {
    robot_at(robot);
  }
  const int n = config_.robots;
  ++bus_.sent;
  Delivery d;
  d.message = std::move(message);
  d.sender = robot;
  if (faults) {
    // TeamBus.recipients: the live robots but the sender; one loss draw per robot (all n).
    for (int i = 0; i < n; ++i) {
      const bool lost = config_.loss > 0 && bus_rng_.random() < config_.loss;
      if (i == robot || !robots_[static_cast<std::size_t>(i)].alive) continue;
      if (lost) {
        ++bus_.lost;
      } else {
        d.recipients.push_back(i);
      }
    }
  } else if (config_.loss > 0) {
    // numpy: lost = rng.random(n) < loss, one draw per robot (the sender's too).
    for (int i = 0; i < n; ++i) {
      const bool lost = bus_rng_.random() < config_.loss;
      if (i == robot) continue;
      if (lost) {
        ++bus_.lost;
      } else {
        d.recipients.push_back(i);
      }
    }
  } else {
    d.all_but_sender = true;
  }
  const bool empty = d.all_but_sender ? n <= 1 : d.recipients.empty();
  if (empty) return;
  if (config_.delay_s == 0) {
    ready_.push_back(std::move(d));
  } else {
    int slot;
    if (!free_slots_.empty()) {
      slot = free_slots_.back();
      free_slots_.pop_back();
      slots_[static_cast<std::size_t>(slot)] = std::move(d);
    } else {
      slot = static_cast<int>(slots_.size());
      slots_.push_back(std::move(d));
    }
    push(now_ + config_.delay_s, kDeliver, slot);
  }
}

void GraphEngine::wake_at(int robot, double time_s) {
  Robot& r = const_cast<Robot&>(robot_at(robot));
  push(py_max(time_s, now_), kWake, robot);
  r.wake_pending = true;
}

void GraphEngine::change_goal(int robot, int vertex) {
  Robot& r = const_cast<Robot&>(robot_at(robot));
  graph_.check_vertex(vertex);
  r.redirect = vertex;
}

void GraphEngine::deliver_batch_by_robot() {
  // The ready deliveries, robot by robot; each robot gets them in their order (the strategy's
  // messages_are_local() makes this the same as delivery by delivery).
  batch_.clear();
  while (!ready_.empty()) {
    batch_.push_back(std::move(ready_.front()));
    ready_.pop_front();
  }
  batch_cursor_.assign(batch_.size(), 0);
  const int n = config_.robots;
  const bool faults = !faults_.empty();
  for (int r = 0; r < n; ++r) {
    for (std::size_t k = 0; k < batch_.size(); ++k) {
      Delivery& d = batch_[k];
      if (d.all_but_sender) {
        if (r != d.sender) strategy_->on_message(*this, r, d.message);
      } else {
        std::size_t& c = batch_cursor_[k];
        if (c < d.recipients.size() && d.recipients[c] == r) {  // recipients are ascending
          ++c;
          if (faults) {  // deliver_heard's steps (hear cannot bring a teammate back here)
            if (!robots_[static_cast<std::size_t>(r)].alive) continue;
            hear(r, d.message.robot, now_);
            ++bus_.delivered;
          }
          strategy_->on_message(*this, r, d.message);
        }
      }
    }
  }
  for (const Delivery& d : batch_) {
    if (faults) break;  // counted per live recipient above
    bus_.delivered += d.all_but_sender ? n - 1 : static_cast<long long>(d.recipients.size());
  }
  batch_.clear();
}

void GraphEngine::deliver_heard() {
  // TeamRun._deliver_heard: message by message, each live recipient first hears its sender
  // (liveness; a teammate back from lost moves its checks), then gets the message.
  while (!ready_.empty()) {
    Delivery d = std::move(ready_.front());
    ready_.pop_front();
    const int sender = d.message.robot;
    for (int r : d.recipients) {
      if (!robots_[static_cast<std::size_t>(r)].alive) continue;
      if (hear(r, sender, now_)) plan_liveness(r);
      strategy_->on_message(*this, r, d.message);
      ++bus_.delivered;
    }
  }
}

void GraphEngine::deliver_ready() {
  if (!faults_.empty()) {
    // While no robot holds a sender of these messages for lost, hearing it cannot plan a
    // liveness check (no event is pushed during the deliveries): robot by robot is then the
    // same as message by message.
    bool batch = ready_.size() > 1 && strategy_->messages_are_local();
    for (std::size_t k = 0; batch && k < ready_.size(); ++k) {
      const int sender = ready_[k].message.robot;
      batch =
          sender < 0 || sender >= config_.robots || lost_by_[static_cast<std::size_t>(sender)] == 0;
    }
    if (batch) {
      deliver_batch_by_robot();
    } else {
      deliver_heard();
    }
    return;
  }
  if (team_hears_alike()) {  // the strategy may hear a message once for the team
    const long long mates = config_.robots - 1;
    while (!ready_.empty() && ready_.front().all_but_sender &&
           strategy_->on_team_message(*this, ready_.front().sender, ready_.front().message)) {
      ready_.pop_front();
      bus_.delivered += mates;
    }
    if (ready_.empty()) return;
  }
  if (ready_.size() > 1 && strategy_->messages_are_local()) {
    deliver_batch_by_robot();
    return;
  }
  while (!ready_.empty()) {
    Delivery d = std::move(ready_.front());
    ready_.pop_front();
    if (d.all_but_sender) {
      const int n = config_.robots;
      for (int r = 0; r < n; ++r) {
        if (r != d.sender) strategy_->on_message(*this, r, d.message);
      }
      bus_.delivered += n - 1;
    } else {
      for (int r : d.recipients) strategy_->on_message(*this, r, d.message);
      bus_.delivered += static_cast<long long>(d.recipients.size());
    }
  }
}

void GraphEngine::plan_route(Robot& r, int goal) {
  r.route_k = 0;
  if (goal == r.current) {
    r.route.assign(1, goal);
  } else {
    r.route = graph_.path(r.current, goal);
    r.route.erase(r.route.begin());
  }
}

void GraphEngine::decide(int robot) {
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  if (!r.alive) return;
  r.wake_pending = false;
  const int goal = strategy_->decide(*this, robot);
  r.redirect = -1;
  if (goal < 0) {
    r.goal = -1;
    r.dwelling = false;
    if (!r.wake_pending) wake_at(robot, now_ + config_.retry_s);
    return;
  }
  graph_.check_vertex(goal);
  r.goal = goal;
  plan_route(r, goal);
  // RobotMachine._set_goal: dwell on the goal it stands on, else drive there.
  r.dwelling = goal == r.current && (!r.stalled || at_vertex(robot, goal));
  if (r.dwelling) {
    start_segment(robot);
  } else {
    drive(robot);
  }
}

bool GraphEngine::at_vertex(int robot, int vertex) const {
  double x, y;
  position(robot, now_, x, y);
  return std::hypot(x - positions_(vertex, 0), y - positions_(vertex, 1)) <=
         config_.goal_tolerance_m;
}

int GraphEngine::nearest_vertex(double x, double y) const {
  // PatrolMap.nearest_vertex: argmin of np.hypot (the first on ties).
  int best = 0;
  double best_d = std::hypot(positions_(0, 0) - x, positions_(0, 1) - y);
  for (Eigen::Index v = 1; v < positions_.rows(); ++v) {
    const double d = std::hypot(positions_(v, 0) - x, positions_(v, 1) - y);
    if (d < best_d) {
      best_d = d;
      best = static_cast<int>(v);
    }
  }
  return best;
}

void GraphEngine::drive(int robot) {
  // BatchRun.drive: a stalled robot cannot move; its navigator gives up later.
  if (robots_[static_cast<std::size_t>(robot)].stalled) {
    give_up_later(robot);
  } else {
    start_segment(robot);
  }
}

void GraphEngine::give_up_later(int robot) {
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  r.pending = push(now_ + config_.stall_give_up_s, kGiveUp, robot);
}

void GraphEngine::give_up(int robot) {
  // BatchRun._give_up, then RobotMachine.on_goal_failed.
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  const int goal = r.goal;
  if (goal < 0 || !r.alive) return;
  double x, y;
  position(robot, now_, x, y);
  r.goal = -1;
  r.dwelling = false;
  r.current = nearest_vertex(x, y);
  strategy_->on_goal_failed(*this, robot, goal);
  decide(robot);
}

void GraphEngine::freeze(int robot) {
  // Stop where it is now; its awaited arrival becomes stale.
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  double x, y;
  position(robot, now_, x, y);
  r.p0x = x;
  r.p0y = y;
  r.vx = r.vy = 0.0;
  r.t0 = r.t1 = now_;
  r.pending = 0;
}

void GraphEngine::inject(const EngineFault& fault) {
  // TeamRun.inject.
  const int i = fault.robot;
  Robot& r = robots_[static_cast<std::size_t>(i)];
  if (!r.alive) return;
  if (fault.death) {
    freeze(i);
    r.alive = false;
    r.goal = r.redirect = -1;
    r.dwelling = false;
    recorder_.record_robot_death(i, now_);
    links_->died(i, now_);  // its heartbeats stop: every survivor's checks move
    for (int j = 0; j < config_.robots; ++j) plan_liveness(j);
    return;
  }
  r.stalled = true;
  recorder_.record_robot_stall(i, now_);
  if (!r.dwelling) {  // a dwell needs no motion: it ends as planned
    freeze(i);
    if (r.goal >= 0) give_up_later(i);
  }
}

bool GraphEngine::hear(int robot, int sender, double t) {
  // RobotMachine.hear / TeammateLiveness.heard: true when the sender was lost (it is back).
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  if (!r.alive || sender < 0 || sender >= config_.robots || sender == robot) return false;
  double& last = r.last_heard[static_cast<std::size_t>(sender)];
  if (t <= last) return false;
  last = t;
  char& lost = r.lost[static_cast<std::size_t>(sender)];
  if (lost) {
    lost = 0;
    --lost_by_[static_cast<std::size_t>(sender)];
    return true;
  }
  return false;
}

void GraphEngine::feed_heartbeats(int robot) {
  for (int j = 0; j < config_.robots; ++j) {
    const double t = links_->last_arrival_s(robot, j, now_);
    if (t > -kInf) hear(robot, j, t);
  }
}

void GraphEngine::plan_liveness(int robot) {
  // TeamRun._plan_liveness: the earliest time any teammate's silence can reach the timeout, or
  // one can be heard again; one pending check per robot.
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  if (!r.alive) return;
  feed_heartbeats(robot);
  double due = kInf;
  for (int j = 0; j < config_.robots; ++j) {
    if (j == robot) continue;
    const double t = links_->next_check_s(robot, j, r.last_heard[static_cast<std::size_t>(j)],
                                          r.lost[static_cast<std::size_t>(j)] != 0, now_);
    if (t < due) due = t;
  }
  r.liveness = std::isfinite(due) ? push(py_max(due, now_), kLiveness, robot) : 0;
}

void GraphEngine::liveness_due(int robot) {
  // TeamRun.liveness_due: RobotMachine.check_liveness (each silent teammate reported once).
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  if (!r.alive) return;
  feed_heartbeats(robot);
  lost_now_.clear();
  for (int j = 0; j < config_.robots; ++j) {
    const double t = r.last_heard[static_cast<std::size_t>(j)];
    char& lost = r.lost[static_cast<std::size_t>(j)];
    // now >= t + timeout, as the due time of the check is computed
    if (j != robot && !lost && std::isfinite(t) && now_ >= t + config_.teammate_timeout_s) {
      lost = 1;
      ++lost_by_[static_cast<std::size_t>(j)];
      lost_now_.push_back(j);
    }
  }
  const std::vector<int> lost = lost_now_;  // a hook may re-enter the engine
  for (int j : lost) strategy_->on_teammate_lost(*this, robot, j);
  for (int j : lost) losses_.push_back({now_, robot, j});
  plan_liveness(robot);
}

void GraphEngine::start_segment(int robot) {
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  const int here = r.current, next = r.route[r.route_k];
  const double x0 = positions_(here, 0), y0 = positions_(here, 1);
  const double x1 = positions_(next, 0), y1 = positions_(next, 1);
  double duration;
  if (next == here) {
    duration = config_.stay_s;
  } else {
    const double length = graph_.edge_length(here, next);
    duration = length / config_.nominal_speed_mps;
    r.travelled_m += length;
    r.travel_time_s += duration;
  }
  r.t0 = now_;
  r.t1 = now_ + duration;
  r.p0x = x0;
  r.p0y = y0;
  r.vx = (x1 - x0) / duration;  // [m/s] along the straight segment
  r.vy = (y1 - y0) / duration;
  r.pending = push(r.t1, kArrive, robot);
}

void GraphEngine::arrive(int robot) {
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  const int vertex = r.route[r.route_k++];
  r.current = vertex;
  if (r.redirect >= 0 && r.goal >= 0) {
    r.goal = r.redirect;
    r.redirect = -1;
    plan_route(r, r.goal);
    if (vertex != r.goal) {
      r.dwelling = false;
      drive(robot);
      return;
    }
  } else if (r.route_k < r.route.size()) {
    start_segment(robot);  // pass-through vertex: not a visit
    return;
  }
  r.dwelling = false;
  recorder_.record_visit(robot, vertex, now_);
  r.goal = -1;
  decide(robot);
}

void GraphEngine::record_positions(double t) {
  if (t > last_positions_time_) {
    positions(t, scratch_);
    recorder_.record_positions(t, scratch_);
    last_positions_time_ = t;
  }
}

void GraphEngine::run(const std::function<void(double)>& progress) {
  if (strategy_ == nullptr) throw std::logic_error("no strategy set");
  const double end = config_.duration_s;
  const int n = config_.robots;
  record_positions(0.0);
  for (std::size_t k = 0; k < faults_.size(); ++k) {
    push(faults_[k].time_s, kFault, static_cast<int>(k));
  }
  for (int i = 0; i < n; ++i) strategy_->start(*this, i);
  for (int i = 0; i < n; ++i)
    recorder_.record_visit(i, robots_[static_cast<std::size_t>(i)].current, 0.0);
  deliver_ready();
  for (int i = 0; i < n; ++i) {
    decide(i);
    deliver_ready();
  }
  if (links_) {
    for (int i = 0; i < n; ++i) plan_liveness(i);
  }
  double next_progress = 0.0;
  auto next_wall = std::chrono::steady_clock::now() + std::chrono::milliseconds(100);
  while (!events_queue_.empty() && events_queue_.top().time <= end) {
    const Event ev = events_queue_.top();
    events_queue_.pop();
    ++events_;
    if (ev.time > now_) {
      record_positions(ev.time);
      now_ = ev.time;
    }
    if (ev.kind == kArrive) {
      if (robots_[static_cast<std::size_t>(ev.payload)].pending == ev.seq) arrive(ev.payload);
    } else if (ev.kind == kWake) {
      if (robots_[static_cast<std::size_t>(ev.payload)].goal < 0) decide(ev.payload);
    } else if (ev.kind == kFault) {
      inject(faults_[static_cast<std::size_t>(ev.payload)]);
    } else if (ev.kind == kGiveUp) {
      if (robots_[static_cast<std::size_t>(ev.payload)].pending == ev.seq) give_up(ev.payload);
    } else if (ev.kind == kLiveness) {
      if (robots_[static_cast<std::size_t>(ev.payload)].liveness == ev.seq) {
        liveness_due(ev.payload);
      }
    } else {
      const auto slot = static_cast<std::size_t>(ev.payload);
      ready_.push_back(std::move(slots_[slot]));
      slots_[slot] = Delivery{};
      free_slots_.push_back(ev.payload);
    }
    deliver_ready();
    // Every 1/200 of the run, and every 0.1 s of wall time (looked at every 256 events): a
    // signal reaches Python within ~0.1 s however long the run and slow its events (issue 22).
    bool call = progress && now_ >= next_progress;
    if (progress && !call && (events_ & 0xFF) == 0) {
      call = std::chrono::steady_clock::now() >= next_wall;
    }
    if (call) {
      progress(now_);
      next_progress = std::max(next_progress, now_ + end / 200.0);
      next_wall = std::chrono::steady_clock::now() + std::chrono::milliseconds(100);
    }
  }
  record_positions(end);
  now_ = end;
  if (progress) progress(end);
}

}  // namespace tpuaf
