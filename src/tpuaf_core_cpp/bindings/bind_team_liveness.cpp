// TeamLiveness driven from Python (tpuaf.runtimes.base.TeamRun: the physics runtime); the graph
// runtime's loop holds the same class in C++.
#include <pybind11/functional.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <stdexcept>
#include <utility>

#include "bindings.hpp"
#include "python_protocol.hpp"
#include "tpuaf_core/team_liveness.hpp"

namespace py = pybind11;
using namespace tpuaf;

namespace {

// The runtime's hooks, on a weak reference to it (the runtime owns the team: no reference cycle
// the garbage collector cannot see): runtime._schedule_check(robot, t) -> token,
// runtime._stop_motion(robot), runtime._after_stall(robot).
TeamHooks python_hooks(py::handle runtime) {
  auto ref = std::make_shared<py::weakref>(runtime);
  auto call = [ref](const char* name) {
    py::object r = (*ref)();
    if (r.is_none()) throw std::runtime_error("the runtime of this TeamLiveness is gone");
    return r.attr(name);
  };
  TeamHooks hooks;
  hooks.schedule_check = [call](int robot, double t) {
    py::gil_scoped_acquire gil;
    return call("_schedule_check")(robot, t).cast<std::uint64_t>();
  };
  hooks.stop_motion = [call](int robot) {
    py::gil_scoped_acquire gil;
    call("_stop_motion")(robot);
  };
  hooks.after_stall = [call](int robot) {
    py::gil_scoped_acquire gil;
    call("_after_stall")(robot);
  };
  return hooks;
}

}  // namespace

void tpuaf::bindings::bind_team_liveness(py::module_& m) {
  py::class_<TeamLiveness>(m, "TeamLiveness",
                           "The team around the robots' protocols in runs with faults "
                           "(team_liveness.hpp): heartbeats, each robot's pending liveness "
                           "check, the losses, a fault's steps, and delivery that feeds "
                           "liveness; the graph loop's too.")
      .def(py::init([](const std::vector<bindings::PythonDrivenProtocol*>& machines, TeamBus& bus,
                       GroundTruthRecorder& recorder, const HeartbeatLinks& links,
                       py::handle runtime) {
             std::vector<RobotProtocol*> protocols(machines.begin(), machines.end());
             return new TeamLiveness(std::move(protocols), bus, recorder, links,
                                     python_hooks(runtime));
           }),
           py::arg("protocols"), py::arg("bus"), py::arg("recorder"), py::arg("links"),
           py::arg("runtime"), py::keep_alive<1, 2>(), py::keep_alive<1, 3>(),
           py::keep_alive<1, 4>())
      .def_property_readonly("links", &TeamLiveness::links,
                             py::return_value_policy::reference_internal)
      .def_property_readonly("robots", &TeamLiveness::robots)
      .def("start", &TeamLiveness::start, py::arg("now"))
      .def("inject", &TeamLiveness::inject, py::arg("robot"), py::arg("death"), py::arg("now"))
      .def("check_due", &TeamLiveness::check_due, py::arg("robot"), py::arg("token"),
           py::arg("now"))
      .def("pending_check", &TeamLiveness::pending_check, py::arg("robot"))
      .def("lost_by", &TeamLiveness::lost_by, py::arg("robot"))
      .def(
          "deliver_ready",
          [](TeamLiveness& team, double now, const py::function& sender_of,
             const py::function& deliver, const py::function& done) {
            team.deliver_ready(
                now, [&](const BusDelivery& d) { return sender_of(d.message).cast<int>(); },
                [&](int r, const BusDelivery& d) { deliver(r, d.message); },
                [&](const BusDelivery& d) { done(d.message); });
          },
          py::arg("now"), py::arg("sender_of"), py::arg("deliver"), py::arg("done"),
          "Every ready message of the bus to its live recipients, each hearing the sender "
          "first: sender_of(id) -> robot, deliver(recipient, id), done(id).")
      .def_property_readonly("losses", [](const TeamLiveness& team) {
        py::list out;  // (t [s], observer, lost teammate)
        for (const auto& l : team.losses())
          out.append(py::make_tuple(l.time_s, l.observer, l.lost));
        return out;
      });
}
