// TeamMessage factories; PolicyHost: one robot's strategy on a live clock (physics runtime, ROS
// agents).
#include "tpuaf_core/strategy.hpp"

#include <limits>
#include <stdexcept>
#include <string>

namespace tpuaf {

TeamMessage TeamMessage::visit(int robot, int vertex, double time_s, int next_vertex) {
  TeamMessage m;
  m.kind = Kind::kVisit;
  m.robot = robot;
  m.vertex = vertex;
  m.time_s = time_s;
  m.next_vertex = next_vertex;
  return m;
}

TeamMessage TeamMessage::intention(int robot, int from_vertex, int vertex,
                                   double expected_arrival_s, double travel_time_s, double time_s) {
  TeamMessage m;
  m.kind = Kind::kIntention;
  m.robot = robot;
  m.from_vertex = from_vertex;
  m.vertex = vertex;
  m.expected_arrival_s = expected_arrival_s;
  m.travel_time_s = travel_time_s;
  m.time_s = time_s;
  return m;
}

PolicyHost::PolicyHost(const PatrolGraph& graph, int robots, int robot)
    : graph_(&graph),
      robots_(robots),
      robot_(robot),
      wake_s_(std::numeric_limits<double>::quiet_NaN()) {
  if (robots < 1 || robot < 0 || robot >= robots) {
    throw std::invalid_argument("PolicyHost: robot " + std::to_string(robot) + " of " +
                                std::to_string(robots));
  }
}

void PolicyHost::set_graph(const PatrolGraph& graph) {
  if (graph.num_vertices() != graph_->num_vertices()) {
    throw std::invalid_argument("PolicyHost::set_graph: " + std::to_string(graph.num_vertices()) +
                                " vertices, the strategy's graph has " +
                                std::to_string(graph_->num_vertices()));
  }
  graph_ = &graph;
}

void PolicyHost::check_robot(int robot) const {
  if (robot != robot_) {
    throw std::logic_error("the strategy of robot " + std::to_string(robot_) + " asked for robot " +
                           std::to_string(robot));
  }
}

int PolicyHost::current_vertex(int robot) const {
  check_robot(robot);
  return current_;
}

double PolicyHost::average_speed(int robot) const {
  check_robot(robot);
  return speed_mps_;
}

void PolicyHost::send(int robot, TeamMessage message) {
  check_robot(robot);
  outbox_.push_back(std::move(message));
}

void PolicyHost::wake_at(int robot, double time_s) {
  check_robot(robot);
  wake_s_ = time_s;
}

void PolicyHost::change_goal(int robot, int vertex) {
  check_robot(robot);
  goal_change_ = vertex;
}

void PolicyHost::set_state(double now_s, int current_vertex, double average_speed_mps) {
  now_ = now_s;
  current_ = current_vertex;
  speed_mps_ = average_speed_mps;
}

std::vector<TeamMessage> PolicyHost::take_messages() {
  std::vector<TeamMessage> out;
  out.swap(outbox_);
  return out;
}

double PolicyHost::take_wake_time() {
  const double t = wake_s_;
  wake_s_ = std::numeric_limits<double>::quiet_NaN();
  return t;
}

int PolicyHost::take_goal_change() {
  const int v = goal_change_;
  goal_change_ = -1;
  return v;
}

}  // namespace tpuaf
