// TPUAF+'s plan arithmetic in C++ (tpuaf/policies/tpuaf_plus.py and tours.walk_idleness, the
// same floating-point operations in the same order): the steady-state worst idleness of a
// walk and the start schedule; the closed-loop spacing's pace and phase arithmetic. Times in
// seconds, lengths in metres.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <stdexcept>

#include "tpuaf_core/assignment.hpp"
#include "tpuaf_core/tpuaf_plus.hpp"

namespace tpuaf {

// A walk's positions of a vertex or of a step (PlusRoute, tpuaf_plus.hpp).
PlusRoute::Indices PlusRoute::positions(int from, int to) const {
  const std::size_t n = walk.size();
  if (by_vertex_.empty() && n > 0) {
    const int top = *std::max_element(walk.begin(), walk.end());
    by_vertex_.assign(static_cast<std::size_t>(top) + 2, 0);
    for (int v : walk) ++by_vertex_[static_cast<std::size_t>(v) + 1];
    for (std::size_t v = 1; v < by_vertex_.size(); ++v) by_vertex_[v] += by_vertex_[v - 1];
    at_.resize(n);
    std::vector<int> fill(by_vertex_.begin(), by_vertex_.end() - 1);
    for (std::size_t i = 0; i < n; ++i) {
      at_[static_cast<std::size_t>(fill[static_cast<std::size_t>(walk[i])]++)] =
          static_cast<int>(i);
    }
    steps_ = at_;
    const auto next = [&](int i) { return walk[(static_cast<std::size_t>(i) + 1) % n]; };
    for (std::size_t v = 0; v + 1 < by_vertex_.size(); ++v) {
      std::stable_sort(steps_.begin() + by_vertex_[v], steps_.begin() + by_vertex_[v + 1],
                       [&](int a, int b) { return next(a) < next(b); });
    }
  }
  const int* none = at_.data();
  if (from < 0 || static_cast<std::size_t>(from) + 1 >= by_vertex_.size()) return {none, none};
  const std::size_t lo = static_cast<std::size_t>(by_vertex_[static_cast<std::size_t>(from)]);
  const std::size_t hi = static_cast<std::size_t>(by_vertex_[static_cast<std::size_t>(from) + 1]);
  if (from == to) return {at_.data() + lo, at_.data() + hi};
  const int* first = steps_.data() + lo;
  while (first != steps_.data() + hi && walk[(static_cast<std::size_t>(*first) + 1) % n] != to) {
    ++first;
  }
  const int* last = first;
  while (last != steps_.data() + hi && walk[(static_cast<std::size_t>(*last) + 1) % n] == to) {
    ++last;
  }
  return {first, last};
}

namespace {

constexpr double kEps = 1e-6;      // tpuaf_plus._EPS
constexpr double kStartGap = 1.1;  // largest start gap between robots, over L / m
constexpr double kInf = std::numeric_limits<double>::infinity();

// tpuaf_plus._slot_departures: for a robot at `start`, late by late_m [m], and slots at arc
// positions `slots` [m] at t = 0, per slot the earliest v * departure [m] and walk index at
// which the robot is at a walk vertex when its slot passes. With u_k = (arc_k - d_k) mod L,
// v t = d_k + u_k - s (+ L when s > u_k).
void slot_departures(const PatrolGraph& graph, const PlusRoute& route, int start,
                     const std::vector<double>& slots, double late_m, double* out_t, int* out_k) {
  const std::size_t n = route.walk.size();
  const double L = route.length;
  std::vector<double> d(n), u(n);
  const std::shared_ptr<const DistanceRow> from = graph.row(start);
  for (std::size_t i = 0; i < n; ++i) {
    d[i] = from->distance[static_cast<std::size_t>(route.walk[i])] + late_m;
    u[i] = py_mod(route.arc[i] - d[i], L);
  }
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return u[a] < u[b]; });
  std::vector<double> u_sorted(n), b_sorted(n);
  for (std::size_t i = 0; i < n; ++i) {
    u_sorted[i] = u[order[i]];
    b_sorted[i] = d[order[i]] + u[order[i]];
  }
  // suffix / prefix minima of B = d + u over indices sorted by u (and where they are)
  std::vector<std::size_t> suf(n), pre(n);
  std::size_t best = n - 1;
  for (std::size_t i = n; i-- > 0;) {
    if (b_sorted[i] <= b_sorted[best]) best = i;
    suf[i] = best;
  }
  best = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (b_sorted[i] < b_sorted[best]) best = i;
    pre[i] = best;
  }
  for (std::size_t j = 0; j < slots.size(); ++j) {
    const double s = slots[j];
    const std::size_t p = static_cast<std::size_t>(
        std::lower_bound(u_sorted.begin(), u_sorted.end(), s) - u_sorted.begin());
    out_t[j] = kInf;
    out_k[j] = 0;
    if (p < n) {
      out_t[j] = b_sorted[suf[p]] - s;
      out_k[j] = order[suf[p]];
    }
    if (p > 0) {
      const std::size_t i = pre[p - 1];
      const double t = b_sorted[i] + L - s;
      if (t < out_t[j] - kEps) {
        out_t[j] = t;
        out_k[j] = order[i];
      }
    }
  }
}

}  // namespace

