#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "tpuaf_core/uncertainty.hpp"

namespace py = pybind11;

void tpuaf::bindings::bind_uncertainty(py::module_& m) {
  py::class_<UncertaintyModel>(m, "UncertaintyModel",
                               "Growth law g(X) = sum_l a_l X^l of Eq. 2 (a_l >= 0).")
      .def(py::init([](std::vector<double> coefficients, double max_value, double max_ode_step_s) {
             UncertaintyModel model{std::move(coefficients), max_value, max_ode_step_s};
             model.validate();
             return model;
           }),
           py::arg("growth_coefficients") = std::vector<double>{1.0, 0.6},
           py::arg("max_value") = 1e12, py::arg("max_ode_step_s") = 0.05)
      .def_readonly("growth_coefficients", &UncertaintyModel::growth_coefficients)
      .def_readonly("max_value", &UncertaintyModel::max_value)
      .def_readonly("max_ode_step_s", &UncertaintyModel::max_ode_step_s)
      .def_property_readonly("is_affine", &UncertaintyModel::is_affine)
      .def("g", &UncertaintyModel::g, py::arg("x"), "g(X) of Eq. 2.")
      .def("evolve", &UncertaintyModel::evolve, py::arg("x0"), py::arg("rate"), py::arg("dt_s"),
           "X after dt_s [s] of dX/dt = rate * g(X), rate = C - sum M constant; exact for affine g.")
      .def(
          "evolve_many",
          [](const UncertaintyModel& model, const Eigen::VectorXd& x0, const Eigen::VectorXd& rate,
             const Eigen::VectorXd& dt_s) {
            if (rate.size() != x0.size() || dt_s.size() != x0.size()) {
              throw std::invalid_argument("x0, rate and dt_s need the same length");
            }
            Eigen::VectorXd out(x0.size());
            for (Eigen::Index j = 0; j < x0.size(); ++j) out[j] = model.evolve(x0[j], rate[j], dt_s[j]);
            return out;
          },
          py::arg("x0"), py::arg("rate"), py::arg("dt_s"), py::call_guard<py::gil_scoped_release>(),
          "evolve() element-wise over arrays: x0, rate = C - sum M, dt_s [s].");

  py::class_<UncertaintyField>(m, "UncertaintyField",
                               "Uncertainty X_j of every target (Eq. 2-3), kept in [0, max_value].")
      .def(py::init<const Points&, const Eigen::VectorXd&, const Eigen::VectorXd&,
                    UncertaintyModel>(),
           py::arg("targets"), py::arg("importance"), py::arg("initial"),
           py::arg("model") = UncertaintyModel{})
      .def_property("values", &UncertaintyField::values, &UncertaintyField::set_values,
                    "X_j of every target (copy).")
      .def_property_readonly("importance", &UncertaintyField::importance)
      .def_property_readonly("targets", &UncertaintyField::targets)
      .def_property_readonly("model", &UncertaintyField::model)
      .def("__len__", &UncertaintyField::size)
      .def("advance", &UncertaintyField::advance, py::arg("dt_s"), py::arg("robots"),
           py::arg("peaks"), py::arg("radii_m"), py::call_guard<py::gil_scoped_release>(),
           "Advance dt_s [s] with robots (rows, m) held still; exact for affine g.")
      .def("advance_linear", &UncertaintyField::advance_linear, py::arg("dt_s"), py::arg("start"),
           py::arg("end"), py::arg("peaks"), py::arg("radii_m"), py::arg("max_substep_s") = 0.25,
           py::call_guard<py::gil_scoped_release>(),
           "Advance dt_s [s] with robots moving linearly from start to end (rows, m); substeps of "
           "at most max_substep_s [s], Simpson's rule for the coverage of each.")
      .def("advance_uncovered", &UncertaintyField::advance_uncovered, py::arg("dt_s"),
           py::call_guard<py::gil_scoped_release>(), "Advance dt_s [s] with no coverage.")
      .def("advance_with_coverage", &UncertaintyField::advance_with_coverage, py::arg("dt_s"),
           py::arg("coverage"), py::call_guard<py::gil_scoped_release>(),
           "Advance dt_s [s] with a given sum of M per target.")
      .def("predict", &UncertaintyField::predict, py::arg("horizon_s"),
           py::call_guard<py::gil_scoped_release>(),
           "X of every target after horizon_s [s] more without coverage.")
      .def("predict_one", &UncertaintyField::predict_one, py::arg("target"), py::arg("horizon_s"),
           "X of one target after horizon_s [s] more without coverage.");
}
