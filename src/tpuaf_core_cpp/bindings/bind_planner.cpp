#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <memory>
#include <sstream>
#include <vector>

#include "bindings.hpp"
#include "tpuaf_core/planner.hpp"

namespace py = pybind11;

namespace {

using tpuaf::Costmap;
using tpuaf::CostmapSpec;
using tpuaf::Disc;
using tpuaf::GridPlanner;
using tpuaf::Plan;
using tpuaf::PlannerOptions;
using tpuaf::PlanStatus;
using EdgeRows = Eigen::Matrix<int, Eigen::Dynamic, 2, Eigen::RowMajor>;

// None, or anything numpy reads as (k, 3) rows of x [m], y [m], radius [m].
std::vector<Disc> discs_from(const py::object& obstacles) {
  std::vector<Disc> out;
  if (obstacles.is_none()) return out;
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obstacles);
  if (!a) throw py::value_error("obstacles: expected rows of (x, y, radius_m)");
  if (a.size() == 0) return out;
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw py::value_error("obstacles: expected a (k, 3) array of (x, y, radius_m) rows");
  const double* d = a.data();
  for (py::ssize_t i = 0; i < a.shape(0); ++i)
    out.push_back({d[3 * i], d[3 * i + 1], d[3 * i + 2]});
  return out;
}

EdgeRows edges_from(const py::object& edges) {
  const auto a = py::array_t<int, py::array::c_style | py::array::forcecast>::ensure(edges);
  if (!a) throw py::value_error("edges: expected (u, v) rows of vertex indices");
  if (a.size() == 0) return EdgeRows(0, 2);
  if (a.ndim() != 2 || a.shape(1) != 2)
    throw py::value_error("edges: expected an (E, 2) array of vertex indices");
  EdgeRows out(a.shape(0), 2);
  std::copy(a.data(), a.data() + a.size(), out.data());
  return out;
}

tpuaf::Points points_of(const Plan& p) {
  tpuaf::Points out(static_cast<Eigen::Index>(p.points.size()), 2);
  for (std::size_t i = 0; i < p.points.size(); ++i) out.row(i) = p.points[i].transpose();
  return out;
}

template <class T>
py::array_t<T> grid_array(const std::vector<T>& data, int h, int w) {
  py::array_t<T> out({h, w});
  std::copy(data.begin(), data.end(), out.mutable_data());
  return out;
}

std::string spec_repr(const CostmapSpec& s) {
  std::ostringstream os;
  os << "CostmapSpec(inscribed_radius_m=" << s.inscribed_radius_m
     << ", inflation_radius_m=" << s.inflation_radius_m
     << ", cost_scaling_per_m=" << s.cost_scaling_per_m << ", cost_weight=" << s.cost_weight
     << ")";
  return os.str();
}

std::string plan_repr(const Plan& p) {
  std::ostringstream os;
  os << "Plan(status=" << tpuaf::to_string(p.status) << ", points=" << p.points.size()
     << ", length_m=" << p.length_m << ", cost_m=" << p.cost_m
     << ", start_snapped=" << (p.start_snapped ? "True" : "False")
     << ", goal_snapped=" << (p.goal_snapped ? "True" : "False") << ", expanded=" << p.expanded
     << ")";
  return os.str();
}

}  // namespace