double py_mod(double a, double b) {
  double m = std::fmod(a, b);
  if (m != 0) {
    if ((b < 0) != (m < 0)) m += b;
  } else {
    m = std::copysign(0.0, b);
  }
  return m;
}

double update_pace(double pace_mps, double sample_mps, double weight, double speed_mps) {
  // within 1e-9 of v is v (an arrival time's rounding)
  const double top = sample_mps >= speed_mps * (1 - 1e-9) ? speed_mps : sample_mps;
  const double sample = std::min(std::max(top, 0.1 * speed_mps), speed_mps);
  return pace_mps + weight * (sample - pace_mps);
}

double phase_error(const std::vector<double>& ahead_m, double length_m) {
  const double m = static_cast<double>(ahead_m.size() + 1);
  double sum = 0;  // sum over mates j = 1..m-1 of d_j - j L / m (j = 0 adds 0)
  for (std::size_t j = 0; j < ahead_m.size(); ++j) {
    sum += ahead_m[j] - static_cast<double>(j + 1) * length_m / m;
  }
  return -sum / m;
}

double spacing_dwell(std::vector<MatePlace> mates, double length_m, double pace_mps, double gain,
                     double deadband_s) {
  if (mates.empty() || !(length_m > 0)) return 0.0;
  std::stable_sort(mates.begin(), mates.end(),
                   [](const MatePlace& a, const MatePlace& b) { return a.ahead_m < b.ahead_m; });
  std::vector<double> phases;  // [m] ahead, in the mates' order along the walk
  for (const MatePlace& p : mates) phases.push_back(p.ahead_m - p.dwell_m);
  const double e = phase_error(phases, length_m);
  double wait = 2.0 * gain * e / pace_mps;
  if (e > deadband_s * pace_mps) wait = std::max(wait, deadband_s + 0.1);  // past the deadband
  const double even_s = length_m / static_cast<double>(mates.size() + 1) / pace_mps;
  const double reach_s = (length_m - phases.back()) / mates.back().pace_mps - deadband_s;
  return std::max(0.0, std::min({wait, even_s, reach_s}));
}

int nearest_entry(const PatrolGraph& graph, const PlusRoute& route, int vertex) {
  int best = -1;
  double best_d = kInf;
  const std::shared_ptr<const DistanceRow> from = graph.row(vertex);
  for (int w : route.walk) {
    const double d = from->distance[static_cast<std::size_t>(w)];
    if (best < 0 || d < best_d || (d == best_d && w < best)) {
      best = w;
      best_d = d;
    }
  }
  return static_cast<int>(std::find(route.walk.begin(), route.walk.end(), best) -
                          route.walk.begin());
}

