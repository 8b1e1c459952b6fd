// TeamMessage, PolicyHost and the TeamStrategy calls: how one robot's policy (physics runtime,
// ROS agents) runs a C++ strategy, the same one the graph runtime's event loop runs.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <vector>

#include "bindings.hpp"
#include "tpuaf_core/strategy.hpp"

namespace py = pybind11;
using namespace tpuaf;

void tpuaf::bindings::bind_strategy(py::module_& m) {
  py::class_<TeamMessage> message(m, "TeamMessage",
                                  "A team message of a C++ strategy (tpuaf.team.messages).");
  py::enum_<TeamMessage::Kind>(message, "Kind")
      .value("VISIT", TeamMessage::Kind::kVisit)
      .value("INTENTION", TeamMessage::Kind::kIntention)
      .value("OPAQUE", TeamMessage::Kind::kOpaque);
  message
      .def_static("visit", &TeamMessage::visit, py::arg("robot"), py::arg("vertex"),
                  py::arg("time_s"), py::arg("next_vertex"))
      .def_static("intention", &TeamMessage::intention, py::arg("robot"), py::arg("from_vertex"),
                  py::arg("vertex"), py::arg("expected_arrival_s"), py::arg("travel_time_s"),
                  py::arg("time_s"))
      .def_readonly("kind", &TeamMessage::kind)
      .def_readonly("robot", &TeamMessage::robot)
      .def_readonly("vertex", &TeamMessage::vertex)
      .def_readonly("time_s", &TeamMessage::time_s)
      .def_readonly("next_vertex", &TeamMessage::next_vertex)
      .def_readonly("from_vertex", &TeamMessage::from_vertex)
      .def_readonly("expected_arrival_s", &TeamMessage::expected_arrival_s)
      .def_readonly("travel_time_s", &TeamMessage::travel_time_s);

  py::class_<PolicyHost>(m, "PolicyHost",
                         "One robot's strategy host on a live clock: set_state before each "
                         "call, take_messages / take_wake_time / take_goal_change after it.")
      .def(py::init<const PatrolGraph&, int, int>(), py::arg("graph"), py::arg("robots"),
           py::arg("robot"), py::keep_alive<1, 2>())
      .def_property_readonly("robot", &PolicyHost::robot)
      .def("set_graph", &PolicyHost::set_graph, py::arg("graph"), py::keep_alive<1, 2>(),
           "Re-timed edges: strategies reading the host's graph at each call use `graph`.")
      .def("set_state", &PolicyHost::set_state, py::arg("now_s"), py::arg("current_vertex"),
           py::arg("average_speed_mps"))
      .def("take_messages", &PolicyHost::take_messages)
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
          py::arg("host"), py::arg("lost"))
      .def(
          "retime", [](TeamStrategy& s, PolicyHost& h) { s.retime(h, h.robot()); },
          py::arg("host"),
          "The host's graph holds learned travel times (set_graph): re-time what the strategy "
          "keeps from the graph.");
}
