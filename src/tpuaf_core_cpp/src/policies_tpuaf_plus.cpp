// TPUAF+'s decisions (the strategy's one implementation; docs/STRATEGIES.md has the rule):
// spacing, dwelling, start schedule, re-spacing and repair. Python's float % is py_mod, as the
// recorded runs of tests/test_runtime_equivalence.py were made with it.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "tpuaf_core/tpuaf_plus.hpp"

namespace tpuaf {

namespace {

constexpr double kEps = 1e-6;  // tpuaf_plus._EPS
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kWait = -1;    // decide(): wait (a wake-up is set)
constexpr int kDepart = -2;  // hold(): the dwell is over, depart

}  // namespace

TpuafPlusStrategy::TpuafPlusStrategy(const TpuafKnowledge& knowledge, TpuafPlusParams params,
                                     PlanSource plans)
    : prototype_(knowledge), params_(std::move(params)), plans_(std::move(plans)) {
  prototype_.share_visit_results();  // the team hears the same visits: one Eq. 2 per visit
}

double TpuafPlusStrategy::distance(int u, int v) const {
  const std::uint64_t key = (static_cast<std::uint64_t>(static_cast<std::uint32_t>(u)) << 32) |
                            static_cast<std::uint32_t>(v);
  KnownLength& slot = lengths_[static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ULL) >> 50)];
  if (slot.u != u || slot.v != v) slot = {u, v, graph_->distance(u, v)};
  return slot.length_m;
}

TpuafPlusStrategy::Robot& TpuafPlusStrategy::state(int robot) {
  if (robot < 0 || robot >= static_cast<int>(robots_.size())) {
    throw std::out_of_range("unknown robot " + std::to_string(robot));
  }
  return robots_[static_cast<std::size_t>(robot)];
}

const PlusRoute& TpuafPlusStrategy::route(int robot) const {
  if (robot < 0 || robot >= static_cast<int>(robots_.size()) ||
      !robots_[static_cast<std::size_t>(robot)].plan) {
    throw std::out_of_range("robot " + std::to_string(robot) + " has no plan yet");
  }
  return route_of(robots_[static_cast<std::size_t>(robot)]);
}

std::vector<int> TpuafPlusStrategy::walk(int robot) const { return route(robot).walk; }

std::vector<int> TpuafPlusStrategy::team(int robot) const {
  if (robot < 0 || robot >= static_cast<int>(robots_.size())) {
    throw std::out_of_range("unknown robot " + std::to_string(robot));
  }
  const Robot& r = robots_[static_cast<std::size_t>(robot)];
  std::vector<int> out;
  for (std::size_t k = 0; k < r.alive.size(); ++k) {
    if (r.alive[k] || static_cast<int>(k) == robot) out.push_back(static_cast<int>(k));
  }
  return out;
}

std::shared_ptr<const PlusPlan> TpuafPlusStrategy::plan_for(const std::vector<int>& team) {
  auto it = plan_cache_.find(team);
  if (it != plan_cache_.end()) return it->second;
  std::shared_ptr<const PlusPlan> plan = plans_(team, timing_);
  if (!plan || plan->route_of.size() < robots_.size()) {
    throw std::invalid_argument("the TPUAF+ planner returned no route per robot");
  }
  for (int k : team) {
    const int route = plan->route_of[static_cast<std::size_t>(k)];
    if (route < 0 || route >= static_cast<int>(plan->routes.size())) {
      throw std::invalid_argument("the TPUAF+ plan has no walk for robot " + std::to_string(k));
    }
  }
  plan_cache_.emplace(team, plan);
  return plan;
}

// ------------------------------------------------------------------ set-up

