// TPUAF+'s spacing (docs/STRATEGIES.md): where each walk mate is on my walk now (its start slot,
// or extrapolated at its measured pace from its latest message) and how long I dwell at my walk
// vertex to even the gaps (spacing_dwell, or spacing_dwell_gaps on uneven one-way walks).
#include <algorithm>
#include <cmath>
#include <limits>

#include "tpuaf_core/tpuaf_plus.hpp"

namespace tpuaf {

namespace {

constexpr double kEps = 1e-6;  // tpuaf_plus._EPS
constexpr double kInf = std::numeric_limits<double>::infinity();

}  // namespace

bool TpuafPlusStrategy::mate_arc(Robot& r, int k, double now, double& arc, double* dwell_m) {
  // Mate k's estimated arc [m] on my walk now: on its start slot until it leaves (and after,
  // while its latest message is from before that: the one telling me it left may be delayed or
  // lost), else extrapolated at its measured pace from its latest timed message; false when
  // unknown or off my walk. dwell_m: its pace x its dwell left [m] (its vertex is arc + that).
  if (dwell_m != nullptr) *dwell_m = 0.0;
  const PlusRoute& route = route_of(r);
  const double L = route.length, speed = params_.speed_mps;
  const std::size_t kk = static_cast<std::size_t>(k);
  const auto& schedule = r.plan->schedule;
  const bool scheduled = kk < schedule.size() && schedule[kk].first >= 0 &&
                         std::binary_search(route.robots.begin(), route.robots.end(), k);
  const auto on_slot = [&]() {
    arc = py_mod(route.arc[static_cast<std::size_t>(schedule[kk].first)] -
                     speed * (schedule[kk].second - now),
                 L);
    r.mate_arc[kk] = arc;
    r.has_mate_arc[kk] = 1;
    return true;
  };
  if (scheduled && now < schedule[kk].second) return on_slot();
  if (!r.has_heard[kk]) return scheduled ? on_slot() : false;
  const Heard& info = r.heard[kk];
  const double moved = r.pace[kk] * (now - info.departure);
  int chosen = -1;
  int hits = 0;
  double best = kInf;
  for (const int i : route.positions(info.from, info.to)) {
    ++hits;
    if (chosen < 0) chosen = i;
    if (r.has_mate_arc[kk]) {  // several hits: the one nearest my last estimate
      const double off = std::abs(
          py_mod((route.arc[static_cast<std::size_t>(i)] + moved - r.mate_arc[kk]) + L / 2, L) -
          L / 2);
      if (off < best) {
        best = off;
        if (hits > 1) chosen = i;
      }
    }
  }
  if (hits > 1) {  // one-way walks: the position its messages were followed to
    const int tracked = tracked_hit(r, k, route.positions(info.from, info.to));
    if (tracked >= 0) chosen = tracked;
  }
  if (scheduled && info.sent < schedule[kk].second - kEps) {
    // its latest message is from before it left its start slot: off my walk, or due at its
    // entry vertex in time, it left unheard (delay, loss)
    const int entry_vertex = route.walk[static_cast<std::size_t>(schedule[kk].first)];
    const double to_entry_m = distance(info.from, info.to) + distance(info.to, entry_vertex);
    const double due_s = info.departure + to_entry_m / speed;  // at its entry vertex
    if (chosen < 0 || due_s <= schedule[kk].second + kEps) return on_slot();
  }
  if (chosen < 0) return false;
  arc = py_mod(route.arc[static_cast<std::size_t>(chosen)] + moved, L);
  if (dwell_m != nullptr) *dwell_m = r.pace[kk] * std::max(0.0, info.departure - now);
  r.mate_arc[kk] = arc;
  r.has_mate_arc[kk] = 1;
  return true;
}

double TpuafPlusStrategy::spacing_wait(Robot& r, int robot, double now) {
  // Dwell [s] at my walk vertex: spacing_dwell over my placed walk mates, my measured pace.
  const PlusRoute& route = route_of(r);
  const double L = route.length;
  if (!(L > 0)) return 0.0;
  const double here = route.arc[static_cast<std::size_t>(r.idx)];
  std::vector<MatePlace> mates;
  mates.reserve(route.robots.size());
  for (int k : route.robots) {
    const std::size_t kk = static_cast<std::size_t>(k);
    double arc = 0, dwell = 0;
    if (k == robot || !r.alive[kk] || !mate_arc(r, k, now, arc, &dwell)) continue;
    double d = py_mod(arc + dwell - here, L);
    if (d < kEps || L - d < kEps) d = k < robot ? 0.0 : L;  // together: the lower index ahead
    mates.push_back(MatePlace{d, dwell, r.pace[kk], k});
  }
  const double pace = r.pace[static_cast<std::size_t>(robot)];
  if (!route.gaps.empty()) {
    return spacing_dwell_gaps(std::move(mates), route.gaps, robot, L, pace, params_.gain,
                              params_.deadband_s);
  }
  return spacing_dwell(std::move(mates), L, pace, params_.gain, params_.deadband_s);
}

}  // namespace tpuaf
