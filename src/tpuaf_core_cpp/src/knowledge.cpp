#include "tpuaf_core/knowledge.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

namespace tpuaf {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}

TpuafKnowledge::TpuafKnowledge(const Eigen::VectorXd& importance, const Eigen::VectorXd& initial,
                               UncertaintyModel model, double pass_coverage, double pass_time_s,
                               double intention_timeout_s, double silence_timeout_s)
    : importance_(importance),
      last_visit_(Eigen::VectorXd::Zero(importance.size())),
      anchor_value_(initial),
      anchor_time_(Eigen::VectorXd::Zero(importance.size())),
      model_(std::move(model)),
      pass_coverage_(pass_coverage),
      pass_time_s_(pass_time_s),
      intention_timeout_s_(intention_timeout_s),
      silence_timeout_s_(silence_timeout_s) {
  model_.validate();
  if (initial.size() != importance.size()) {
    throw std::invalid_argument("need one importance C and one initial X0 per vertex");
  }
  if (!(pass_coverage >= 0) || !(pass_time_s >= 0)) {
    throw std::invalid_argument("pass coverage and pass time must be >= 0");
  }
  if (!(intention_timeout_s > 0) || !(silence_timeout_s > 0)) {
    throw std::invalid_argument("timeouts must be > 0 s");
  }
}

void TpuafKnowledge::check_vertex(int v) const {
  if (v < 0 || v >= size()) {
    throw std::out_of_range("unknown vertex index " + std::to_string(v) + " (graph has " +
                            std::to_string(size()) + " vertices)");
  }
}

void TpuafKnowledge::record_visit(int vertex, double time_s) {
  check_vertex(vertex);
  last_visit_[vertex] = std::max(last_visit_[vertex], time_s);
  if (time_s < anchor_time_[vertex]) return;  // older than what the estimate already holds
  const double c = importance_[vertex];
  const double x = model_.evolve(anchor_value_[vertex], c, time_s - anchor_time_[vertex]);
  anchor_value_[vertex] = model_.evolve(x, c - pass_coverage_, pass_time_s_);
  anchor_time_[vertex] = time_s;
}

void TpuafKnowledge::hear_visit(int robot, int vertex, double time_s, double now_s) {
  if (robot < 0) throw std::out_of_range("robot index must be >= 0");
  if (static_cast<std::size_t>(robot) >= last_heard_s_.size()) last_heard_s_.resize(robot + 1, -kInf);
  last_heard_s_[robot] = now_s;
  record_visit(vertex, time_s);
  for (auto it = intentions_.begin(); it != intentions_.end(); ++it) {
    if (it->robot == robot) {
      if (it->vertex == vertex) intentions_.erase(it);
      break;
    }
  }
}

void TpuafKnowledge::hear_intention(const Intention& intention, double now_s) {
  check_vertex(intention.vertex);
  if (intention.robot < 0) throw std::out_of_range("robot index must be >= 0");
  if (static_cast<std::size_t>(intention.robot) >= last_heard_s_.size()) {
    last_heard_s_.resize(intention.robot + 1, -kInf);
  }
  last_heard_s_[intention.robot] = now_s;
  for (Intention& held : intentions_) {
    if (held.robot == intention.robot) {
      if (intention.sent_s >= held.sent_s) held = intention;
      return;
    }
  }
  intentions_.push_back(intention);
}

void TpuafKnowledge::forget_intention(int robot) {
  intentions_.erase(std::remove_if(intentions_.begin(), intentions_.end(),
                                   [robot](const Intention& i) { return i.robot == robot; }),
                    intentions_.end());
}

void TpuafKnowledge::drop_stale(double now_s) {
  intentions_.erase(
      std::remove_if(intentions_.begin(), intentions_.end(),
                     [&](const Intention& i) {
                       const bool late = now_s - i.expected_arrival_s > intention_timeout_s_;
                       const double heard = static_cast<std::size_t>(i.robot) < last_heard_s_.size()
                                                ? last_heard_s_[i.robot]
                                                : -kInf;
                       return late || now_s - heard > silence_timeout_s_;
                     }),
      intentions_.end());
}

Eigen::VectorXd TpuafKnowledge::estimate(double now_s) const {
  Eigen::VectorXd x(size());
  for (int j = 0; j < size(); ++j) {
    x[j] = model_.evolve(anchor_value_[j], importance_[j], std::max(0.0, now_s - anchor_time_[j]));
  }
  return x;
}

void TpuafKnowledge::announced(Eigen::VectorXd& arrival_s, Eigen::VectorXd& travel_s) const {
  arrival_s = Eigen::VectorXd::Constant(size(), kInf);
  travel_s = Eigen::VectorXd::Zero(size());
  for (const Intention& i : intentions_) {
    if (i.expected_arrival_s < arrival_s[i.vertex]) {
      arrival_s[i.vertex] = i.expected_arrival_s;
      travel_s[i.vertex] = i.travel_time_s;
    }
  }
}

UtilityResult TpuafKnowledge::utilities(const PatrolGraph& graph, double now_s, int current_vertex,
                                        const std::vector<int>& candidates, double speed_mps,
                                        UtilityForm form, bool use_path_length) {
  if (graph.num_vertices() != size()) {
    throw std::invalid_argument("graph and knowledge disagree on the number of vertices");
  }
  drop_stale(now_s);
  UtilityQuery q;
  q.now_s = now_s;
  q.current_vertex = current_vertex;
  q.candidates = candidates;
  q.speed_mps = speed_mps;
  q.use_path_length = use_path_length;
  q.form = form;
  q.last_visit_s = last_visit_;
  q.estimate = estimate(now_s);
  announced(q.announced_arrival_s, q.announced_travel_s);
  return tpuaf_utilities(graph, importance_, model_, q);
}

}  // namespace tpuaf