void TpuafPlusStrategy::start(StrategyHost& host, int robot) {
  const int n = host.robots();
  graph_ = &host.graph();
  if (static_cast<int>(robots_.size()) != n) {
    robots_.clear();
    robots_.reserve(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) robots_.emplace_back(prototype_);
    visits_ = TeamVisits(prototype_, n);
    histories_.assign(static_cast<std::size_t>(n) * static_cast<std::size_t>(n), Recent{});
    plan_cache_.clear();
  }
  Robot& r = state(robot);
  r = Robot(prototype_);
  visits_.reset(robot);
  const std::size_t size = static_cast<std::size_t>(n);
  r.alive.assign(size, 1);
  r.lost_at.assign(size, kInf);
  r.heard.assign(size, Heard{});
  r.has_heard.assign(size, 0);
  r.mate_arc.assign(size, 0.0);
  r.has_mate_arc.assign(size, 0);
  for (int k = 0; k < n; ++k) history(r, k) = Recent{};
  r.pace.assign(size, params_.speed_mps);
  r.last_announce = -kInf;
  r.started = true;
  install_plan(host, robot, true);
}

void TpuafPlusStrategy::install_plan(StrategyHost& host, int robot, bool initial) {
  Robot& r = state(robot);
  std::shared_ptr<const PlusPlan> old_plan = r.plan;
  const PlusRoute* old_route = old_plan ? &route_of(r) : nullptr;
  r.plan = plan_for(team(robot));
  r.route = r.plan->route_of[static_cast<std::size_t>(robot)];
  const PlusRoute& route = route_of(r);
  r.has_departure = false;
  r.respacing = false;
  const auto& schedule = r.plan->schedule;
  const bool scheduled = static_cast<std::size_t>(robot) < schedule.size() &&
                         schedule[static_cast<std::size_t>(robot)].first >= 0;
  if (initial && scheduled) {
    r.entry = schedule[static_cast<std::size_t>(robot)].first;
    r.departure = schedule[static_cast<std::size_t>(robot)].second;
    r.has_departure = true;
    r.idx = -1;
  } else if (old_route != nullptr && old_route->walk == route.walk) {
    // same walk (a cycle): keep my place on it; after a loss, re-space at once
    if (route.robots.size() < old_route->robots.size()) {
      double target = 0;
      r.respacing = respace_target(r, robot, host.now(), target);
      r.respace_target = target;
      r.respace_at = host.now();
    }
  } else if (route.robots.size() == 1 && route.walk.size() > 1) {  // a new part alone
    r.entry = urgent_entry(robot, route, host.current_vertex(robot), host.now());
    r.idx = -1;
  } else {
    // a walk new to several robots: the start schedule's entries from where each stood
    const std::map<int, int> entries = transition_entries(r, robot);
    auto it = entries.find(robot);
    r.entry = it != entries.end() ? it->second
                                  : nearest_entry(*graph_, route, host.current_vertex(robot));
    r.idx = -1;
  }
  r.holding = false;
}

int TpuafPlusStrategy::urgent_entry(int robot, const PlusRoute& route, int vertex,
                                    double now) const {
  // min over entries k of max over walk entries i of (drive to k + arc k -> i + idleness of i)
  // [s], rounded to 1e-6 s as np.round; ties to the nearer entry, then the lower index.
  const std::size_t n = route.walk.size();
  const double speed = params_.speed_mps;
  std::vector<double> idle(n), reach(n), worst(n);
  for (std::size_t i = 0; i < n; ++i) {
    idle[i] = now - visits_.last_visit(robot, route.walk[i]);
    reach[i] = distance(vertex, route.walk[i]) / speed;
  }
  for (std::size_t k = 0; k < n; ++k) {
    double top = -kInf;
    for (std::size_t i = 0; i < n; ++i) {
      const double ahead = py_mod(route.arc[i] - route.arc[k], route.length) / speed;
      top = std::max(top, reach[k] + ahead + idle[i]);
    }
    worst[k] = std::nearbyint(top * 1e6) / 1e6;
  }
  std::size_t best = 0;
  for (std::size_t k = 1; k < n; ++k) {
    if (worst[k] < worst[best] || (worst[k] == worst[best] && reach[k] < reach[best])) best = k;
  }
  return static_cast<int>(best);
}

