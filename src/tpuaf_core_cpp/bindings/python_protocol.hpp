// The RobotProtocol of a Python RobotMachine (bind_robot_protocol.cpp builds it; TeamLiveness's
// binding takes it as the core's protocol).
#pragma once
#include <pybind11/pybind11.h>

#include <stdexcept>
#include <utility>

#include "tpuaf_core/robot_protocol.hpp"

namespace tpuaf::bindings {

namespace py = pybind11;

// The RobotDriver of a Python RobotMachine: the motion and clock of `machine.driver` (the
// tpuaf.robot.machine.RobotDriver protocol) and the policy hooks and events of the machine.
// A weak reference: the machine owns the protocol (and keeps its driver); a protocol outliving its
// machine refuses to call back (no reference cycle that the garbage collector cannot see).
class PythonDriver : public RobotDriver {
 public:
  explicit PythonDriver(py::handle machine) : machine_ref_(machine) {}
  double now() const override { return driver().attr("now").cast<double>(); }
  void position(int robot, double& x, double& y) const override {
    auto p = driver().attr("position_of")(robot).cast<std::pair<double, double>>();
    x = p.first;
    y = p.second;
  }
  bool at_vertex(int /*robot*/, int vertex) const override {
    return machine().attr("at_vertex")(vertex).cast<bool>();
  }
  void schedule_wake(int robot, double time_s) override {
    driver().attr("schedule_wake")(robot, time_s);
  }
  void drive(int robot, int from_vertex, int goal) override {
    driver().attr("drive")(robot, from_vertex, goal);
  }
  void dwell(int robot, int vertex, double duration_s) override {
    driver().attr("dwell")(robot, vertex, duration_s);
  }
  void halt(int robot) override { driver().attr("halt")(robot); }
  void policy_start(int /*robot*/) override { machine().attr("_policy_start")(); }
  int policy_decide(int /*robot*/) override {
    py::object goal = machine().attr("_policy_decide")();
    return goal.is_none() ? -1 : goal.cast<int>();
  }
  void policy_goal_failed(int /*robot*/, int vertex) override {
    machine().attr("_policy_goal_failed")(vertex);
  }
  void policy_teammate_lost(int /*robot*/, int teammate) override {
    machine().attr("_policy_teammate_lost")(teammate);
  }
  void emit(int /*robot*/, int kind, int vertex, int from_vertex, double t) override {
    machine().attr("_emit_event")(kind, vertex, from_vertex, t);
  }

 private:
  py::object machine() const {
    py::object m = machine_ref_();
    if (m.is_none()) throw std::runtime_error("the RobotMachine of this RobotProtocol is gone");
    return m;
  }
  py::object driver() const { return machine().attr("driver"); }
  py::weakref machine_ref_;
};

// A protocol with its Python driver (the driver is built first: a base before the protocol).
struct DriverHolder {
  explicit DriverHolder(py::handle machine) : python_driver(machine) {}
  PythonDriver python_driver;
};

class PythonDrivenProtocol : private DriverHolder, public RobotProtocol {
 public:
  PythonDrivenProtocol(py::handle machine, const Points& positions, ProtocolConfig config)
      : DriverHolder(machine), RobotProtocol(python_driver, positions, config) {}
};

}  // namespace tpuaf::bindings
