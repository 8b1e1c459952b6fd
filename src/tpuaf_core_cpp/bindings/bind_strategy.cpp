// TeamMessage, PolicyHost and the TeamStrategy calls: how one robot's policy (physics runtime,
// ROS agents) runs a C++ strategy, the same one the graph runtime's event loop runs.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <vector>

#include "bindings.hpp"
#include "tpuaf_core/strategy.hpp"

namespace py = pybind11;
using namespace tpuaf;

namespace {

TeamMessage visit(int robot, int vertex, double time_s, int next_vertex) {
  TeamMessage m;
  m.kind = TeamMessage::Kind::kVisit;
  m.robot = robot;
  m.vertex = vertex;
  m.time_s = time_s;
  m.next_vertex = next_vertex;
  return m;
}

TeamMessage intention(int robot, int from_vertex, int vertex, double expected_arrival_s,
                      double travel_time_s, double time_s) {
  TeamMessage m;
  m.kind = TeamMessage::Kind::kIntention;
  m.robot = robot;
  m.from_vertex = from_vertex;
  m.vertex = vertex;
  m.expected_arrival_s = expected_arrival_s;
  m.travel_time_s = travel_time_s;
  m.time_s = time_s;
  return m;
}

TeamMessage idleness_estimate(int robot, double time_s, std::vector<double> estimate,
                              int next_vertex) {
  TeamMessage m;
  m.kind = TeamMessage::Kind::kIdlenessEstimate;
  m.robot = robot;
  m.time_s = time_s;
  m.next_vertex = next_vertex;
  m.estimate = std::make_shared<const std::vector<double>>(std::move(estimate));
  return m;
}

}  // namespace

void tpuaf::bindings::bind_strategy(py::module_& m) {
  py::class_<TeamMessage> message(m, "TeamMessage",
                                  "A team message of a C++ strategy (tpuaf.team.messages).");
  py::enum_<TeamMessage::Kind>(message, "Kind")
      .value("VISIT", TeamMessage::Kind::kVisit)
      .value("INTENTION", TeamMessage::Kind::kIntention)
      .value("IDLENESS_ESTIMATE", TeamMessage::Kind::kIdlenessEstimate)
      .value("OPAQUE", TeamMessage::Kind::kOpaque);
  message
      .def_static("visit", &visit, py::arg("robot"), py::arg("vertex"), py::arg("time_s"),
                  py::arg("next_vertex"))
      .def_static("intention", &intention, py::arg("robot"), py::arg("from_vertex"),
                  py::arg("vertex"), py::arg("expected_arrival_s"), py::arg("travel_time_s"),
                  py::arg("time_s"))
      .def_static("idleness_estimate", &idleness_estimate, py::arg("robot"), py::arg("time_s"),
                  py::arg("estimate"), py::arg("next_vertex"))
      .def_readonly("kind", &TeamMessage::kind)
      .def_readonly("robot", &TeamMessage::robot)
      .def_readonly("vertex", &TeamMessage::vertex)
      .def_readonly("time_s", &TeamMessage::time_s)
      .def_readonly("next_vertex", &TeamMessage::next_vertex)
      .def_readonly("from_vertex", &TeamMessage::from_vertex)
      .def_readonly("expected_arrival_s", &TeamMessage::expected_arrival_s)
      .def_readonly("travel_time_s", &TeamMessage::travel_time_s)
      .def_property_readonly("estimate", [](const TeamMessage& msg) {
        return msg.estimate ? *msg.estimate : std::vector<double>{};
      });

  py::class_<PolicyHost>(m, "PolicyHost",
                         "One robot's strategy host on a live clock: set_state before each "
                         "call, take_messages / take_wake_time / take_goal_change after it.")
      .def(py::init<const PatrolGraph&, int, int>(), py::arg("graph"), py::arg("robots"),
           py::arg("robot"), py::keep_alive<1, 2>())
      .def_property_readonly("robot", &PolicyHost::robot)
      .def("set_state", &PolicyHost::set_state, py::arg("now_s"), py::arg("current_vertex"),
           py::arg("average_speed_mps"))
      .def("take_messages",
           [](PolicyHost& h) {
             std::vector<TeamMessage> out;
             for (auto& o : h.take_messages()) out.push_back(std::move(o.message));
             return out;
           })
      .def("take_wake_time", &PolicyHost::take_wake_time, "[s], NaN: no wake-up asked.")
      .def("take_goal_change", &PolicyHost::take_goal_change, "-1: the goal stays.");
}

// The calls of one robot's policy into a C++ strategy (the graph runtime's loop makes the same
// calls with itself as the host).
void tpuaf::bindings::bind_strategy_calls(py::class_<TeamStrategy>& strategy) {
  strategy
      .def(
          "start", [](TeamStrategy& s, PolicyHost& h) { s.start(h, h.robot()); }, py::arg("host"))
      .def(
          "decide", [](TeamStrategy& s, PolicyHost& h) { return s.decide(h, h.robot()); },
          py::arg("host"), "The next goal vertex, or -1 to wait (a wake-up is set).")
      .def(
          "on_message",
          [](TeamStrategy& s, PolicyHost& h, const TeamMessage& msg) {
            s.on_message(h, h.robot(), msg);
          },
          py::arg("host"), py::arg("message"))
      .def(
          "on_goal_failed",
          [](TeamStrategy& s, PolicyHost& h, int vertex) {
            s.on_goal_failed(h, h.robot(), vertex);
          },
          py::arg("host"), py::arg("vertex"))
      .def(
          "on_teammate_lost",
          [](TeamStrategy& s, PolicyHost& h, int lost) { s.on_teammate_lost(h, h.robot(), lost); },
          py::arg("host"), py::arg("lost"));
}