std::map<int, int> TpuafPlusStrategy::transition_entries(const Robot& r, int robot) const {
  // Each robot of my new walk starts at the vertex its last announcement before the team
  // change headed to, late by what was left of that drive; {} when one was never heard.
  const double t_ref = r.changed_at;
  const double speed = params_.speed_mps;
  const PlusRoute& route = route_of(r);
  std::vector<int> starts;
  std::vector<double> late;
  for (int k : route.robots) {
    const Heard* info = nullptr;
    for (const Heard& h : history(r, k)) {
      if (h.sent <= t_ref + kEps) info = &h;
    }
    if (info == nullptr) return {};
    starts.push_back(info->to);
    late.push_back(std::max(0.0, info->departure + distance(info->from, info->to) / speed - t_ref) *
                   speed);
  }
  std::vector<double> idle(static_cast<std::size_t>(graph_->num_vertices()));
  for (int v = 0; v < graph_->num_vertices(); ++v) {
    idle[static_cast<std::size_t>(v)] = std::max(t_ref - visits_.last_visit(robot, v), 0.0);
  }
  const auto plan = start_schedule(*graph_, route, starts, late, speed, &idle);
  std::map<int, int> out;
  for (std::size_t j = 0; j < plan.size(); ++j) out[route.robots[j]] = plan[j].first;
  return out;
}

bool TpuafPlusStrategy::respace_target(Robot& r, int robot, double now, double& target) {
  // The survivors' even spacing L / m keeping their cyclic order with the least dwell of
  // anyone: e_j = p_j - j L / m, my target = my arc - (e_0 - min e).
  const PlusRoute& route = route_of(r);
  const double L = route.length;
  const std::size_t m = route.robots.size();
  if (r.idx < 0 || m < 2 || L <= 0) return false;
  double mine = route.arc[static_cast<std::size_t>(r.idx)];
  if (r.holding) mine -= params_.speed_mps * std::max(0.0, r.hold_until - now);
  std::vector<std::pair<int, double>> arcs{{robot, py_mod(mine, L)}};
  for (int k : route.robots) {
    if (k == robot) continue;
    double arc = 0;
    if (!mate_arc(r, k, now, arc)) return false;
    arcs.emplace_back(k, arc);
  }
  const double me = arcs[0].second;
  std::vector<std::pair<double, int>> order;  // ((arc - mine) mod L, -k)
  for (const auto& [k, arc] : arcs) order.emplace_back(py_mod(arc - me, L), -k);
  std::sort(order.begin(), order.end());
  std::vector<double> e(m);
  double e_min = kInf;
  for (std::size_t j = 0; j < m; ++j) {
    e[j] = (me + order[j].first) - static_cast<double>(j) * (L / static_cast<double>(m));
    e_min = std::min(e_min, e[j]);
  }
  target = mine - (e[0] - e_min);
  return true;
}

double TpuafPlusStrategy::idle_room(Robot& r, int robot, double now) {
  // How long I can dwell before a walk vertex ahead (up to the nearest mate ahead, within
  // L / m) waits longer than L / (m v): min of L / (m v) - its idleness - my drive to it.
  const PlusRoute& route = route_of(r);
  const std::size_t n = route.walk.size();
  const double L = route.length, speed = params_.speed_mps;
  const double here = route.arc[static_cast<std::size_t>(r.idx)];
  const double even = L / static_cast<double>(route.robots.size());
  double reach = even;
  for (int k : route.robots) {
    if (k == robot) continue;
    double arc = 0, dwell = 0;
    if (mate_arc(r, k, now, arc, &dwell)) {  // a dwelling mate is at its vertex
      reach = std::min(reach, py_mod(arc + dwell - here, L));
    }
  }
  double room = kInf;
  for (std::size_t step = 1; step < n; ++step) {
    const std::size_t i = (static_cast<std::size_t>(r.idx) + step) % n;
    const double d = py_mod(route.arc[i] - here, L);
    if (d > reach + kEps) break;
    room = std::min(room, (even - d) / speed - (now - visits_.last_visit(robot, route.walk[i])));
  }
  return std::isfinite(room) ? std::max(0.0, room) : 0.0;
}

double TpuafPlusStrategy::respace_wait(Robot& r, int robot, double now) {
  // What is left of my re-spacing dwell, capped by idle_room; done below the deadband or
  // after a lap.
  const PlusRoute& route = route_of(r);
  const double L = route.length, speed = params_.speed_mps;
  const double behind = py_mod(
      route.arc[static_cast<std::size_t>(r.idx)] - r.respace_target - speed * (now - r.respace_at),
      L);
  const double left = behind < L / 2 ? behind / speed : 0.0;
  const double wait = std::min(left, idle_room(r, robot, now));
  if (left - wait <= params_.deadband_s || now - r.respace_at > L / speed) r.respacing = false;
  return wait;
}