double walk_worst_idleness(const PatrolGraph& graph, const std::vector<int>& walk, int n_robots,
                           double speed_mps) {
  const std::size_t n = walk.size();
  double length = 0;  // tours.walk_length: edges in walk order, last -> first too
  if (n >= 2) {
    for (std::size_t i = 0; i < n; ++i) length += graph.edge_length(walk[i], walk[(i + 1) % n]);
  }
  if (length <= 0.0 || n_robots < 1) return 0.0;
  const double spacing = length / n_robots;   // [m] between robots
  const double period = spacing / speed_mps;  // [s] the visit pattern repeats with this period
  std::map<int, std::vector<double>> times;   // vertex -> pass times in one period [s]
  double s = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    times[walk[i]].push_back(std::nearbyint(py_mod(s, spacing) / speed_mps * 1e9) / 1e9);
    s += graph.edge_length(walk[i], walk[(i + 1) % n]);
  }
  double worst = 0.0;
  for (auto& [vertex, t] : times) {
    std::sort(t.begin(), t.end());
    t.erase(std::unique(t.begin(), t.end()), t.end());
    double gap = (t.front() + period) - t.back();
    for (std::size_t i = 1; i < t.size(); ++i) gap = std::max(gap, t[i] - t[i - 1]);
    worst = std::max(worst, gap);
  }
  return worst;
}

// The latest first visit [m of travel] over the walk's vertices when robot t leaves the walk
// position entry_arc[t] [m] after t_dep[t] [m]; with idle_m, each vertex's soonest first visit
// plus its idleness [m]. first (one per walk entry), soonest: workspaces.
double latest_first_visit(const PlusRoute& route, const std::vector<double>& entry_arc,
                          const std::vector<double>& t_dep, const std::vector<double>* idle_m,
                          std::vector<double>& first, std::vector<double>& soonest) {
  const std::size_t n = route.walk.size(), m = t_dep.size();
  const double L = route.length;
  // first visit [m at v] of every walk vertex: the first robot passing it
  // (arc - entry_arc lies in (-L, L): py_mod adds L to a negative one, as fmod does)
  for (std::size_t i = 0; i < n; ++i) {
    double f = kInf;
    for (std::size_t t = 0; t < m; ++t) {
      const double ahead = route.arc[i] - entry_arc[t];
      f = std::min(f, t_dep[t] + (ahead < 0 ? ahead + L : ahead));
    }
    first[i] = f;
  }
  double score = -kInf;
  if (idle_m == nullptr) {
    for (double f : first) score = std::max(score, f);
    return score;
  }
  // per vertex: its first visit over all its walk entries, after its idleness
  soonest.assign(idle_m->size(), kInf);
  for (std::size_t i = 0; i < n; ++i) {
    double& s = soonest[static_cast<std::size_t>(route.walk[i])];
    s = std::min(s, first[i]);
  }
  for (int v : route.walk) {
    score = std::max(score,
                     soonest[static_cast<std::size_t>(v)] + (*idle_m)[static_cast<std::size_t>(v)]);
  }
  return score;
}

// [m] slot j's arc at t = 0 in phase q of `phases`: L / m apart, or route.gaps apart (one-way
// walks that pass a vertex twice).
double slot_arc(const PlusRoute& route, std::size_t j, int q, int phases, int m) {
  const double L = route.length;
  if (route.gaps.size() != static_cast<std::size_t>(m)) {
    return (static_cast<double>(q) / phases + static_cast<double>(j)) * (L / m);
  }
  double offset = 0;
  for (std::size_t i = 0; i < j; ++i) offset += route.gaps[i];
  return static_cast<double>(q) / phases * (L / m) + offset;
}

// Each robot to the walk entry nearest its start, leaving at once: (entry, travel [s]).
std::vector<std::pair<int, double>> nearest_entries(const PatrolGraph& graph,
                                                    const PlusRoute& route,
                                                    const std::vector<int>& starts,
                                                    double speed_mps) {
  std::vector<std::pair<int, double>> out(starts.size());
  for (std::size_t i = 0; i < starts.size(); ++i) {
    const int k = nearest_entry(graph, route, starts[i]);
    out[i] = {k, graph.distance(starts[i], route.walk[static_cast<std::size_t>(k)]) / speed_mps};
  }
  return out;
}

