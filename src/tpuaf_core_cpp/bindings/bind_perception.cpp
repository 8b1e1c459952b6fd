#include <pybind11/eigen.h>

#include "bindings.hpp"
#include "tpuaf_core/perception.hpp"

namespace py = pybind11;

void tpuaf::bindings::bind_perception(py::module_& m) {
  m.def("perception", &tpuaf::perception, py::arg("distance_m"), py::arg("peak"),
        py::arg("radius_m"),
        "Perception M of a target at distance_m [m] (Eq. 1): G (s^2 - r^2)^2 / r^4 if s <= r, "
        "else 0.");
  m.def("perception_matrix", &tpuaf::perception_matrix, py::arg("targets"), py::arg("robots"),
        py::arg("peaks"), py::arg("radii_m"), py::call_guard<py::gil_scoped_release>(),
        "Eq. 1 for every target (rows, m) and robot (rows, m): a targets x robots matrix.");
  m.def("total_perception", &tpuaf::total_perception, py::arg("targets"), py::arg("robots"),
        py::arg("peaks"), py::arg("radii_m"), py::call_guard<py::gil_scoped_release>(),
        "Sum over robots of Eq. 1 per target: the coverage term of Eq. 2.");
}
