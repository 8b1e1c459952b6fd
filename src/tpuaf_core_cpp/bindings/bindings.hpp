#pragma once
#include <pybind11/pybind11.h>

namespace tpuaf::bindings {
void bind_perception(pybind11::module_& m);
void bind_uncertainty(pybind11::module_& m);
void bind_graph(pybind11::module_& m);
void bind_utility(pybind11::module_& m);
void bind_knowledge(pybind11::module_& m);
void bind_world(pybind11::module_& m);
void bind_recorder(pybind11::module_& m);
void bind_engine(pybind11::module_& m);
void bind_planner(pybind11::module_& m);
void bind_tours(pybind11::module_& m);
void bind_assignment(pybind11::module_& m);
void bind_visit_rule(pybind11::module_& m);
void bind_strategy(pybind11::module_& m);
void bind_team_bus(pybind11::module_& m);
void bind_robot_protocol(pybind11::module_& m);
void bind_team_liveness(pybind11::module_& m);
}  // namespace tpuaf::bindings

namespace tpuaf {
class TeamStrategy;
}
namespace tpuaf::bindings {
void bind_strategy_calls(pybind11::class_<TeamStrategy>& strategy);
}  // namespace tpuaf::bindings
