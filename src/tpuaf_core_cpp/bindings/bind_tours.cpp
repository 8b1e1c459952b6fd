// Plan search (tours.hpp): tsp_order, closed_walk, balanced_partition, robots_per_part.
#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <stdexcept>
#include <string>

#include "bindings.hpp"
#include "tpuaf_core/tours.hpp"

namespace py = pybind11;

namespace {

tpuaf::TourSearch search_of(int starts, int kicks, std::uint64_t seed,
                            const std::string& metric = "auto") {
  if (starts < 1) throw py::value_error("starts must be >= 1, got " + std::to_string(starts));
  if (kicks < 0) throw py::value_error("kicks must be >= 0, got " + std::to_string(kicks));
  tpuaf::TourMetric kind = tpuaf::TourMetric::kAuto;
  if (metric == "dense") {
    kind = tpuaf::TourMetric::kDense;
  } else if (metric == "sparse") {
    kind = tpuaf::TourMetric::kSparse;
  } else if (metric != "auto") {
    throw py::value_error("metric must be 'auto', 'dense' or 'sparse', got '" + metric + "'");
  }
  return {starts, kicks, seed, kind};
}

}  // namespace

void tpuaf::bindings::bind_tours(py::module_& m) {
  m.def(
      "tsp_order",
      [](const Eigen::MatrixXd& dist, int starts, int kicks, std::uint64_t seed) {
        if (dist.rows() != dist.cols()) throw py::value_error("tsp_order: dist is not square");
        const int n = static_cast<int>(dist.rows());
        std::vector<double> flat(static_cast<std::size_t>(n) * n);
        for (int i = 0; i < n; ++i) {
          for (int j = 0; j < n; ++j) flat[static_cast<std::size_t>(i) * n + j] = dist(i, j);
        }
        py::gil_scoped_release release;
        return tsp_order(flat, n, search_of(starts, kicks, seed));
      },
      py::arg("dist"), py::arg("starts") = 12, py::arg("kicks") = 30, py::arg("seed") = 12345,
      "A short cyclic order of the rows of the symmetric metric `dist` [m]: nearest neighbour from "
      "`starts` spread start rows, 2-opt + Or-opt, then `kicks` double-bridge kicks (fixed seed).");
  m.def(
      "closed_walk",
      [](const PatrolGraph& graph, const std::vector<int>& vertices, int starts, int kicks,
         std::uint64_t seed, const std::string& metric) {
        const TourSearch search = search_of(starts, kicks, seed, metric);
        ClosedWalk walk;
        try {
          py::gil_scoped_release release;
          walk = closed_walk(graph, vertices, search);
        } catch (const std::invalid_argument& e) {
          throw py::value_error(e.what());
        }
        return std::make_pair(walk.walk, walk.length_m);
      },
      py::arg("graph"), py::arg("vertices"), py::arg("starts") = 12, py::arg("kicks") = 30,
      py::arg("seed") = 12345, py::arg("metric") = "auto",
      "Shortest closed walk found through `vertices` inside their induced subgraph: (walk "
      "without the repeated first vertex, length [m]). ValueError when it is not connected. "
      "metric: 'dense' (the k x k matrix of shortest paths), 'sparse' (lengths searched on "
      "demand) or 'auto' (sparse above DENSE_TOUR_MAX vertices).");
  m.attr("DENSE_TOUR_MAX") = kDenseTourMax;
  m.def(
      "balanced_partition",
      [](const PatrolGraph& graph, int k, int max_moves, int starts, int kicks, std::uint64_t seed,
         const Progress& progress, bool tree_score) {
        if (k < 1) throw py::value_error("balanced_partition: k must be >= 1");
        return balanced_partition(graph, k, max_moves, search_of(starts, kicks, seed), progress,
                                  tree_score);
      },
      py::arg("graph"), py::arg("k"), py::arg("max_moves") = 400, py::arg("starts") = 3,
      py::arg("kicks") = 4, py::arg("seed") = 12345, py::arg("progress") = nullptr,
      py::arg("tree_score") = false,
      "min(k, |V|) connected parts (sorted vertex lists) balanced by closed-walk length (or, "
      "tree_score, by spanning-tree length); progress(stage, done, total) is called now and "
      "then.");
  m.def("robots_per_part", &robots_per_part, py::arg("lengths_m"), py::arg("n_robots"),
        "One robot per part, every extra robot to the part of largest length / robots.");
}
