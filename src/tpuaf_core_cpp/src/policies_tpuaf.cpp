// TPUAF's decision path in C++ (the same steps as tpuaf/policies/tpuaf.py, in the same order).
#include <cmath>
#include <stdexcept>
#include <string>

#include "tpuaf_core/engine.hpp"

namespace tpuaf {

TpuafStrategy::TpuafStrategy(const TpuafKnowledge& knowledge, UtilityForm form, bool any_vertex,
                             std::vector<NumpyPcg64> rngs)
    : prototype_(knowledge), form_(form), any_vertex_(any_vertex), rngs_(std::move(rngs)) {
  prototype_.share_visit_results();  // the team hears the same visits: one Eq. 2 per visit
  knowledge_.assign(rngs_.size(), prototype_);
}

const TpuafKnowledge& TpuafStrategy::knowledge(int robot) const {
  if (robot < 0 || robot >= static_cast<int>(knowledge_.size())) {
    throw std::out_of_range("unknown robot " + std::to_string(robot));
  }
  return knowledge_[static_cast<std::size_t>(robot)];
}

void TpuafStrategy::start(GraphEngine& engine, int robot) {
  if (static_cast<int>(rngs_.size()) != engine.robots()) {
    throw std::invalid_argument("TPUAF needs one random stream per robot: got " +
                                std::to_string(rngs_.size()) + " for " +
                                std::to_string(engine.robots()) + " robots");
  }
  knowledge_[static_cast<std::size_t>(robot)] = prototype_;
}

int TpuafStrategy::decide(GraphEngine& engine, int robot) {
  TpuafKnowledge& k = knowledge_[static_cast<std::size_t>(robot)];
  const double now = engine.now();
  const int here = engine.current_vertex(robot);
  k.record_visit(here, now);
  k.forget_intention(robot);  // never count my own old intention
  const PatrolGraph& graph = engine.graph();
  candidates_.clear();
  if (any_vertex_) {
    for (int v = 0; v < graph.num_vertices(); ++v) {
      if (v != here) candidates_.push_back(v);
    }
  } else {
    candidates_ = graph.neighbours(here);
  }
  TeamMessage visit;
  visit.kind = TeamMessage::Kind::kVisit;
  visit.robot = robot;
  visit.vertex = here;
  visit.time_s = now;
  if (candidates_.empty()) {  // a one-vertex graph: stay
    visit.next_vertex = here;
    engine.send(robot, visit);
    return here;
  }
  const UtilityResult result =
      k.utilities(graph, now, here, candidates_, engine.average_speed(robot), form_, any_vertex_);
  const Eigen::VectorXd& utility = result.utility;
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
  const int target = candidates_[static_cast<std::size_t>(chosen)];
  visit.next_vertex = target;
  engine.send(robot, visit);
  TeamMessage intention;
  intention.kind = TeamMessage::Kind::kIntention;
  intention.robot = robot;
  intention.from_vertex = here;
  intention.vertex = target;
  intention.expected_arrival_s = result.arrival_s[chosen];
  intention.travel_time_s = result.travel_time_s[chosen];
  intention.time_s = now;
  engine.send(robot, intention);
  return target;
}

void TpuafStrategy::on_message(GraphEngine& engine, int robot, const TeamMessage& message) {
  TpuafKnowledge& k = knowledge_[static_cast<std::size_t>(robot)];
  if (message.kind == TeamMessage::Kind::kVisit) {
    k.hear_visit(message.robot, message.vertex, message.time_s, engine.now());
  } else if (message.kind == TeamMessage::Kind::kIntention) {
    k.hear_intention({message.robot, message.from_vertex, message.vertex,
                      message.expected_arrival_s, message.travel_time_s, message.time_s},
                     engine.now());
  }
}

}  // namespace tpuaf
