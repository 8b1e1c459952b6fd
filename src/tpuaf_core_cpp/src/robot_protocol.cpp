// One robot's patrol protocol (robot_protocol.hpp).
#include "tpuaf_core/robot_protocol.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace tpuaf {

namespace {
// Python's max(a, b): a unless b > a (the same number for doubles without NaN).
inline double py_max(double a, double b) { return b > a ? b : a; }
}  // namespace

// ---------------------------------------------------------------------------- RobotProtocol

RobotProtocol::RobotProtocol(RobotDriver& driver, const Points& positions, ProtocolConfig config)
    : driver_(driver),
      config_(config),
      rule_(positions, config.visit_radius_m),
      liveness_(config.robots, config.robot, config.teammate_timeout_s) {
  if (config.robot < 0 || config.robot >= config.robots) {
    throw std::out_of_range("robot " + std::to_string(config.robot) + " outside a team of " +
                            std::to_string(config.robots));
  }
}

void RobotProtocol::check_vertex(int vertex) const {
  if (vertex < 0 || vertex >= rule_.num_vertices()) {
    throw std::out_of_range("unknown vertex index " + std::to_string(vertex) + " (the map has " +
                            std::to_string(rule_.num_vertices()) + ")");
  }
}

void RobotProtocol::place(int vertex) {
  check_vertex(vertex);
  start_ = current_ = vertex;
}

void RobotProtocol::start() {
  started_ = true;
  double x, y;
  driver_.position(config_.robot, x, y);
  rule_.start(start_, x, y);
  driver_.emit(config_.robot, robot_event::kStart, start_, -1, driver_.now());
  driver_.policy_start(config_.robot);
}

void RobotProtocol::decide() {
  if (!alive_) return;
  wake_pending_ = false;
  ++decisions_;
  const int goal = driver_.policy_decide(config_.robot);
  redirect_ = -1;
  if (goal < 0) {
    goal_ = -1;
    dwelling_ = false;
    driver_.halt(config_.robot);
    if (!wake_pending_) wake_at(driver_.now() + config_.retry_s);
    return;
  }
  check_vertex(goal);
  set_goal(goal);
}

bool RobotProtocol::within_goal_tolerance(int vertex) const {
  check_vertex(vertex);
  double x, y;
  driver_.position(config_.robot, x, y);
  return within_vertex(rule_.positions(), vertex, x, y, config_.goal_tolerance_m);
}

void RobotProtocol::set_goal(int goal) {
  goal_ = goal;
  const int here = current_;
  const double now = driver_.now();
  driver_.emit(config_.robot, robot_event::kGoal, goal, here, now);
  if (goal == here && driver_.at_vertex(config_.robot, goal)) {
    dwelling_ = true;
    dwell_since_s_ = now;
    driver_.dwell(config_.robot, goal, config_.stay_s);
  } else {
    dwelling_ = false;
    leg_from_ = here;
    leg_start_s_ = now;
    driver_.drive(config_.robot, here, goal);
  }
}

void RobotProtocol::on_wake() {
  if (alive_ && started_ && goal_ < 0) decide();
}

bool RobotProtocol::on_vertex(int vertex, bool at_goal) {
  if (!alive_) return false;
  current_ = vertex;
  if (redirect_ >= 0 && goal_ >= 0) {
    goal_ = redirect_;
    redirect_ = -1;
    if (vertex != goal_) {
      dwelling_ = false;
      driver_.emit(config_.robot, robot_event::kGoal, goal_, vertex, driver_.now());
      driver_.drive(config_.robot, vertex, goal_);
      return false;
    }
  } else if (!at_goal) {
    return true;  // a pass-through vertex: not a visit
  }
  reach(vertex);
  return false;
}

void RobotProtocol::reach(int vertex) {
  // The goal ends at `vertex`: a visit (REACHED) if the VisitRule says so, else DWELL.
  const double now = driver_.now();
  double x, y;
  driver_.position(config_.robot, x, y);
  last_dwell_s_ = 0;
  if (rule_.arrive(vertex, x, y)) {
    ++visits_;
    driver_.emit(config_.robot, robot_event::kReached, vertex, vertex, now);
  } else {
    ++dwells_;
    if (dwelling_) last_dwell_s_ = now - dwell_since_s_;
    dwell_time_s_ += last_dwell_s_;
    driver_.emit(config_.robot, robot_event::kDwell, vertex, vertex, now);
  }
  leg_from_ = -1;
  dwelling_ = false;
  goal_ = -1;
  decide();
}

void RobotProtocol::on_goal_failed(int vertex, int nearest_vertex) {
  if (!alive_) return;
  ++failures_;
  leg_from_ = -1;
  driver_.emit(config_.robot, robot_event::kFailed, vertex, current_, driver_.now());
  goal_ = -1;
  dwelling_ = false;
  current_ = nearest_vertex;
  driver_.policy_goal_failed(config_.robot, vertex);
  decide();
}

std::vector<int> RobotProtocol::check_liveness(double now) {
  std::vector<int> lost;
  if (!alive_) return lost;
  liveness_.check(now, lost);
  for (int robot : lost) on_teammate_lost(robot);
  return lost;
}

void RobotProtocol::on_teammate_lost(int robot) {
  if (alive_ && started_) driver_.policy_teammate_lost(config_.robot, robot);
}

void RobotProtocol::die() {
  if (!alive_) return;
  alive_ = false;
  goal_ = redirect_ = -1;
  dwelling_ = false;
  driver_.halt(config_.robot);
}

void RobotProtocol::stall() { stalled_ = true; }

void RobotProtocol::wake_at(double time_s) {
  driver_.schedule_wake(config_.robot, py_max(time_s, driver_.now()));
  wake_pending_ = true;
}

void RobotProtocol::change_goal(int vertex) {
  check_vertex(vertex);
  redirect_ = vertex;
}

}  // namespace tpuaf
