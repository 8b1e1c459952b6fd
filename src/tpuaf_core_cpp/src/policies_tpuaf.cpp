// TPUAF's decision path in C++ (the same steps as tpuaf/policies/tpuaf.py, in the same order).
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "tpuaf_core/strategies.hpp"

namespace tpuaf {

TpuafStrategy::TpuafStrategy(const TpuafKnowledge& knowledge, UtilityForm form, bool any_vertex,
                             std::vector<NumpyPcg64> rngs, bool colocation)
    : prototype_(knowledge),
      form_(form),
      any_vertex_(any_vertex),
      rngs_(std::move(rngs)),
      colocation_(colocation) {
  colocated_.resize(rngs_.size());
  failed_.resize(rngs_.size());
  prototype_.share_visit_results();  // the team hears the same visits: one Eq. 2 per visit
  knowledge_.assign(rngs_.size(), prototype_);
}

TpuafKnowledge TpuafStrategy::knowledge(int robot) const {
  if (robot < 0 || robot >= static_cast<int>(rngs_.size())) {
    throw std::out_of_range("unknown robot " + std::to_string(robot));
  }
  if (shared_) return knowledge_[0].as_robot(robot);
  return knowledge_[static_cast<std::size_t>(robot)];
}

void TpuafStrategy::start(StrategyHost& host, int robot) {
  if (static_cast<int>(rngs_.size()) != host.robots()) {
    throw std::invalid_argument("TPUAF needs one random stream per robot: got " +
                                std::to_string(rngs_.size()) + " for " +
                                std::to_string(host.robots()) + " robots");
  }
  const bool shared = host.team_hears_alike();
  if (robot == 0 || shared != shared_) {  // a new run: the team's or every robot's copy
    shared_ = shared;
    knowledge_.assign(shared_ ? 1 : rngs_.size(), prototype_);
  } else if (!shared_) {
    knowledge_[static_cast<std::size_t>(robot)] = prototype_;
  }
  Colocation& c = colocated_[static_cast<std::size_t>(robot)];
  c = Colocation{};
  failed_[static_cast<std::size_t>(robot)].clear();
  c.shadows.assign(static_cast<std::size_t>(host.robots()), 0);
}

void TpuafStrategy::presume_choice(StrategyHost& host, int robot, int mate) {
  // Teammate `mate`'s presumed choice here (argmax of the same utility, the first on ties)
  // counts as its announced intention (only under delay: never with a shared knowledge).
  TpuafKnowledge& k = knowledge_of(robot);
  const double now = host.now();
  const int here = host.current_vertex(robot);
  const UtilityResult result = k.utilities(host.graph(), now, here, candidates_,
                                           host.average_speed(robot), form_, any_vertex_);
  Eigen::Index best = 0;  // np.argmax: the first maximum (a NaN wins)
  for (Eigen::Index j = 1; j < result.utility.size(); ++j) {
    if (std::isnan(result.utility[best])) break;
    if (result.utility[j] > result.utility[best] || std::isnan(result.utility[j])) best = j;
  }
  k.hear_intention({mate, here, candidates_[static_cast<std::size_t>(best)], result.arrival_s[best],
                    result.travel_time_s[best], now});
}

void TpuafStrategy::track_shadow(int robot, const TeamMessage& visit) {
  // A teammate's visit at (about) my own visit of that vertex, followed by the same next
  // vertex, makes it my shadow; any other visit of it ends that.
  Colocation& c = colocated_[static_cast<std::size_t>(robot)];
  const double tol = std::max(1.0, 0.1 * c.latency_s);
  bool same = false;
  auto it = c.my_visits.find(visit.vertex);
  if (it != c.my_visits.end()) {
    for (const auto& [t, next] : it->second) {
      if (std::abs(t - visit.time_s) <= tol && next == visit.next_vertex) same = true;
    }
  }
  if (visit.robot >= 0 && static_cast<std::size_t>(visit.robot) < c.shadows.size()) {
    c.shadows[static_cast<std::size_t>(visit.robot)] = same ? 1 : 0;
  }
}

// Teammates that reached `here` within the latency of now, whose next decision is not heard
// yet (their intention for it held), and my shadows: the lower-indexed ones decide first.
void TpuafStrategy::resolve_colocation(StrategyHost& host, int robot, const TpuafKnowledge& k,
                                       int here, double now) {
  const Colocation& col = colocated_[static_cast<std::size_t>(robot)];
  const double window = col.latency_s + 1e-6;
  std::vector<int> mates;
  for (const Intention& i : k.intentions()) {
    if (i.robot != robot && i.vertex == here && now - window <= i.expected_arrival_s &&
        i.expected_arrival_s <= now + 1e-6) {
      mates.push_back(i.robot);
    }
  }
  for (std::size_t m = 0; m < col.shadows.size(); ++m) {
    if (col.shadows[m] && static_cast<int>(m) != robot) mates.push_back(static_cast<int>(m));
  }
  std::sort(mates.begin(), mates.end());
  mates.erase(std::unique(mates.begin(), mates.end()), mates.end());
  for (int mate : mates) {
    if (mate < robot) presume_choice(host, robot, mate);
  }
}

// Index of the best utility; a seeded tie-break (rng.choice of the best) among equals.
int TpuafStrategy::choose(int robot, const Eigen::VectorXd& utility) {
  double top = utility[0];
  for (Eigen::Index j = 1; j < utility.size(); ++j) {
    if (utility[j] > top || std::isnan(utility[j])) top = utility[j];
    if (std::isnan(top)) break;
  }
  const double absolute = std::abs(top);
  const double threshold = top - 1e-12 * (absolute > 1.0 ? absolute : 1.0);
  int first = -1, count = 0;
  for (Eigen::Index j = 0; j < utility.size(); ++j) {
    if (utility[j] >= threshold) {
      if (count == 0) first = static_cast<int>(j);
      ++count;
    }
  }
  if (count == 0) {
    throw std::runtime_error("strategy 'tpuaf' failed for robot " + std::to_string(robot) +
                             ": no candidate has a finite utility");
  }
  int chosen = first;
  if (count > 1) {  // seeded tie-break: rng.choice(best)
    const std::int64_t pick = rngs_[static_cast<std::size_t>(robot)].integers(count);
    int seen = 0;
    for (Eigen::Index j = 0; j < utility.size(); ++j) {
      if (utility[j] >= threshold && seen++ == pick) {
        chosen = static_cast<int>(j);
        break;
      }
    }
  }
  return chosen;
}

int TpuafStrategy::decide(StrategyHost& host, int robot) {
  TpuafKnowledge& k = knowledge_of(robot);
  const double now = host.now();
  const int here = host.current_vertex(robot);
  k.record_visit(here, now);  // shared: the teammates' hearing of it, too
  // Never count my own old intention (a shared knowledge keeps it for the teammates and
  // leaves it out of my utilities).
  if (!shared_) k.forget_intention(robot);
  const int exclude = shared_ ? robot : -1;
  const PatrolGraph& graph = host.graph();
  candidates_.clear();
  if (any_vertex_) {
    for (int v = 0; v < graph.num_vertices(); ++v) {
      if (v != here) candidates_.push_back(v);
    }
  } else {
    candidates_ = graph.neighbours(here);
  }
  auto& failed = failed_[static_cast<std::size_t>(robot)];
  failed.erase(here);     // reached: its failures are forgotten
  if (!failed.empty()) {  // goals given up on twice lately are no candidates, unless all are
    std::vector<int> kept;
    for (int v : candidates_) {
      auto it = failed.find(v);
      if (it == failed.end() || it->second.first < 2 ||
          now - it->second.second >= kFailedGoalHoldS) {
        kept.push_back(v);
      }
    }
    if (!kept.empty()) candidates_.swap(kept);
  }
  if (candidates_.empty()) {  // a one-vertex graph: stay
    host.send(robot, TeamMessage::visit(robot, here, now, here));
    return here;
  }
  Colocation& col = colocated_[static_cast<std::size_t>(robot)];
  if (colocation_ && col.latency_s > 0) resolve_colocation(host, robot, k, here, now);
  const UtilityResult result = k.utilities(graph, now, here, candidates_, host.average_speed(robot),
                                           form_, any_vertex_, exclude);
  const int chosen = choose(robot, result.utility);
  const int target = candidates_[static_cast<std::size_t>(chosen)];
  // Own visits and shadows only matter once a message arrived late, which needs a delay.
  if (colocation_ && host.messages_may_be_late()) {
    auto& mine = col.my_visits[here];
    mine.emplace_back(now, target);
    while (mine.size() > 4) mine.pop_front();
  }
  host.send(robot, TeamMessage::visit(robot, here, now, target));
  host.send(robot, TeamMessage::intention(robot, here, target, result.arrival_s[chosen],
                                          result.travel_time_s[chosen], now));
  return target;
}

void TpuafStrategy::on_goal_failed(StrategyHost& host, int robot, int vertex) {
  const double now = host.now();
  auto& [count, last] = failed_[static_cast<std::size_t>(robot)][vertex];
  count = count > 0 && now - last < kFailedGoalHoldS ? count + 1 : 1;
  last = now;
}

bool TpuafStrategy::on_team_message(StrategyHost& /*host*/, int sender,
                                    const TeamMessage& message) {
  if (!shared_) return false;
  TpuafKnowledge& k = knowledge_[0];
  bool kept = true;
  if (message.kind == TeamMessage::Kind::kVisit) {
    kept = k.hear_team_visit(message.robot, message.vertex);
  } else if (message.kind == TeamMessage::Kind::kIntention) {
    kept =
        k.hear_team_intention({message.robot, message.from_vertex, message.vertex,
                               message.expected_arrival_s, message.travel_time_s, message.time_s});
  }
  // Without delay the latency is 0 and nothing of Colocation changes; other kinds are ignored
  // as on_message ignores them.
  if (!kept) {
    throw std::logic_error("TPUAF's shared team knowledge: robot " + std::to_string(sender) +
                           " sent a message out of the visit-then-intention pattern");
  }
  return true;
}

void TpuafStrategy::on_teammate_lost(StrategyHost& host, int robot, int lost) {
  if (shared_) {
    throw std::logic_error("TPUAF's shared team knowledge cannot forget one robot's teammate");
  }
  knowledge_of(robot).forget_intention(lost);
  Colocation& c = colocated_[static_cast<std::size_t>(robot)];
  if (lost >= 0 && lost < host.robots()) c.shadows[static_cast<std::size_t>(lost)] = 0;
}

void TpuafStrategy::on_message(StrategyHost& host, int robot, const TeamMessage& message) {
  TpuafKnowledge& k = knowledge_of(robot);
  if (message.kind == TeamMessage::Kind::kVisit || message.kind == TeamMessage::Kind::kIntention) {
    Colocation& c = colocated_[static_cast<std::size_t>(robot)];
    const double latency = host.now() - message.time_s;
    if (latency > c.latency_s) c.latency_s = latency;  // Python's max(latency, now - sent)
  }
  if (message.kind == TeamMessage::Kind::kVisit) {
    k.hear_visit(message.robot, message.vertex, message.time_s);
    if (colocation_ && host.messages_may_be_late()) track_shadow(robot, message);
  } else if (message.kind == TeamMessage::Kind::kIntention) {
    k.hear_intention({message.robot, message.from_vertex, message.vertex,
                      message.expected_arrival_s, message.travel_time_s, message.time_s});
  }
}

}  // namespace tpuaf
