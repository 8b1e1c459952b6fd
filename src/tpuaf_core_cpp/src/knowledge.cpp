#include "tpuaf_core/knowledge.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace tpuaf {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}

TpuafKnowledge::TpuafKnowledge(const Eigen::VectorXd& importance, const Eigen::VectorXd& initial,
                               UncertaintyModel model, double pass_coverage, double pass_time_s,
                               double intention_timeout_s)
    : importance_(importance),
      last_visit_(Eigen::VectorXd::Zero(importance.size())),
      anchor_(static_cast<std::size_t>(importance.size())),
      model_(std::move(model)),
      pass_coverage_(pass_coverage),
      pass_time_s_(pass_time_s),
      intention_timeout_s_(intention_timeout_s) {
  model_.validate();
  if (initial.size() != importance.size()) {
    throw std::invalid_argument("need one importance C and one initial X0 per vertex");
  }
  for (Eigen::Index j = 0; j < initial.size(); ++j)
    anchor_[static_cast<std::size_t>(j)] = {initial[j], 0.0};
  if (!(pass_coverage >= 0) || !(pass_time_s >= 0)) {
    throw std::invalid_argument("pass coverage and pass time must be >= 0");
  }
  if (!(intention_timeout_s > 0)) {
    throw std::invalid_argument("the intention timeout must be > 0 s");
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
  if (time_s < anchor_[vertex].time) return;  // older than what the estimate already holds
  VisitResult* shared = shared_visits_ ? &(*shared_visits_)[vertex] : nullptr;
  if (shared != nullptr && shared->valid && shared->value_in == anchor_[vertex].value &&
      shared->time_in == anchor_[vertex].time && shared->visit_time == time_s) {
    anchor_[vertex].value = shared->value_out;
    anchor_[vertex].time = time_s;
    return;
  }
  const double value = after_visit(vertex, anchor_[vertex].value, anchor_[vertex].time, time_s);
  if (shared != nullptr)
    *shared = {anchor_[vertex].value, anchor_[vertex].time, time_s, value, true};
  anchor_[vertex].value = value;
  anchor_[vertex].time = time_s;
}

double TpuafKnowledge::after_visit(int vertex, double value, double time_s,
                                   double visit_time_s) const {
  const double c = importance_[vertex];
  const double x = model_.evolve(value, c, visit_time_s - time_s);
  return model_.evolve(x, c - pass_coverage_, pass_time_s_);
}

double TpuafKnowledge::anchor_value(int vertex) const {
  check_vertex(vertex);
  return anchor_[static_cast<std::size_t>(vertex)].value;
}

double TpuafKnowledge::anchor_time(int vertex) const {
  check_vertex(vertex);
  return anchor_[static_cast<std::size_t>(vertex)].time;
}

void TpuafKnowledge::set_visit_state(int vertex, double value, double time_s) {
  check_vertex(vertex);
  anchor_[static_cast<std::size_t>(vertex)] = {value, time_s};
  last_visit_[vertex] = time_s;
}

void TpuafKnowledge::share_visit_results() {
  shared_visits_ = std::make_shared<std::vector<VisitResult>>(static_cast<std::size_t>(size()));
}

TpuafKnowledge::Slot* TpuafKnowledge::slot(int robot) {
  if (robot < 0) throw std::out_of_range("robot index must be >= 0");
  if (static_cast<std::size_t>(robot) >= slots_.size()) slots_.resize(robot + 1);
  return &slots_[static_cast<std::size_t>(robot)];
}

void TpuafKnowledge::hear_visit(int robot, int vertex, double time_s) {
  Slot* s = slot(robot);  // throws for robot < 0
  record_visit(vertex, time_s);
  if (s->intention.vertex == vertex) s->held = s->open = false;
}

bool TpuafKnowledge::hear_team_visit(int robot, int vertex) {
  check_vertex(vertex);
  Slot* s = slot(robot);  // throws for robot < 0
  if (s->open && s->intention.vertex != vertex) return false;
  if (s->intention.vertex == vertex) s->held = s->open = false;
  return true;
}

bool TpuafKnowledge::hear_team_intention(const Intention& intention) {
  check_vertex(intention.vertex);
  Slot* s = slot(intention.robot);  // throws for robot < 0
  if (s->open) return false;  // held implies open: a closed slot is free in every robot's copy
  *s = Slot{intention, next_order_++, true, true};
  return true;
}

TpuafKnowledge TpuafKnowledge::as_robot(int robot) const {
  TpuafKnowledge copy(*this);
  copy.forget_intention(robot);
  return copy;
}

void TpuafKnowledge::hear_intention(const Intention& intention) {
  check_vertex(intention.vertex);
  Slot* s = slot(intention.robot);  // throws for robot < 0
  if (s->held) {
    if (intention.sent_s >= s->intention.sent_s) s->intention = intention;
    return;
  }
  *s = Slot{intention, next_order_++, true, true};
}

void TpuafKnowledge::forget_intention(int robot) {
  if (robot >= 0 && static_cast<std::size_t>(robot) < slots_.size()) {
    slots_[static_cast<std::size_t>(robot)].held = false;
  }
}

void TpuafKnowledge::drop_stale(double now_s) {
  for (Slot& s : slots_) {
    if (!s.held) continue;
    const Intention& i = s.intention;
    const bool late = now_s - i.expected_arrival_s > intention_timeout_s_;
    // s is robot i.robot's slot: its last message time is kept there.
    if (late) s.held = false;
  }
}

std::vector<Intention> TpuafKnowledge::intentions() const {
  std::vector<const Slot*> held;
  for (const Slot& s : slots_) {
    if (s.held) held.push_back(&s);
  }
  std::sort(held.begin(), held.end(),
            [](const Slot* a, const Slot* b) { return a->order < b->order; });
  std::vector<Intention> out;
  for (const Slot* s : held) out.push_back(s->intention);
  return out;
}

Eigen::VectorXd TpuafKnowledge::estimate(double now_s) const {
  Eigen::VectorXd x(size());
  for (int j = 0; j < size(); ++j) {
    x[j] = model_.evolve(anchor_[j].value, importance_[j], std::max(0.0, now_s - anchor_[j].time));
  }
  return x;
}

void TpuafKnowledge::announced(Eigen::VectorXd& arrival_s, Eigen::VectorXd& travel_s) const {
  arrival_s = Eigen::VectorXd::Constant(size(), kInf);
  travel_s = Eigen::VectorXd::Zero(size());
  for (const Intention& i : intentions()) {
    if (i.expected_arrival_s < arrival_s[i.vertex]) {
      arrival_s[i.vertex] = i.expected_arrival_s;
      travel_s[i.vertex] = i.travel_time_s;
    }
  }
}

UtilityResult TpuafKnowledge::utilities(const PatrolGraph& graph, double now_s, int current_vertex,
                                        const std::vector<int>& candidates, double speed_mps,
                                        UtilityForm form, bool use_path_length, int exclude_robot) {
  if (graph.num_vertices() != size()) {
    throw std::invalid_argument("graph and knowledge disagree on the number of vertices");
  }
  drop_stale(now_s);
  const int n = size();
  check_vertex(current_vertex);
  for (int j : candidates) check_vertex(j);
  // The query holds only what tpuaf_utilities reads (the candidates' and the current vertex's
  // entries); the vectors are lent to it and taken back, so a decision costs O(candidates +
  // robots), not O(vertices).
  if (scratch_estimate_.size() != n) {
    scratch_estimate_ = Eigen::VectorXd::Zero(n);
    scratch_arrival_ = Eigen::VectorXd::Constant(n, kInf);
    scratch_travel_ = Eigen::VectorXd::Zero(n);
  }
  auto estimate_at = [&](int j) {
    scratch_estimate_[j] =
        model_.evolve(anchor_[j].value, importance_[j], std::max(0.0, now_s - anchor_[j].time));
  };
  estimate_at(current_vertex);
  for (int j : candidates) estimate_at(j);
  // Earliest announced arrival per vertex; ties go to the intention heard first.
  if (scratch_order_.size() != static_cast<std::size_t>(n)) scratch_order_.assign(n, 0);
  std::vector<int> touched;
  for (std::size_t r = 0; r < slots_.size(); ++r) {
    const Slot& s = slots_[r];
    if (!s.held || static_cast<int>(r) == exclude_robot) continue;
    const int v = s.intention.vertex;
    const double a = s.intention.expected_arrival_s;
    const bool unset = std::isinf(scratch_arrival_[v]) && scratch_arrival_[v] > 0;
    if (unset ? a < scratch_arrival_[v]
              : (a < scratch_arrival_[v] ||
                 (a == scratch_arrival_[v] && s.order < scratch_order_[v]))) {
      if (unset) touched.push_back(v);
      scratch_arrival_[v] = a;
      scratch_travel_[v] = s.intention.travel_time_s;
      scratch_order_[v] = s.order;
    }
  }
  UtilityQuery q;
  q.now_s = now_s;
  q.current_vertex = current_vertex;
  q.candidates = candidates;
  q.speed_mps = speed_mps;
  q.use_path_length = use_path_length;
  q.form = form;
  q.last_visit_s.swap(last_visit_);
  q.estimate.swap(scratch_estimate_);
  q.announced_arrival_s.swap(scratch_arrival_);
  q.announced_travel_s.swap(scratch_travel_);
  struct GiveBack {  // also when tpuaf_utilities throws
    TpuafKnowledge& k;
    UtilityQuery& q;
    const std::vector<int>& touched;
    ~GiveBack() {
      k.last_visit_.swap(q.last_visit_s);
      k.scratch_estimate_.swap(q.estimate);
      k.scratch_arrival_.swap(q.announced_arrival_s);
      k.scratch_travel_.swap(q.announced_travel_s);
      for (int v : touched) {
        k.scratch_arrival_[v] = kInf;
        k.scratch_travel_[v] = 0.0;
      }
    }
  } give_back{*this, q, touched};
  return tpuaf_utilities(graph, importance_, model_, q);
}

}  // namespace tpuaf
