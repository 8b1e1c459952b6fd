#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <cmath>
#include <limits>

#include "bindings.hpp"
#include "tpuaf_core/graph.hpp"
#include "tpuaf_core/shortest_path.hpp"

namespace py = pybind11;

// Over 80 lines on purpose: one .def per bound member, in the order of the C++ header; split,
// one class's binding would be scattered.
// long: one pybind11 declaration per bound name, read top to bottom; no logic
void tpuaf::bindings::bind_graph(py::module_& m) {
  py::class_<PatrolGraph>(m, "PatrolGraph",
                          "Patrol graph: vertex positions [m], undirected edges with lengths [m], "
                          "shortest paths searched on demand (rows cached).")
      .def(py::init([](const Points& positions, const std::vector<py::tuple>& edges,
                       std::vector<std::int64_t> ids,
                       const std::vector<std::pair<int, int>>& one_way) {
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
             return PatrolGraph(positions, parsed, std::move(ids), one_way);
           }),
           py::arg("positions"), py::arg("edges"), py::arg("ids") = std::vector<std::int64_t>{},
           py::arg("one_way") = std::vector<std::pair<int, int>>{},
           "positions: n x 2 [m]; edges: (u, v) or (u, v, length_m) by vertex index, length "
           "defaults to the Euclidean distance; ids: names used in error messages; one_way: "
           "arcs (u, v) of edges driven only from u to v (paths, distances and neighbours "
           "follow them; the graph must stay strongly connected).")
      .def_property_readonly(
          "one_way", &PatrolGraph::one_way,
          "The one-way arcs (u, v) by vertex index; empty: every edge both ways.")
      .def_property_readonly("num_vertices", &PatrolGraph::num_vertices)
      .def_property_readonly("num_edges", &PatrolGraph::num_edges)
      .def_property_readonly("positions", &PatrolGraph::positions)
      .def_property_readonly("ids", &PatrolGraph::ids)
      .def_property_readonly("edges",
                             [](const PatrolGraph& g) {
                               std::vector<std::tuple<int, int, double>> out;
                               for (const Edge& e : g.edges())
                                 out.emplace_back(e.u, e.v, e.length_m);
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
           "Shortest-path length [m] from u to v (u's search).",
           py::call_guard<py::gil_scoped_release>())
      .def(
          "distances_from",
          [](const PatrolGraph& g, int source) {
            std::shared_ptr<const DistanceRow> row;
            {
              py::gil_scoped_release release;
              row = g.row(source);
            }
            return Eigen::Map<const Eigen::VectorXd>(
                       row->distance.data(), static_cast<Eigen::Index>(row->distance.size()))
                .eval();
          },
          py::arg("source"),
          "Shortest-path lengths [m] from `source` to every vertex (a copy of the cached row): "
          "the same values as row `source` of `distances`, without the all-pairs matrix.")
      .def(
          "distances_from_set",
          [](const PatrolGraph& g, const std::vector<int>& sources) {
            std::vector<double> d;
            {
              py::gil_scoped_release release;
              d = g.distances_from_set(sources);
            }
            return Eigen::Map<const Eigen::VectorXd>(d.data(), static_cast<Eigen::Index>(d.size()))
                .eval();
          },
          py::arg("sources"),
          "Shortest-path lengths [m] from the nearest of `sources` to every vertex (one search "
          "from all of them, not cached).")
      .def_property_readonly("distances", &PatrolGraph::distances,
                             "All-pairs shortest-path lengths [m] (n x n, 8 n^2 bytes): built on "
                             "first use and kept; distances_from(source) gives one row.")
      .def_property_readonly("cached_rows", &PatrolGraph::cached_rows,
                             "Rows of shortest paths the graph keeps now.")
      .def_property_readonly("has_dense_matrices", &PatrolGraph::has_dense_matrices,
                             "Whether an all-pairs matrix (distances, hop_matrix) was built.")
      .def("path", &PatrolGraph::path, py::arg("u"), py::arg("v"),
           "Vertices of a shortest path, both ends included.",
           py::call_guard<py::gil_scoped_release>())
      .def("hops", &PatrolGraph::hops, py::arg("u"), py::arg("v"))
      .def_property_readonly("hop_matrix", &PatrolGraph::hop_matrix);

  m.def(
      "dijkstra",
      [](int num_vertices, const std::vector<int>& tails, const std::vector<int>& heads,
         const std::vector<double>& weights, const std::vector<int>& sources, double tolerance,
         const std::vector<bool>& allowed, int stop_at) {
        if (num_vertices < 0) throw py::value_error("dijkstra: num_vertices must be >= 0");
        if (tails.size() != heads.size() || tails.size() != weights.size()) {
          throw py::value_error("dijkstra: tails, heads and weights differ in length");
        }
        ArcLists arcs(num_vertices);
        for (std::size_t k = 0; k < tails.size(); ++k) {
          const int u = tails[k];
          if (u < 0 || u >= num_vertices) {
            throw py::index_error("dijkstra: arc from unknown vertex " + std::to_string(u));
          }
          if (!(weights[k] >= 0.0)) {
            throw py::value_error("dijkstra: arc weights must be >= 0, got " +
                                  std::to_string(weights[k]));
          }
          arcs[u].push_back({heads[k], weights[k]});
        }
        std::vector<char> mask(allowed.begin(), allowed.end());
        ShortestPathTree tree;
        {
          py::gil_scoped_release release;
          tree = dijkstra(arcs, sources, tolerance, mask, stop_at);
        }
        return std::make_tuple(tree.distance, tree.parent, tree.source);
      },
      py::arg("num_vertices"), py::arg("tails"), py::arg("heads"), py::arg("weights"),
      py::arg("sources"), py::arg("tolerance") = 0.0, py::arg("allowed") = std::vector<bool>{},
      py::arg("stop_at") = -1,
      "The project's one shortest-path search (Dijkstra) over directed arcs tails[k] -> heads[k] "
      "with weights[k] >= 0, from `sources`. Settling order (distance, source index, vertex); a "
      "vertex is relabelled when a path is shorter than its label + tolerance. `allowed` masks "
      "the vertices it may enter (empty: all); stops once `stop_at` is settled. Returns "
      "(distance, parent, source index) lists (inf / -1 / -1 when unreachable).");
}
