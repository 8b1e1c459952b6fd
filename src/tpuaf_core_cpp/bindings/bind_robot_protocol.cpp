// RobotProtocol driven from Python (tpuaf.robot.machine.RobotMachine: the physics runtime and the
// ROS agents), and TeammateLiveness; the graph runtime's loop drives the same protocol in C++.
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <stdexcept>
#include <utility>

#include "bindings.hpp"
#include "python_protocol.hpp"
#include "tpuaf_core/robot_protocol.hpp"

namespace py = pybind11;
using namespace tpuaf;

namespace {

void bind_liveness(py::module_& m) {
  py::class_<TeammateLiveness>(m, "TeammateLiveness",
                               "Silent-teammate detection of one robot (team/liveness.py): a "
                               "teammate heard once, then silent for timeout_s [s], is lost.")
      .def(py::init<int, int, double>(), py::arg("n_robots"), py::arg("me"), py::arg("timeout_s"))
      .def("heard", &TeammateLiveness::heard, py::arg("robot"), py::arg("now"),
           "Heard at run time now [s]; True when it had been lost (it is back).")
      .def(
          "check",
          [](TeammateLiveness& l, double now) {
            std::vector<int> out;
            l.check(now, out);
            return out;
          },
          py::arg("now"), "Teammates silent for the timeout by now [s], each reported once.")
      .def("last_heard_s", &TeammateLiveness::last_heard, py::arg("robot"), "[s]; -inf: never.")
      .def("is_lost", &TeammateLiveness::lost, py::arg("robot"))
      .def(
          "silent_for",
          [](const TeammateLiveness& l, int robot, double now) {
            return now - l.last_heard(robot);
          },
          py::arg("robot"), py::arg("now"))
      .def_property_readonly("last_heard",
                             [](const TeammateLiveness& l) {
                               std::vector<double> out;
                               for (int r = 0; r < l.robots(); ++r) out.push_back(l.last_heard(r));
                               return out;
                             })
      .def_property_readonly("lost",
                             [](const TeammateLiveness& l) {
                               py::set out;
                               for (int r = 0; r < l.robots(); ++r) {
                                 if (l.lost(r)) out.add(py::int_(r));
                               }
                               return out;
                             })
      .def_property_readonly("timeout_s", &TeammateLiveness::timeout_s)
      .def_property_readonly("n_robots", &TeammateLiveness::robots)
      .def_property_readonly("me", &TeammateLiveness::me);
}

}  // namespace

void tpuaf::bindings::bind_robot_protocol(py::module_& m) {
  bind_liveness(m);
  py::module_ events = m.def_submodule("robot_event", "What a robot's protocol emits.");
  events.attr("START") = robot_event::kStart;
  events.attr("GOAL") = robot_event::kGoal;
  events.attr("REACHED") = robot_event::kReached;
  events.attr("FAILED") = robot_event::kFailed;
  events.attr("DWELL") = robot_event::kDwell;
  using P = bindings::PythonDrivenProtocol;
  py::class_<P>(m, "RobotProtocol",
                "One robot's patrol protocol (robot_protocol.hpp), driven by a Python "
                "RobotMachine: its `driver` moves the robot, its hooks run the policy.")
      .def(py::init([](py::handle machine, const Points& positions, int robot, int robots,
                       double stay_s, double retry_s, double teammate_timeout_s,
                       double visit_radius_m, double goal_tolerance_m) {
             ProtocolConfig c;
             c.robot = robot;
             c.robots = robots;
             c.stay_s = stay_s;
             c.retry_s = retry_s;
             c.teammate_timeout_s = teammate_timeout_s;
             c.visit_radius_m = visit_radius_m;
             c.goal_tolerance_m = goal_tolerance_m;
             return new P(machine, positions, c);
           }),
           py::arg("machine"), py::arg("positions"), py::arg("robot"), py::arg("robots"),
           py::arg("stay_s"), py::arg("retry_s"), py::arg("teammate_timeout_s"),
           py::arg("visit_radius_m"), py::arg("goal_tolerance_m") = kDefaultGoalToleranceM)
      .def("place", &P::place, py::arg("vertex"))
      .def("start", &P::start)
      .def("decide", &P::decide)
      .def("on_wake", &P::on_wake)
      .def("on_vertex", &P::on_vertex, py::arg("vertex"), py::arg("at_goal"))
      .def("on_goal_failed", &P::on_goal_failed, py::arg("vertex"), py::arg("nearest_vertex"))
      .def("observe", &P::observe, py::arg("x"), py::arg("y"))
      .def("within_goal_tolerance", &P::within_goal_tolerance, py::arg("vertex"),
           "Is the robot within the goal tolerance [m] of `vertex` (it dwells rather than drive)?")
      .def("nearest_vertex", &P::nearest_vertex, py::arg("x"), py::arg("y"),
           "The vertex nearest (x, y) [m] (the first on ties).")
      .def("hear", &P::hear, py::arg("robot"), py::arg("t"))
      .def("check_liveness", &P::check_liveness, py::arg("now"))
      .def("on_teammate_lost", &P::on_teammate_lost, py::arg("robot"))
      .def("die", &P::die)
      .def("stall", &P::stall)
      .def("wake_at", &P::wake_at, py::arg("time_s"))
      .def("change_goal", &P::change_goal, py::arg("vertex"))
      .def_property_readonly("current_vertex", &P::current_vertex)
      .def_property_readonly("start_vertex", &P::start_vertex)
      .def_property_readonly("goal", &P::goal)
      .def_property_readonly("redirect", &P::redirect)
      .def_property_readonly("alive", &P::alive)
      .def_property_readonly("started", &P::started)
      .def_property_readonly("stalled", &P::stalled)
      .def_property_readonly("dwelling", &P::dwelling)
      .def_property_readonly("wake_pending", &P::wake_pending)
      .def_property_readonly("listening", &P::listening)
      .def_property_readonly("visits", &P::visits)
      .def_property_readonly("dwells", &P::dwells)
      .def_property_readonly("failures", &P::failures)
      .def_property_readonly("decisions", &P::decisions)
      .def_property_readonly("dwell_time_s", &P::dwell_time_s)
      .def_property_readonly("leg_from", &P::leg_from)
      .def_property_readonly("leg_start_s", &P::leg_start_s)
      .def_property_readonly("visit_rule", &P::visit_rule,
                             py::return_value_policy::reference_internal)
      .def_property_readonly(
          "liveness", static_cast<const TeammateLiveness& (RobotProtocol::*)() const>(&P::liveness),
          py::return_value_policy::reference_internal);
}