// ------------------------------------------------------------------ messages

void TpuafPlusStrategy::heard_from(Robot& r, int k, double sent) const {
  double& lost = r.lost_at[static_cast<std::size_t>(k)];
  if (sent > lost) lost = kInf;  // heard again after it was reported lost
}

void TpuafPlusStrategy::remember(Robot& r, int robot, const Heard& entry) {
  history(r, robot).push(entry);
}

TpuafPlusStrategy::Recent& TpuafPlusStrategy::history(const Robot& r, int k) {
  const auto holder = static_cast<std::size_t>(&r - robots_.data());
  return histories_[static_cast<std::size_t>(k) * robots_.size() + holder];
}

const TpuafPlusStrategy::Recent& TpuafPlusStrategy::history(const Robot& r, int k) const {
  const auto holder = static_cast<std::size_t>(&r - robots_.data());
  return histories_[static_cast<std::size_t>(k) * robots_.size() + holder];
}

void TpuafPlusStrategy::learn_pace(Robot& r, int k, int vertex, double arrived_s) const {
  // One pace sample of robot k, at `vertex` at arrived_s [s]: the drive its newest announcement
  // before then headed here on, length / (arrival - departure) [m/s].
  const Heard* last = nullptr;
  for (const Heard& h : history(r, k)) {
    if (h.sent <= arrived_s + kEps) last = &h;
  }
  if (last == nullptr || last->from == last->to || last->to != vertex) return;
  const double drive_s = arrived_s - last->departure;
  if (!(drive_s > kEps)) return;
  // [m] the drive: a step of my walk by its arcs (the edge driven, which a shortcut may
  // undercut), else the shortest path
  double drive_m = distance(last->from, vertex);
  if (r.plan && r.route >= 0) {
    const PlusRoute& route = route_of(r);
    for (const int i : route.positions(last->from, vertex)) {
      const auto j = static_cast<std::size_t>(i);
      drive_m = (j + 1 < route.arc.size() ? route.arc[j + 1] : route.length) - route.arc[j];
      break;
    }
  }
  double& pace = r.pace[static_cast<std::size_t>(k)];
  pace = update_pace(pace, drive_m / drive_s, params_.pace_weight, params_.speed_mps);
}

void TpuafPlusStrategy::on_message(StrategyHost& /*host*/, int robot, const TeamMessage& message) {
  Robot& r = state(robot);
  const int k = message.robot;
  if (k < 0 || k >= static_cast<int>(r.heard.size())) return;
  const double sent = message.time_s;
  Heard& latest = r.heard[static_cast<std::size_t>(k)];
  char& has = r.has_heard[static_cast<std::size_t>(k)];
  if (message.kind == TeamMessage::Kind::kVisit) {
    visits_.record(robot, message.vertex, sent);  // TpuafKnowledge::hear_visit's record
    heard_from(r, k, sent);
    learn_pace(r, k, message.vertex, sent);
    const int next = message.next_vertex >= 0 ? message.next_vertex : message.vertex;
    const Heard entry{message.vertex, next, sent, sent};
    remember(r, k, entry);
    if (!has || sent > latest.sent + kEps) {
      latest = entry;
      has = 1;
      track_mate(r, k, entry.from, entry.to, sent);
    }
  } else if (message.kind == TeamMessage::Kind::kIntention) {
    heard_from(r, k, sent);
    const double departure = message.expected_arrival_s - message.travel_time_s;
    const Heard entry{message.from_vertex, message.vertex, departure, sent};
    remember(r, k, entry);
    if (!has || sent >= latest.sent - kEps) {
      latest = entry;
      has = 1;
      track_mate(r, k, entry.from, entry.to, sent);
    }
  }
}

