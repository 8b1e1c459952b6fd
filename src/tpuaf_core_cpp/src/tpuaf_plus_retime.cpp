// TPUAF+ on learned travel times (docs/STRATEGIES.md, "Learned travel times"): a robot keeps its
// walk and re-times it on the re-timed graph (arcs, lap length, target gaps from the plan
// source), carrying its estimates over, when that moves a target gap by more than the
// tolerance.
#include <algorithm>
#include <cmath>
#include <cstddef>

#include "tpuaf_core/tpuaf_plus.hpp"

namespace tpuaf {

namespace {

// Arc position a [m] on `from` carried to the same place on `to` (the same walk on other edge
// lengths): the same share of the same walk edge.
double carry_arc(const PlusRoute& from, const PlusRoute& to, double a) {
  const std::size_t n = from.walk.size();
  if (n < 2 || !(from.length > 0) || to.walk != from.walk) return a;
  a = py_mod(a, from.length);
  const auto after = std::upper_bound(from.arc.begin(), from.arc.end(), a);
  const auto i =
      static_cast<std::size_t>(std::max<std::ptrdiff_t>(after - from.arc.begin() - 1, 0));
  const double end_from = i + 1 < n ? from.arc[i + 1] : from.length;
  const double end_to = i + 1 < n ? to.arc[i + 1] : to.length;
  const double span = end_from - from.arc[i];
  const double share = span > 0 ? (a - from.arc[i]) / span : 0.0;
  return to.arc[i] + share * (end_to - to.arc[i]);
}

}  // namespace

double retime_gap_change(const PlusRoute& from, const PlusRoute& to) {
  const std::size_t m = from.robots.size();
  if (m < 2 || to.walk != from.walk || !(from.length > 0) || !(to.length > 0)) return 0.0;
  const auto targets = [m](const PlusRoute& r) {
    return r.gaps.size() == m ? r.gaps
                              : std::vector<double>(m, r.length / static_cast<double>(m));
  };
  const std::vector<double> before = targets(from), after = targets(to);
  const double even = to.length / static_cast<double>(m);
  double worst = 0;
  for (const double first : from.arc) {  // the team's phases from each walk entry on
    double phase = first, at = carry_arc(from, to, first);
    for (std::size_t j = 0; j < m; ++j) {
      phase += before[j];
      const double next = carry_arc(from, to, phase);
      worst = std::max(worst, std::abs(py_mod(next - at, to.length) - after[j]) / even);
      at = next;
    }
  }
  return worst;
}

void TpuafPlusStrategy::retime(StrategyHost& host, int robot) {
  if (!params_.retime) return;  // the model's times, on the graph the robot started with
  Robot& r = state(robot);
  if (!r.plan) {  // not started: start() plans on the new times
    graph_ = &host.graph();
    timing_ = graph_;
    plan_cache_.clear();
    return;
  }
  const std::vector<int> mates = team(robot);
  const std::shared_ptr<const PlusPlan> candidate = plans_(mates, &host.graph());
  const PlusRoute& old = route_of(r);
  const int index = candidate && static_cast<std::size_t>(robot) < candidate->route_of.size()
                        ? candidate->route_of[static_cast<std::size_t>(robot)]
                        : -1;
  if (index < 0 || index >= static_cast<int>(candidate->routes.size())) return;
  const PlusRoute& next = candidate->routes[static_cast<std::size_t>(index)];
  // a lone robot, or targets that move less than the tolerance: the timing I have (re-spacing
  // on noise in the learned times, teammates' waits, would only disturb the team)
  if (next.walk == old.walk && retime_gap_change(old, next) <= params_.retime_tolerance) return;
  graph_ = &host.graph();
  timing_ = graph_;
  std::fill(lengths_.begin(), lengths_.end(), KnownLength{});  // distances on the new edges
  plan_cache_.clear();
  const std::shared_ptr<const PlusPlan> old_plan = r.plan;  // keeps `old` alive
  r.plan = plan_for(mates);
  r.route = r.plan->route_of[static_cast<std::size_t>(robot)];
  const PlusRoute& route = route_of(r);
  if (route.walk != old.walk) {  // not the walk I drove (a plan source that re-plans): enter it
    install_plan(host, robot, false);
    return;
  }
  for (std::size_t k = 0; k < r.mate_arc.size(); ++k) {
    if (r.has_mate_arc[k]) r.mate_arc[k] = carry_arc(old, route, r.mate_arc[k]);
  }
  if (r.respacing) r.respace_target = carry_arc(old, route, r.respace_target);
  // paces [m/s] along the walk: the lap's metres changed by L' / L (a sample is at most v)
  const double scale = old.length > 0 ? route.length / old.length : 1.0;
  for (double& pace : r.pace) pace = std::min(pace * scale, params_.speed_mps);
  if (r.mate_index_route == &old) r.mate_index_route = &route;  // the same walk indices
}

}  // namespace tpuaf
