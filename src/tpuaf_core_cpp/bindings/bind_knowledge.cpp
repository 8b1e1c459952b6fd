#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "tpuaf_core/knowledge.hpp"

namespace py = pybind11;

void tpuaf::bindings::bind_knowledge(py::module_& m) {
  py::class_<TpuafKnowledge>(
      m, "TpuafKnowledge",
      "What one TPUAF robot knows (SPEC 4, steps 3, 6, 7): latest visit per vertex, announced "
      "intentions of the others (stale ones dropped) and its estimate of every X_j.")
      .def(py::init<const Eigen::VectorXd&, const Eigen::VectorXd&, UncertaintyModel, double,
                    double, double>(),
           py::arg("importance"), py::arg("initial"), py::arg("model"), py::arg("pass_coverage"),
           py::arg("pass_time_s"), py::arg("intention_timeout_s"))
      .def("record_visit", &TpuafKnowledge::record_visit, py::arg("vertex"), py::arg("time_s"),
           "A visit of vertex at time_s [s]: idleness clock and one pass on the estimate.")
      .def("hear_visit", &TpuafKnowledge::hear_visit, py::arg("robot"), py::arg("vertex"),
           py::arg("time_s"))
      .def(
          "hear_intention",
          [](TpuafKnowledge& k, int robot, int from_vertex, int vertex, double arrival,
             double travel, double sent) {
            k.hear_intention({robot, from_vertex, vertex, arrival, travel, sent});
          },
          py::arg("robot"), py::arg("from_vertex"), py::arg("vertex"),
          py::arg("expected_arrival_s"), py::arg("travel_time_s"), py::arg("sent_s"))
      .def("forget_intention", &TpuafKnowledge::forget_intention, py::arg("robot"))
      .def("drop_stale", &TpuafKnowledge::drop_stale, py::arg("now_s"))
      .def("estimate", &TpuafKnowledge::estimate, py::arg("now_s"), "X_j estimate at now_s")
      .def_property_readonly("last_visit", &TpuafKnowledge::last_visit, "[s] per vertex")
      .def_property_readonly(
          "intentions",
          [](const TpuafKnowledge& k) {
            std::vector<std::tuple<int, int, int, double, double, double>> out;
            for (const Intention& i : k.intentions()) {
              out.emplace_back(i.robot, i.from_vertex, i.vertex, i.expected_arrival_s,
                               i.travel_time_s, i.sent_s);
            }
            return out;
          },
          "(robot, from_vertex, vertex, expected_arrival_s, travel_time_s, sent_s) per robot")
      .def("utilities", &TpuafKnowledge::utilities, py::arg("graph"), py::arg("now_s"),
           py::arg("current_vertex"), py::arg("candidates"), py::arg("speed_mps"),
           py::arg("form") = UtilityForm::kEq13, py::arg("use_path_length") = false,
           py::arg("exclude_robot") = -1, py::call_guard<py::gil_scoped_release>(),
           "Eq. 6-14 for the candidates with this knowledge (drops stale entries first); the "
           "intention of exclude_robot (>= 0) is not counted.");
}
