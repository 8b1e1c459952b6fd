#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "tpuaf_core/utility.hpp"

namespace py = pybind11;

void tpuaf::bindings::bind_utility(py::module_& m) {
  py::enum_<UtilityForm>(m, "UtilityForm")
      .value("EQ13", UtilityForm::kEq13)
      .value("EQ14", UtilityForm::kEq14);

  py::class_<UtilityResult>(m, "UtilityResult")
      .def_readonly("utility", &UtilityResult::utility, "U_j (Eq. 13 or 14)")
      .def_readonly("travel_time_s", &UtilityResult::travel_time_s, "dt_j [s] (Eq. 6)")
      .def_readonly("arrival_s", &UtilityResult::arrival_s, "t_end_j [s] (Eq. 8)")
      .def_readonly("idleness_s", &UtilityResult::idleness_s, "I_j [s] (Eq. 10)")
      .def_readonly("predicted", &UtilityResult::predicted, "X^_j(t_end_j)");

  m.def(
      "tpuaf_utilities",
      [](const PatrolGraph& graph, const Eigen::VectorXd& importance,
         const UncertaintyModel& model, double now_s, int current_vertex,
         std::vector<int> candidates, double speed_mps, const Eigen::VectorXd& last_visit_s,
         const Eigen::VectorXd& estimate, const Eigen::VectorXd& announced_arrival_s,
         const Eigen::VectorXd& announced_travel_s, UtilityForm form, bool use_path_length) {
        UtilityQuery q;
        q.now_s = now_s;
        q.current_vertex = current_vertex;
        q.candidates = std::move(candidates);
        q.speed_mps = speed_mps;
        q.form = form;
        q.use_path_length = use_path_length;
        q.last_visit_s = last_visit_s;
        q.estimate = estimate;
        q.announced_arrival_s = announced_arrival_s;
        q.announced_travel_s = announced_travel_s;
        py::gil_scoped_release release;
        return tpuaf_utilities(graph, importance, model, q);
      },
      py::arg("graph"), py::arg("importance"), py::arg("model"), py::arg("now_s"),
      py::arg("current_vertex"), py::arg("candidates"), py::arg("speed_mps"),
      py::arg("last_visit_s"), py::arg("estimate"), py::arg("announced_arrival_s"),
      py::arg("announced_travel_s"), py::arg("form") = UtilityForm::kEq13,
      py::arg("use_path_length") = false,
      "TPUAF utility of every candidate vertex for one robot (SPEC section 4, Eq. 6-14). "
      "Per-vertex arrays have one value per graph vertex; announced_arrival_s is +inf where no "
      "other robot has announced the vertex.");
}
