// VisitRule: see visit_rule.hpp.
#include "tpuaf_core/visit_rule.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>

namespace tpuaf {

VisitRule::VisitRule(Points positions, double visit_radius_m)
    : positions_(std::move(positions)),
      radius_(visit_radius_m),
      rearm_sq_(kRearmFactor * visit_radius_m * kRearmFactor * visit_radius_m),
      armed_(static_cast<std::size_t>(positions_.rows()), 0),
      disarmed_(static_cast<std::size_t>(positions_.rows())) {
  std::iota(disarmed_.begin(), disarmed_.end(), 0);
  if (!(visit_radius_m > 0.0) || !std::isfinite(visit_radius_m)) {
    throw std::invalid_argument("visit_radius must be a positive number of metres, not " +
                                std::to_string(visit_radius_m));
  }
}

void VisitRule::check(int vertex) const {
  if (vertex < 0 || vertex >= num_vertices()) {
    throw std::out_of_range("vertex index " + std::to_string(vertex) + " not in 0.." +
                            std::to_string(num_vertices() - 1));
  }
}

double VisitRule::distance(int vertex, double x, double y) const {
  return vertex_distance(positions_, vertex, x, y);
}

void VisitRule::reset() {
  std::fill(armed_.begin(), armed_.end(), 0);
  disarmed_.resize(armed_.size());
  std::iota(disarmed_.begin(), disarmed_.end(), 0);
  visits_ = 0;
}

void VisitRule::start(int vertex, double x, double y) {
  check(vertex);
  reset();
  observe(x, y);
  if (armed_[static_cast<std::size_t>(vertex)]) {
    armed_[static_cast<std::size_t>(vertex)] = 0;
    disarmed_.push_back(vertex);
  }
  visits_ = 1;
}

void VisitRule::observe(double x, double y) {
  std::size_t kept = 0;  // an armed vertex stays armed: only the disarmed ones can change
  for (const int v : disarmed_) {
    const double dx = x - positions_(v, 0), dy = y - positions_(v, 1);
    if (dx * dx + dy * dy > rearm_sq_) {
      armed_[static_cast<std::size_t>(v)] = 1;
    } else {
      disarmed_[kept++] = v;
    }
  }
  disarmed_.resize(kept);
}

bool VisitRule::arrive(int vertex, double x, double y) {
  check(vertex);
  observe(x, y);
  char& armed = armed_[static_cast<std::size_t>(vertex)];
  if (!armed || distance(vertex, x, y) > radius_) return false;
  armed = 0;
  disarmed_.push_back(vertex);
  ++visits_;
  return true;
}

bool VisitRule::within(int vertex, double x, double y) const {
  check(vertex);
  return distance(vertex, x, y) <= radius_;
}

bool VisitRule::armed(int vertex) const {
  check(vertex);
  return armed_[static_cast<std::size_t>(vertex)] != 0;
}

}  // namespace tpuaf
