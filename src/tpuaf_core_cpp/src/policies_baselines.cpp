// C++ decision paths of the paper's rivals GBS and DTAG (tpuaf/policies/bayesian.py, dtag.py),
// step for step in the Python policies' order (same random draws, same arithmetic).
#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include "tpuaf_core/strategies.hpp"

namespace tpuaf {

namespace {
inline double py_max(double a, double b) { return b > a ? b : a; }
constexpr double kIdleRetryS = 1.0;  // tpuaf.policies.common.IDLE_RETRY_S

void check_streams(const std::vector<NumpyPcg64>& rngs, const StrategyHost& host,
                   const char* name) {
  if (static_cast<int>(rngs.size()) != host.robots()) {
    throw std::invalid_argument(std::string(name) + " needs one random stream per robot: got " +
                                std::to_string(rngs.size()) + " for " +
                                std::to_string(host.robots()) + " robots");
  }
}
}  // namespace

int pick_max_index(const std::vector<double>& scores, NumpyPcg64& rng, double tol) {
  if (scores.empty()) throw std::invalid_argument("pick_max of no candidates");
  double top = scores[0];
  for (double s : scores) {
    if (s > top || std::isnan(s)) top = s;
    if (std::isnan(top)) break;
  }
  const double threshold = top - tol * py_max(1.0, std::abs(top));
  int first = -1, count = 0;
  for (std::size_t k = 0; k < scores.size(); ++k) {
    if (scores[k] >= threshold) {
      if (count++ == 0) first = static_cast<int>(k);
    }
  }
  if (count == 0) throw std::runtime_error("no candidate has a finite score");
  if (count == 1) return first;
  const std::int64_t pick = rng.integers(count);
  int seen = 0;
  for (std::size_t k = 0; k < scores.size(); ++k) {
    if (scores[k] >= threshold && seen++ == pick) return static_cast<int>(k);
  }
  return first;  // not reached
}

// ------------------------------------------------------------------------------------ GBS

GbsStrategy::GbsStrategy(double g1, double g2, double edge_min_m, std::vector<NumpyPcg64> rngs)
    : g1_(g1),
      g2_(g2),
      edge_min_m_(edge_min_m),
      log_inv_g1_(std::log(1.0 / g1)),
      rngs_(std::move(rngs)) {
  if (!(g1 > 0 && g1 < 1)) throw std::invalid_argument("GBS needs 0 < G1 < 1");
  if (!(g2 > 0) || !(edge_min_m > 0)) throw std::invalid_argument("GBS needs G2, edge_min > 0");
  last_visit_.resize(rngs_.size());
}

void GbsStrategy::start(StrategyHost& host, int robot) {
  check_streams(rngs_, host, "GBS");
  last_visit_[static_cast<std::size_t>(robot)].assign(
      static_cast<std::size_t>(host.graph().num_vertices()), host.now());
}

int GbsStrategy::decide(StrategyHost& host, int robot) {
  auto& last = last_visit_[static_cast<std::size_t>(robot)];
  const double now = host.now();
  const int here = host.current_vertex(robot);
  last[static_cast<std::size_t>(here)] = py_max(last[static_cast<std::size_t>(here)], now);
  candidates_.clear();
  for (int w : host.graph().neighbours(here)) {
    if (w != here) candidates_.push_back(w);
  }
  std::sort(candidates_.begin(), candidates_.end());
  candidates_.erase(std::unique(candidates_.begin(), candidates_.end()), candidates_.end());
  if (candidates_.empty()) {  // wait_nowhere_to_go
    host.wake_at(robot, now + kIdleRetryS);
    return -1;
  }
  int next = candidates_[0];
  if (candidates_.size() > 1) {
    scores_.clear();
    for (int c : candidates_) {
      const double w = py_max(host.graph().edge_length(here, c), edge_min_m_);
      const double idle = py_max(now - last[static_cast<std::size_t>(c)], 0.0);
      const double gain = idle / w;
      scores_.push_back(gain >= g2_ ? 1.0 : g1_ * std::exp(log_inv_g1_ * gain / g2_));
    }
    next = candidates_[static_cast<std::size_t>(
        pick_max_index(scores_, rngs_[static_cast<std::size_t>(robot)]))];
  }
  TeamMessage visit;
  visit.kind = TeamMessage::Kind::kVisit;
  visit.robot = robot;
  visit.vertex = here;
  visit.time_s = now;
  visit.next_vertex = -1;  // GBS broadcasts only (robot, vertex reached)
  host.send(robot, visit);
  return next;
}

void GbsStrategy::on_message(StrategyHost&, int robot, const TeamMessage& message) {
  if (message.kind != TeamMessage::Kind::kVisit || message.robot == robot) return;
  auto& last = last_visit_[static_cast<std::size_t>(robot)];
  const int v = message.vertex;
  if (v >= 0 && v < static_cast<int>(last.size())) {
    last[static_cast<std::size_t>(v)] = py_max(last[static_cast<std::size_t>(v)], message.time_s);
  }
}

// ----------------------------------------------------------------------------------- DTAG

DtagStrategy::DtagStrategy(double initial_estimate_s, double w_idleness, double w_path,
                           double w_origin, std::vector<std::vector<double>> origin_distance_m,
                           std::vector<NumpyPcg64> rngs)
    : initial_(initial_estimate_s),
      w_idleness_(w_idleness),
      w_path_(w_path),
      w_origin_(w_origin),
      origin_distance_m_(std::move(origin_distance_m)),
      rngs_(std::move(rngs)) {
  if (origin_distance_m_.size() != rngs_.size()) {
    throw std::invalid_argument("DTAG needs one origin-distance row per robot");
  }
  states_.resize(rngs_.size());
}

long long DtagStrategy::replans(int robot) const {
  return states_.at(static_cast<std::size_t>(robot)).replans;
}

void DtagStrategy::start(StrategyHost& host, int robot) {
  check_streams(rngs_, host, "DTAG");
  const auto n = static_cast<std::size_t>(host.graph().num_vertices());
  if (origin_distance_m_[static_cast<std::size_t>(robot)].size() != n) {
    throw std::invalid_argument("DTAG origin distances need one value per vertex");
  }
  State& s = states_[static_cast<std::size_t>(robot)];
  s.values.assign(n, initial_);
  s.updated = host.now();
  s.next = -1;
  s.replans = 0;
  s.replanned = false;
}

void DtagStrategy::advance(State& s, double now) {
  const double elapsed = py_max(0.0, now - s.updated);
  for (double& v : s.values) v += elapsed;
  s.updated = py_max(s.updated, now);
}

int DtagStrategy::choose(StrategyHost& host, int robot, int here, int exclude_a, int exclude_b) {
  const State& s = states_[static_cast<std::size_t>(robot)];
  const auto& origin = origin_distance_m_[static_cast<std::size_t>(robot)];
  const Eigen::MatrixXd& dist = host.graph().distances();
  candidates_.clear();
  scores_.clear();
  const int n = static_cast<int>(s.values.size());
  for (int v = 0; v < n; ++v) {
    if (v == exclude_a || v == exclude_b) continue;
    candidates_.push_back(v);
    scores_.push_back(w_idleness_ * s.values[static_cast<std::size_t>(v)] -
                      w_path_ * dist(here, v) - w_origin_ * origin[static_cast<std::size_t>(v)]);
  }
  if (candidates_.empty()) return -1;
  return candidates_[static_cast<std::size_t>(
      pick_max_index(scores_, rngs_[static_cast<std::size_t>(robot)]))];
}

void DtagStrategy::announce(StrategyHost& host, int robot, int next) {
  const State& s = states_[static_cast<std::size_t>(robot)];
  auto sent = std::make_shared<std::vector<double>>(s.values);
  (*sent)[static_cast<std::size_t>(next)] = 0.0;  // reservation
  TeamMessage m;
  m.kind = TeamMessage::Kind::kIdlenessEstimate;
  m.robot = robot;
  m.time_s = host.now();
  m.next_vertex = next;
  m.estimate = std::move(sent);
  host.send(robot, std::move(m));
}

int DtagStrategy::decide(StrategyHost& host, int robot) {
  State& s = states_[static_cast<std::size_t>(robot)];
  const double now = host.now();
  const int here = host.current_vertex(robot);
  advance(s, now);
  s.values[static_cast<std::size_t>(here)] = 0.0;
  const int next = choose(host, robot, here, here, -1);
  s.next = next;
  if (next < 0) {
    host.wake_at(robot, now + kIdleRetryS);
    return -1;
  }
  s.replanned = false;
  announce(host, robot, next);
  return next;
}

void DtagStrategy::on_message(StrategyHost& host, int robot, const TeamMessage& message) {
  if (message.kind != TeamMessage::Kind::kIdlenessEstimate || message.robot == robot) return;
  State& s = states_[static_cast<std::size_t>(robot)];
  const double now = host.now();
  advance(s, now);
  if (message.estimate && message.estimate->size() == s.values.size()) {  // else another map's
    const double transit = py_max(0.0, now - message.time_s);
    const auto& r = *message.estimate;
    for (std::size_t v = 0; v < s.values.size(); ++v) {
      const double other = r[v] + transit;
      if (other < s.values[v]) s.values[v] = other;
    }
  }
  // Only the higher-id robot yields, once per decision.
  if (s.next >= 0 && message.next_vertex == s.next && message.robot < robot && !s.replanned) {
    s.replanned = true;
    const int here = host.current_vertex(robot);
    const int next = choose(host, robot, here, here, s.next);
    if (next < 0) return;
    ++s.replans;
    s.next = next;
    host.change_goal(robot, next);
    announce(host, robot, next);
  }
}

}  // namespace tpuaf