void TpuafPlusStrategy::on_teammate_lost(StrategyHost& host, int robot, int lost) {
  Robot& r = state(robot);
  if (lost >= 0 && lost < static_cast<int>(r.lost_at.size())) {
    r.lost_at[static_cast<std::size_t>(lost)] = host.now();
  }
}

void TpuafPlusStrategy::update_team(StrategyHost& host, int robot) {
  // Mates the runtime's liveness rule reported lost leave (on_teammate_lost); one heard again
  // rejoins (heard_from).
  Robot& r = state(robot);
  const double now = host.now();
  const std::size_t n = r.alive.size();
  std::vector<char> alive(n, 0);
  for (std::size_t k = 0; k < n; ++k) {
    alive[k] = static_cast<int>(k) == robot || std::isinf(r.lost_at[k]);
  }
  if (alive == r.alive) return;
  // dated as every survivor dates it: the loss report
  double latest_gone = -kInf;
  bool any_gone = false;
  for (std::size_t k = 0; k < n; ++k) {
    if (r.alive[k] && !alive[k]) {
      any_gone = true;
      latest_gone = std::max(latest_gone, r.lost_at[k]);
    }
  }
  r.changed_at = any_gone ? std::min(latest_gone, now) : now;
  r.alive = std::move(alive);
  install_plan(host, robot, false);
}

void TpuafPlusStrategy::replan(StrategyHost& host, int robot, PlanSource plans) {
  graph_ = &host.graph();
  if (timing_ != nullptr) timing_ = graph_;  // re-timed (retime): on the new graph's lengths
  std::fill(lengths_.begin(), lengths_.end(), KnownLength{});
  plans_ = std::move(plans);
  plan_cache_.clear();
  if (state(robot).started) install_plan(host, robot, false);
}

// ------------------------------------------------------------------ decisions

void TpuafPlusStrategy::announce(StrategyHost& host, int robot, int here, int next,
                                 double departure, bool visit) {
  Robot& r = state(robot);
  const double now = host.now();
  const double travel = next != here ? graph_->edge_length(here, next) / params_.speed_mps : 0.0;
  if (visit) host.send(robot, TeamMessage::visit(robot, here, now, next));
  host.send(robot, TeamMessage::intention(robot, here, next, departure + travel, travel, now));
  remember(r, robot, Heard{here, next, departure, now});
  r.last_announce = now;
}

int TpuafPlusStrategy::hold(StrategyHost& host, int robot, int here, bool waking) {
  // While dwelling: re-visit my vertex every dwell_revisit_s; kDepart at hold_until.
  Robot& r = state(robot);
  const double now = host.now();
  const double remaining = r.hold_until - now;
  if (remaining <= kEps) return kDepart;
  const double stay = params_.stay_s;
  if (waking && remaining >= stay - kEps) return here;  // a re-visit; it ends stay_s later
  const double nap =
      remaining < stay + 0.1 ? remaining : std::min(remaining - stay, params_.dwell_revisit_s);
  host.wake_at(robot, now + nap);
  return kWait;
}

int TpuafPlusStrategy::decide(StrategyHost& host, int robot) {
  if (!state(robot).started) start(host, robot);
  Robot& r = state(robot);
  const double now = host.now();
  const int here = host.current_vertex(robot);
  const bool waking = r.waking;
  r.waking = false;
  if (!waking) {
    visits_.record(robot, here, now);
    learn_pace(r, robot, here, now);  // my own drive here
  }
  update_team(host, robot);
  const PlusRoute& route = route_of(r);
  if (r.idx >= 0 && route.walk[static_cast<std::size_t>(r.idx)] != here) {  // off my walk
    r.idx = -1;
    r.holding = false;
    r.entry = nearest_entry(*graph_, route, here);
  }
  if (r.idx < 0) {  // driving to my walk
    const int target = route.walk[static_cast<std::size_t>(r.entry)];
    if (here != target) {
      const int hop = repair_hop(host, robot, here, target);
      announce(host, robot, here, hop, now, !waking);
      return hop;
    }
    r.idx = r.entry;
  }
  if (route.walk.size() == 1) {  // a one-vertex part: stay, re-visiting it
    if (now - r.last_announce >= params_.dwell_revisit_s - kEps) {
      announce(host, robot, here, here, now + params_.stay_s, true);
    }
    return here;
  }
  return step(host, robot, waking);
}

