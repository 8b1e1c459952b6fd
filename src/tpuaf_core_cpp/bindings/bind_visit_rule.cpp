#include <pybind11/eigen.h>

#include "bindings.hpp"
#include "tpuaf_core/visit_rule.hpp"

namespace py = pybind11;

void tpuaf::bindings::bind_visit_rule(py::module_& m) {
  m.attr("DEFAULT_VISIT_RADIUS_M") = kDefaultVisitRadiusM;
  m.attr("DEFAULT_GOAL_TOLERANCE_M") = kDefaultGoalToleranceM;
  m.def("nearest_vertex", &nearest_vertex, py::arg("positions"), py::arg("x"), py::arg("y"),
        "The vertex nearest (x, y) [m] (the first on ties: numpy's argmin of hypot).");
  m.attr("VISIT_REARM_FACTOR") = kRearmFactor;
  py::class_<VisitRule>(m, "VisitRule",
                        "The one definition of a visit (docs/RUNTIMES.md): an arrival within "
                        "the visit radius [m] of a vertex while armed for it (farther than 2 x "
                        "the radius since its last visit). Standing never visits again.")
      .def(py::init<Points, double>(), py::arg("positions"), py::arg("visit_radius_m"))
      .def("start", &VisitRule::start, py::arg("vertex"), py::arg("x"), py::arg("y"),
           "The start pose [m]: the start vertex's first visit.")
      .def("reset", &VisitRule::reset)
      .def("observe", &VisitRule::observe, py::arg("x"), py::arg("y"),
           "A position [m]: arms the vertices farther than 2 x the radius.")
      .def("arrive", &VisitRule::arrive, py::arg("vertex"), py::arg("x"), py::arg("y"),
           "A leg ends at vertex at (x, y) [m]: True = a visit (disarms it), False = a dwell.")
      .def("within", &VisitRule::within, py::arg("vertex"), py::arg("x"), py::arg("y"))
      .def("armed", &VisitRule::armed, py::arg("vertex"))
      .def_property_readonly("radius", &VisitRule::radius)
      .def_property_readonly("num_vertices", &VisitRule::num_vertices)
      .def_property_readonly("visits", &VisitRule::visits);
}