// Over 80 lines on purpose: one .def per bound member, in the order of the C++ header; split,
// one class's binding would be scattered.
// long: one pybind11 declaration per bound name, read top to bottom; no logic
void tpuaf::bindings::bind_planner(py::module_& m) {
  py::class_<CostmapSpec>(m, "CostmapSpec",
                          "Costmap inflation: cells closer than inscribed_radius_m [m] to an "
                          "obstacle are lethal; the cost falls as exp(-cost_scaling_per_m (d - "
                          "inscribed)) to 0 at inflation_radius_m [m]; cost_weight: extra metres "
                          "of path per metre travelled at cost 1.")
      .def(py::init([](double inscribed, double inflation, double scaling, double weight) {
             return CostmapSpec{inscribed, inflation, scaling, weight};
           }),
           py::arg("inscribed_radius_m") = 0.2, py::arg("inflation_radius_m") = 0.6,
           py::arg("cost_scaling_per_m") = 5.0, py::arg("cost_weight") = 1.0)
      .def_readwrite("inscribed_radius_m", &CostmapSpec::inscribed_radius_m)
      .def_readwrite("inflation_radius_m", &CostmapSpec::inflation_radius_m)
      .def_readwrite("cost_scaling_per_m", &CostmapSpec::cost_scaling_per_m)
      .def_readwrite("cost_weight", &CostmapSpec::cost_weight)
      .def("__repr__", &spec_repr);

  py::class_<Costmap, std::shared_ptr<Costmap>>(
      m, "Costmap",
      "Exact distance transform, lethal cells and inflation costs of an occupancy grid (row 0 "
      "the bottom row, outside occupied), on a planning grid of k x k map cells (a planning cell "
      "is lethal if any of its cells is).")
      .def(py::init([](py::array_t<bool, py::array::c_style | py::array::forcecast> occupied,
                       double resolution_m, std::pair<double, double> origin,
                       const CostmapSpec& spec, double planning_resolution_m) {
             if (occupied.ndim() != 2) throw py::value_error("occupied must be a 2-D bool array");
             const auto h = occupied.shape(0), w = occupied.shape(1);
             tpuaf::GridMask grid(h, w);
             std::copy(occupied.data(), occupied.data() + h * w, grid.data());
             py::gil_scoped_release release;
             return std::make_shared<Costmap>(grid, resolution_m, origin.first, origin.second,
                                              spec, planning_resolution_m);
           }),
           py::arg("occupied"), py::arg("resolution_m"),
           py::arg("origin") = std::make_pair(0.0, 0.0), py::arg("spec") = CostmapSpec(),
           py::arg("planning_resolution_m") = 0.0,
           "occupied: (height, width) bool, row 0 the bottom row; resolution_m [m per cell]; "
           "origin (x, y) [m] of the lower-left corner of cell (0, 0); planning_resolution_m: "
           "rounded to whole map cells (0: the map's resolution).")
      .def_property_readonly("spec", &Costmap::spec)
      .def_property_readonly(
          "origin", [](const Costmap& c) { return py::make_tuple(c.origin_x(), c.origin_y()); },
          "(x, y) [m] of the lower-left corner of cell (0, 0)")
      .def_property_readonly("map_width", &Costmap::map_width, "[cells]")
      .def_property_readonly("map_height", &Costmap::map_height, "[cells]")
      .def_property_readonly("map_resolution", &Costmap::map_resolution, "[m per cell]")
      .def_property_readonly("width", &Costmap::width, "planning grid [cells]")
      .def_property_readonly("height", &Costmap::height, "planning grid [cells]")
      .def_property_readonly("resolution", &Costmap::resolution, "planning grid [m per cell]")
      .def_property_readonly("downsample", &Costmap::downsample, "map cells per planning cell")
      .def("distance_to_obstacle", &Costmap::distance_to_obstacle, py::arg("x"), py::arg("y"),
           "Gap [m] between the map cell of (x, y) and the nearest occupied cell (0 outside).")
      .def("is_lethal", &Costmap::is_lethal, py::arg("x"), py::arg("y"),
           "Is the planning cell of (x, y) lethal (outside the map: yes)?")
      .def("cost", &Costmap::cost, py::arg("x"), py::arg("y"),
           "Cost in [0, 1] of the planning cell of (x, y); 1 when lethal.")
      .def(
          "map_distances",
          [](const Costmap& c) {
            return grid_array(c.map_distances(), c.map_height(), c.map_width());
          },
           "(map_height, map_width) float32 gaps [m] to the nearest occupied cell.")
      .def("costs", [](const Costmap& c) { return grid_array(c.costs(), c.height(), c.width()); },
           "(height, width) float32 costs of the planning grid.")
      .def(
          "lethal",
          [](const Costmap& c) {
            py::array_t<bool> out({c.height(), c.width()});
            std::copy(c.lethal().begin(), c.lethal().end(), out.mutable_data());
            return out;
          },
          "(height, width) bool lethal cells of the planning grid.");

  py::enum_<PlanStatus>(m, "PlanStatus")
      .value("ok", PlanStatus::ok)
      .value("start_blocked", PlanStatus::start_blocked)
      .value("goal_blocked", PlanStatus::goal_blocked)
      .value("no_path", PlanStatus::no_path);

  py::class_<Plan>(m, "Plan",
                   "A planned path: points (n, 2) [m] from the start as given (then the snapped "
                   "start, if snapped) to the goal (or the snapped goal); empty unless ok.")
      .def_property_readonly("points", &points_of)
      .def_readonly("length_m", &Plan::length_m)
      .def_readonly("cost_m", &Plan::cost_m, "integral of 1 + cost_weight cost along the path [m]")
      .def_readonly("status", &Plan::status)
      .def_readonly("start_snapped", &Plan::start_snapped)
      .def_readonly("goal_snapped", &Plan::goal_snapped)
      .def_property_readonly(
          "start", [](const Plan& p) { return py::make_tuple(p.start.x(), p.start.y()); },
          "planned-from point (x, y) [m], snapped or as given")
      .def_property_readonly(
          "goal", [](const Plan& p) { return py::make_tuple(p.goal.x(), p.goal.y()); },
          "planned-to point (x, y) [m], snapped or as given")
      .def_readonly("expanded", &Plan::expanded, "cells expanded by the search")
      .def_property_readonly("ok", &Plan::ok)
      .def("__bool__", &Plan::ok)
      .def("__repr__", &plan_repr);

  py::class_<PlannerOptions>(m, "PlannerOptions")
      .def(py::init([](double snap_radius_m, bool smooth) {
             return PlannerOptions{snap_radius_m, smooth};
           }),
           py::arg("snap_radius_m") = 0.5, py::arg("smooth") = true,
           "snap_radius_m [m]: a lethal start or goal moves to the nearest free cell visible "
           "within it; smooth: line-of-sight shortcuts.")
      .def_readwrite("snap_radius_m", &PlannerOptions::snap_radius_m)
      .def_readwrite("smooth", &PlannerOptions::smooth);

  py::class_<GridPlanner>(m, "GridPlanner",
                          "8-connected A* on a Costmap (octile heuristic, step cost length (1 + "
                          "cost_weight cost)), cost-aware line-of-sight smoothing. Reuses its "
                          "buffers: not thread-safe.")
      .def(py::init<std::shared_ptr<const Costmap>, const PlannerOptions&>(), py::arg("costmap"),
           py::arg("options") = PlannerOptions())
      .def_property_readonly("costmap", &GridPlanner::costmap_ptr)
      .def_property("options", &GridPlanner::options, &GridPlanner::set_options)
      .def(
          "plan",
          [](GridPlanner& p, const Eigen::Vector2d& start, const Eigen::Vector2d& goal,
             const py::object& obstacles) {
            const std::vector<Disc> discs = discs_from(obstacles);
            py::gil_scoped_release release;
            return p.plan(start, goal, discs);
          },
          py::arg("start"), py::arg("goal"), py::arg("obstacles") = py::none(),
          "Plan from start (x, y) [m] to goal (x, y) [m]; obstacles: (k, 3) rows (x, y, radius_m) "
          "lethal and inflated for this plan only. No path is a status, not an error.")
      .def(
          "path_length",
          [](GridPlanner& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
             const py::object& obstacles) {
            const std::vector<Disc> discs = discs_from(obstacles);
            py::gil_scoped_release release;
            return p.path_length(a, b, discs);
          },
          py::arg("a"), py::arg("b"), py::arg("obstacles") = py::none(),
          "Length [m] of the planned path, inf when there is none.")
      .def(
          "plan_edges",
          [](GridPlanner& p, const tpuaf::Points& vertices, const py::object& edges,
             const py::object& obstacles) {
            const EdgeRows e = edges_from(edges);
            const std::vector<Disc> discs = discs_from(obstacles);
            py::gil_scoped_release release;
            return p.plan_edges(vertices, e, discs);
          },
          py::arg("vertices"), py::arg("edges"), py::arg("obstacles") = py::none(),
          "One Plan per edge (u, v) (vertex indices) from vertices[u] to vertices[v] [m]: one "
          "multi-target search per source vertex.");
}
