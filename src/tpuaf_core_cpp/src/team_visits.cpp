#include "tpuaf_core/team_visits.hpp"

#include <stdexcept>
#include <string>

namespace tpuaf {

TeamVisits::TeamVisits(const TpuafKnowledge& initial, int n_robots)
    : rule_(&initial), robots_(n_robots) {
  if (n_robots < 0) throw std::invalid_argument("TeamVisits: n_robots must be >= 0");
  const int n = initial.size();
  initial_.resize(static_cast<std::size_t>(n));
  for (int v = 0; v < n; ++v) {
    const double time = initial.anchor_time(v);
    if (!(initial.last_visit()[v] == time)) {  // record_visit keeps them equal
      throw std::invalid_argument("TeamVisits: vertex " + std::to_string(v) +
                                  "'s newest visit is not its estimate's anchor");
    }
    initial_[static_cast<std::size_t>(v)] = {initial.anchor_value(v), time};
  }
  anchors_.resize(initial_.size() * static_cast<std::size_t>(robots_));
  for (int r = 0; r < robots_; ++r) reset(r);
  results_.resize(initial_.size());
}

std::size_t TeamVisits::index(int robot, int vertex) const {
  if (robot < 0 || robot >= robots_) {
    throw std::out_of_range("unknown robot " + std::to_string(robot));
  }
  if (vertex < 0 || vertex >= static_cast<int>(initial_.size())) {
    throw std::out_of_range("unknown vertex index " + std::to_string(vertex) + " (graph has " +
                            std::to_string(initial_.size()) + " vertices)");
  }
  return static_cast<std::size_t>(vertex) * static_cast<std::size_t>(robots_) +
         static_cast<std::size_t>(robot);
}

void TeamVisits::reset(int robot) {
  for (std::size_t v = 0; v < initial_.size(); ++v) {
    anchors_[index(robot, static_cast<int>(v))] = initial_[v];
  }
}

void TeamVisits::record(int robot, int vertex, double time_s) {
  Anchor& anchor = anchors_[index(robot, vertex)];
  // TpuafKnowledge::record_visit: its newest visit is max(newest, time_s) and equals the
  // anchor's time, which moves only for a visit at least as new.
  if (time_s < anchor.time) return;
  Result& result = results_[static_cast<std::size_t>(vertex)];
  if (result.valid && result.value_in == anchor.value && result.time_in == anchor.time &&
      result.visit_time == time_s) {
    anchor = {result.value_out, time_s};
    return;
  }
  const double value = rule_->after_visit(vertex, anchor.value, anchor.time, time_s);
  result = {anchor.value, anchor.time, time_s, value, true};
  anchor = {value, time_s};
}

void TeamVisits::lend(int robot, const std::vector<int>& vertices,
                      TpuafKnowledge& knowledge) const {
  for (int v : vertices) {
    const Anchor& anchor = anchors_[index(robot, v)];
    knowledge.set_visit_state(v, anchor.value, anchor.time);
  }
}

}  // namespace tpuaf
