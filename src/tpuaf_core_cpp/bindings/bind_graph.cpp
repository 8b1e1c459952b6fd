#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <cmath>
#include <limits>

#include "bindings.hpp"
#include "tpuaf_core/graph.hpp"

namespace py = pybind11;

void tpuaf::bindings::bind_graph(py::module_& m) {
  py::class_<PatrolGraph>(m, "PatrolGraph",
                          "Patrol graph: vertex positions [m], undirected edges with lengths [m], "
                          "all-pairs shortest paths.")
      .def(py::init([](const Points& positions, const std::vector<py::tuple>& edges,
                       std::vector<std::int64_t> ids) {
             std::vector<Edge> parsed;
             parsed.reserve(edges.size());
             for (const py::tuple& t : edges) {
               if (t.size() != 2 && t.size() != 3) {
                 throw py::value_error("an edge is (u, v) or (u, v, length_m)");
               }
               double length = std::numeric_limits<double>::quiet_NaN();
               if (t.size() == 3 && !t[2].is_none()) length = t[2].cast<double>();
               parsed.push_back({t[0].cast<int>(), t[1].cast<int>(), length});
             }
             py::gil_scoped_release release;
             return PatrolGraph(positions, parsed, std::move(ids));
           }),
           py::arg("positions"), py::arg("edges"), py::arg("ids") = std::vector<std::int64_t>{},
           "positions: n x 2 [m]; edges: (u, v) or (u, v, length_m) by vertex index, length "
           "defaults to the Euclidean distance; ids: names used in error messages.")
      .def_property_readonly("num_vertices", &PatrolGraph::num_vertices)
      .def_property_readonly("num_edges", &PatrolGraph::num_edges)
      .def_property_readonly("positions", &PatrolGraph::positions)
      .def_property_readonly("ids", &PatrolGraph::ids)
      .def_property_readonly("edges",
                             [](const PatrolGraph& g) {
                               std::vector<std::tuple<int, int, double>> out;
                               for (const Edge& e : g.edges()) out.emplace_back(e.u, e.v, e.length_m);
                               return out;
                             })
      .def("neighbours", &PatrolGraph::neighbours, py::arg("v"))
      .def("edge_length", &PatrolGraph::edge_length, py::arg("u"), py::arg("v"), "[m]")
      .def("has_edge", &PatrolGraph::has_edge, py::arg("u"), py::arg("v"))
      .def_property_readonly("mean_edge_length", &PatrolGraph::mean_edge_length,
                             "c_G^avg of Eq. 7 [m]")
      .def_property_readonly("total_edge_length", &PatrolGraph::total_edge_length, "[m]")
      .def_property_readonly("min_edge_length", &PatrolGraph::min_edge_length, "[m]")
      .def_property_readonly("max_edge_length", &PatrolGraph::max_edge_length, "[m]")
      .def("distance", &PatrolGraph::distance, py::arg("u"), py::arg("v"),
           "Shortest-path length [m].")
      .def_property_readonly("distances", &PatrolGraph::distances,
                             "All-pairs shortest-path lengths [m].")
      .def("path", &PatrolGraph::path, py::arg("u"), py::arg("v"),
           "Vertices of a shortest path, both ends included.")
      .def("hops", &PatrolGraph::hops, py::arg("u"), py::arg("v"))
      .def_property_readonly("hop_matrix", &PatrolGraph::hop_matrix);
}