std::vector<std::pair<int, double>> start_schedule(const PatrolGraph& graph, const PlusRoute& route,
                                                   const std::vector<int>& starts,
                                                   const std::vector<double>& late_m,
                                                   double speed_mps,
                                                   const std::vector<double>* idle_s) {
  const std::size_t m = route.robots.size();
  const double L = route.length;
  if (starts.size() != m || late_m.size() != m || route.arc.size() != route.walk.size() ||
      route.walk.empty()) {
    throw std::invalid_argument("start_schedule: one start and one lateness per robot needed");
  }
  if (m == 1 || L <= 0) return nearest_entries(graph, route, starts, speed_mps);
  std::vector<std::pair<int, double>> out(m);
  const std::size_t n = route.walk.size();
  const int mi = static_cast<int>(m);
  const int phases = std::max(4, std::min(16, 4000 / (mi * mi) + 4));
  std::vector<double> idle_m;
  if (idle_s != nullptr) {
    idle_m.resize(idle_s->size());
    for (std::size_t v = 0; v < idle_s->size(); ++v) idle_m[v] = (*idle_s)[v] * speed_mps;
  }
  std::vector<double> slots(m), dep(m * m), cost(m * m), t_dep(m), entry_arc(m), reach(m), first(n),
      virt(m), soonest;
  std::vector<int> ent(m * m), k(m);
  bool have_best = false;
  double best0 = 0, best1 = 0;
  std::vector<std::int64_t> best_rows;
  std::vector<int> best_k;
  std::vector<double> best_t;
  static const double kAlphas[] = {1.0, 0.75, 0.5, 0.25, 0.0};
  for (int q = 0; q < phases; ++q) {
    for (std::size_t j = 0; j < m; ++j) slots[j] = slot_arc(route, j, q, phases, mi);
    for (std::size_t i = 0; i < m; ++i) {
      slot_departures(graph, route, starts[i], slots, late_m[i], &dep[i * m], &ent[i * m]);
    }
    for (std::size_t x = 0; x < m * m; ++x) {
      const double c = dep[x] / L;
      cost[x] = c * c;
    }
    const Assignment match = linear_sum_assignment(cost, mi, mi);
    for (std::size_t t = 0; t < m; ++t) {
      const std::size_t row = static_cast<std::size_t>(match.rows[t]);
      const std::size_t col = static_cast<std::size_t>(match.cols[t]);
      k[t] = ent[row * m + col];
      entry_arc[t] = route.arc[static_cast<std::size_t>(k[t])];
      reach[t] =
          graph.distance(starts[row], route.walk[static_cast<std::size_t>(k[t])]) + late_m[row];
    }
    for (double alpha : kAlphas) {
      for (std::size_t t = 0; t < m; ++t) {
        const std::size_t x =
            static_cast<std::size_t>(match.rows[t]) * m + static_cast<std::size_t>(match.cols[t]);
        t_dep[t] = reach[t] + alpha * (dep[x] - reach[t]);  // [m] of travel at v
      }
      for (std::size_t t = 0; t < m; ++t) virt[t] = py_mod(entry_arc[t] - t_dep[t], L);
      std::sort(virt.begin(), virt.end());
      double gap = (virt[0] + L) - virt[m - 1];
      for (std::size_t t = 1; t < m; ++t) gap = std::max(gap, virt[t] - virt[t - 1]);
      if (alpha < 1.0 && gap > kStartGap * L / mi) continue;
      const double score0 = latest_first_visit(
          route, entry_arc, t_dep, idle_s != nullptr ? &idle_m : nullptr, first, soonest);
      const double score1 = numpy_sum(t_dep.data(), m);
      if (!have_best || score0 < best0 - kEps ||
          (score0 <= best0 + kEps && score1 < best1 - kEps)) {
        have_best = true;
        best0 = score0;
        best1 = score1;
        best_rows = match.rows;
        best_k = k;
        best_t = t_dep;
      }
    }
  }
  for (std::size_t t = 0; t < m; ++t) {
    out[static_cast<std::size_t>(best_rows[t])] = {best_k[t], best_t[t] / speed_mps};
  }
  return out;
}

}  // namespace tpuaf
