// TPUAF+ on one-way walks that pass a vertex twice (the lab's figure eight): evenly spaced
// robots can reach it at once from its two passes, so the plan spaces them unevenly
// (tpuaf_plus_routes.uneven_gaps) and the spacing aims at those gaps (spacing_dwell_gaps); a step
// of the walk can be on it twice, so each mate's walk position is followed from message to message
// (track_mate) instead of guessed from its latest step.
#include <algorithm>
#include <cmath>
#include <limits>

#include "tpuaf_core/tpuaf_plus.hpp"

namespace tpuaf {

double spacing_dwell_gaps(std::vector<MatePlace> mates, const std::vector<double>& gaps, int robot,
                          double length_m, double pace_mps, double gain, double deadband_s) {
  const std::size_t m = mates.size() + 1;
  if (mates.empty() || !(length_m > 0) || gaps.size() != m) {
    return spacing_dwell(std::move(mates), length_m, pace_mps, gain, deadband_s);
  }
  std::stable_sort(mates.begin(), mates.end(),
                   [](const MatePlace& a, const MatePlace& b) { return a.ahead_m < b.ahead_m; });
  // my slot in the gaps: the rotation of the pattern nearest the mates' phases (every robot
  // sees the same team, so they agree but at ties)
  std::size_t slot = 0;
  double best = std::numeric_limits<double>::infinity(), sum = 0;
  for (std::size_t s = 0; s < m; ++s) {
    double target = 0, error = 0, squares = 0;
    for (std::size_t j = 0; j < mates.size(); ++j) {
      target += gaps[(s + j) % m];
      const double d = (mates[j].ahead_m - mates[j].dwell_m) - target;
      error += d;
      squares += d * d;
    }
    if (squares < best - 1e-9) {
      best = squares;
      slot = s;
      sum = error;
    }
  }
  const double e = -sum / static_cast<double>(m);
  double wait = 2.0 * gain * e / pace_mps;
  if (e > deadband_s * pace_mps) wait = std::max(wait, deadband_s + 0.1);  // past the deadband
  const double even_s = length_m / static_cast<double>(m) / pace_mps;
  const double phase_behind = mates.back().ahead_m - mates.back().dwell_m;
  const double reach_s = (length_m - phase_behind) / mates.back().pace_mps - deadband_s;
  return std::max(0.0, std::min({wait, even_s, reach_s}));
}

}  // namespace tpuaf

namespace tpuaf {

void TpuafPlusStrategy::track_mate(Robot& r, int k, int from, int to, double sent) const {
  if (graph_ == nullptr || graph_->one_way().empty() || !r.plan || r.route < 0) return;
  const PlusRoute& route = route_of(r);
  if (!std::binary_search(route.robots.begin(), route.robots.end(), k)) return;
  const std::size_t kk = static_cast<std::size_t>(k);
  if (r.mate_index_route != &route) {  // a new plan: follow every mate afresh
    r.mate_index.assign(r.heard.size(), -1);
    r.mate_index_route = &route;
  }
  const auto& schedule = r.plan->schedule;
  if (kk < schedule.size() && schedule[kk].first >= 0 && sent < schedule[kk].second - 1e-6) {
    r.mate_index[kk] = schedule[kk].first;  // not on its slot yet: it leaves from its entry
    return;
  }
  const int n = static_cast<int>(route.walk.size());
  const int before = r.mate_index[kk];
  int best = -1;
  double best_off = std::numeric_limits<double>::infinity();
  for (const int i : route.positions(from, to)) {
    double off;
    if (before >= 0) {
      off = static_cast<double>(((i - before) % n + n) % n);  // steps forward from before
    } else if (r.has_mate_arc[kk]) {                          // first heard: nearest my estimate
      const double L = route.length;
      off = std::abs(
          std::fmod(route.arc[static_cast<std::size_t>(i)] - r.mate_arc[kk] + 1.5 * L, L) - L / 2);
    } else {
      off = 0;  // the first position
    }
    if (off < best_off) {
      best_off = off;
      best = i;
    }
  }
  if (best >= 0) r.mate_index[kk] = best;
}

int TpuafPlusStrategy::tracked_hit(const Robot& r, int k, const PlusRoute::Indices& hits) const {
  if (graph_ == nullptr || graph_->one_way().empty() || !r.plan) return -1;
  if (r.mate_index_route != &route_of(r)) return -1;
  const int tracked = r.mate_index[static_cast<std::size_t>(k)];
  for (const int i : hits) {
    if (i == tracked) return tracked;
  }
  return -1;
}

}  // namespace tpuaf