int TpuafPlusStrategy::step(StrategyHost& host, int robot, bool waking) {
  Robot& r = state(robot);
  const double now = host.now();
  const int here = host.current_vertex(robot);
  const PlusRoute& route = route_of(r);
  const int next_idx = (r.idx + 1) % static_cast<int>(route.walk.size());
  const int next = route.walk[static_cast<std::size_t>(next_idx)];
  if (!r.holding) {
    double wait = 0;
    if (r.has_departure) {  // the start schedule
      wait = std::max(0.0, r.departure - now);
      r.has_departure = false;
    } else if (r.respacing) {
      wait = respace_wait(r, robot, now);
    } else {
      wait = spacing_wait(r, robot, now);
    }
    if (wait > params_.deadband_s) {
      r.holding = true;
      r.hold_until = now + wait;
      announce(host, robot, here, next, r.hold_until, true);
    }
  } else if (!waking) {
    announce(host, robot, here, next, r.hold_until, true);  // heartbeat
  }
  if (r.holding) {
    const int action = hold(host, robot, here, waking);
    if (action == kWait) {
      r.waking = true;
      return kWait;
    }
    if (action != kDepart) return action;
    r.holding = false;
    announce(host, robot, here, next, now, false);
  } else {
    announce(host, robot, here, next, now, true);
  }
  r.idx = next_idx;
  return next;
}

int TpuafPlusStrategy::repair_hop(StrategyHost& host, int robot, int here, int target) {
  // Among the neighbours on a shortest path to target, the one of maximal TPUAF utility
  // (Eq. 13), so that driving to a new part also repairs gaps.
  std::vector<int> nbrs;
  for (int w : graph_->neighbours(here)) {
    if (w != here) nbrs.push_back(w);
  }
  std::sort(nbrs.begin(), nbrs.end());
  nbrs.erase(std::unique(nbrs.begin(), nbrs.end()), nbrs.end());
  const double best = distance(here, target);
  std::vector<int> on_path;
  for (int w : nbrs) {
    if (std::abs(graph_->edge_length(here, w) + distance(w, target) - best) <= 1e-6 * (1 + best)) {
      on_path.push_back(w);
    }
  }
  if (on_path.size() == 1) return on_path[0];
  if (on_path.empty()) {
    int pick = -1;
    for (int w : nbrs) {
      if (pick < 0 || distance(w, target) < distance(pick, target)) pick = w;
    }
    return pick;
  }
  Robot& r = state(robot);
  std::vector<int> lent = on_path;
  lent.push_back(here);
  visits_.lend(robot, lent, r.knowledge);  // what Eq. 13 reads of them
  const UtilityResult result = r.knowledge.utilities(*graph_, host.now(), here, on_path,
                                                     params_.speed_mps, UtilityForm::kEq13, false);
  Eigen::Index pick = 0;  // np.argmax: the first maximum (a NaN wins)
  for (Eigen::Index j = 1; j < result.utility.size(); ++j) {
    if (std::isnan(result.utility[pick])) break;
    if (result.utility[j] > result.utility[pick] || std::isnan(result.utility[j])) pick = j;
  }
  return on_path[static_cast<std::size_t>(pick)];
}

void TpuafPlusStrategy::on_goal_failed(StrategyHost& host, int robot, int vertex) {
  Robot& r = state(robot);
  r.idx = -1;
  r.holding = false;
  const PlusRoute& route = route_of(r);
  r.entry = nearest_entry(*graph_, route, host.current_vertex(robot));
  // The goal given up on is no way back onto the walk: when it is the entry or the vertex
  // after it, join the walk after it, so that a vertex no robot can reach (a dead robot's body
  // on it) is skipped, not tried again and again.
  const std::size_t n = route.walk.size();
  for (std::size_t s = 0; n > 1 && s < 2; ++s) {
    const std::size_t k = (static_cast<std::size_t>(r.entry) + s) % n;
    if (route.walk[k] == vertex) {
      r.entry = static_cast<int>((k + 1) % n);
      break;
    }
  }
}

}  // namespace tpuaf
