// The compiled module tpuaf_core._core: lists the bindings, one file per type.
#include "bindings.hpp"

PYBIND11_MODULE(_core, m) {
  m.doc() = "tpuaf C++ core: perception, uncertainty field, patrol graph, TPUAF utility, world.";
  tpuaf::bindings::bind_perception(m);
  tpuaf::bindings::bind_uncertainty(m);
  tpuaf::bindings::bind_graph(m);
  tpuaf::bindings::bind_utility(m);
  tpuaf::bindings::bind_knowledge(m);
  tpuaf::bindings::bind_world(m);
  tpuaf::bindings::bind_strategy(m);
  tpuaf::bindings::bind_recorder(m);
  tpuaf::bindings::bind_engine(m);
  tpuaf::bindings::bind_team_bus(m);
  tpuaf::bindings::bind_planner(m);
  tpuaf::bindings::bind_tours(m);
  tpuaf::bindings::bind_assignment(m);
  tpuaf::bindings::bind_visit_rule(m);
  tpuaf::bindings::bind_robot_protocol(m);
  tpuaf::bindings::bind_team_liveness(m);
}
