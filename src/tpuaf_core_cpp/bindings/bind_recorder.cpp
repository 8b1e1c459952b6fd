// Bindings of the one ground-truth recorder (tpuaf_core/recorder.hpp): RecorderConfig and
// GroundTruthRecorder, fed by tpuaf.measure.metrics.RunRecorder and read by it and by the graph
// runtime (GraphEngine.recorder).
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <cmath>
#include <string>

#include "bindings.hpp"
#include "tpuaf_core/recorder.hpp"

namespace py = pybind11;

namespace tpuaf {
namespace {

// Position in the kept visits of visit index `first` (clamped to the end); a forgotten visit
// cannot be read again.
std::size_t kept_visit_index(const GroundTruthRecorder& rec, std::size_t first) {
  if (first < rec.visits_forgotten()) {
    throw py::value_error("visits: visits before " + std::to_string(rec.visits_forgotten()) +
                          " were forgotten");
  }
  return std::min(first - rec.visits_forgotten(), rec.visits().size());
}

// (t [s], robot) of each record.
py::list time_robot(const std::vector<VisitRecord>& records) {
  py::list out;
  for (const auto& d : records) out.append(py::make_tuple(d.time_s, d.robot));
  return out;
}

void wrap_recorder_config(py::module_& m) {
  py::class_<RecorderConfig>(m, "RecorderConfig",
                             "Settings of the ground-truth recorder (SI units); the defaults are "
                             "RunRecorder's.")
      .def(py::init<>())
      .def_readwrite("robots", &RecorderConfig::robots)
      .def_readwrite("start_time_s", &RecorderConfig::start_time_s)
      .def_readwrite("sample_period_s", &RecorderConfig::sample_period_s)
      .def_readwrite("refractory_s", &RecorderConfig::refractory_s)
      .def_readwrite("max_substep_s", &RecorderConfig::max_substep_s)
      .def_readwrite("field_merge_s", &RecorderConfig::field_merge_s)
      .def_readwrite("interference_distance_m", &RecorderConfig::interference_distance_m)
      .def_readwrite("sensing_peak", &RecorderConfig::sensing_peak)
      .def_readwrite("sensing_radius_m", &RecorderConfig::sensing_radius_m)
      .def_readwrite("ground_truth", &RecorderConfig::ground_truth);
}

// What the recorder is told: visits, positions, faults, goals, dwells, announcements.
void wrap_feed(py::class_<GroundTruthRecorder>& rec) {
  rec.def(py::init<const RecorderConfig&, UncertaintyField>(), py::arg("config"), py::arg("field"))
      .def("record_visit", &GroundTruthRecorder::record_visit, py::arg("robot"), py::arg("vertex"),
           py::arg("time_s"), "Robot reached its goal vertex (graph index) at time_s [s].")
      .def("record_positions", &GroundTruthRecorder::record_positions, py::arg("time_s"),
           py::arg("positions"),
           "True positions (n_robots, 2) [m] at time_s [s]; a NaN row: robot absent.")
      .def("finish", &GroundTruthRecorder::finish, py::arg("end_s"),
           "Every accumulator brought to end_s [s] (robots held at their last positions).")
      .def("flush_field", &GroundTruthRecorder::flush_field,
           "The field brought to the last positions' time.")
      .def("record_robot_death", &GroundTruthRecorder::record_robot_death, py::arg("robot"),
           py::arg("time_s"))
      .def("record_robot_outage", &GroundTruthRecorder::record_robot_outage, py::arg("robot"),
           py::arg("time_s"), py::arg("cause"))
      .def("record_robot_back", &GroundTruthRecorder::record_robot_back, py::arg("robot"),
           py::arg("time_s"))
      .def("record_robot_stall", &GroundTruthRecorder::record_robot_stall, py::arg("robot"),
           py::arg("time_s"))
      .def("record_announcement", &GroundTruthRecorder::record_announcement, py::arg("robot"),
           py::arg("vertex"), py::arg("time_s"))
      .def("record_goal", &GroundTruthRecorder::record_goal, py::arg("robot"), py::arg("vertex"),
           py::arg("from_vertex"), py::arg("time_s"))
      .def("record_dwell", &GroundTruthRecorder::record_dwell, py::arg("robot"), py::arg("vertex"),
           py::arg("time_s"))
      .def_property_readonly("dwells", &GroundTruthRecorder::dwells,
                             "Goal arrivals that were no visit (VisitRule).")
      .def_property_readonly("dwell_time_s", &GroundTruthRecorder::dwell_time_s);
}

// Visits and 1 Hz rows, from an index on, and dropping those a results writer has on disk.
void wrap_logs(py::class_<GroundTruthRecorder>& rec) {
  rec.def(
         "visits",
         [](const GroundTruthRecorder& r, std::size_t first) {
           const auto& v = r.visits();
           py::list out;
           for (std::size_t k = kept_visit_index(r, first); k < v.size(); ++k) {
             out.append(py::make_tuple(v[k].time_s, v[k].robot, v[k].vertex));
           }
           return out;
         },
         py::arg("first") = 0, "(time_s, robot, vertex) of the visits from index first on.")
      .def(
          "visit_idleness",
          [](const GroundTruthRecorder& r, std::size_t first) {
            const auto& v = r.visit_idleness();
            return std::vector<double>(
                v.begin() + static_cast<std::ptrdiff_t>(kept_visit_index(r, first)), v.end());
          },
          py::arg("first") = 0, "Interval idleness [s] of each visit as known at its arrival.")
      .def_property_readonly("visit_count", &GroundTruthRecorder::visit_count)
      .def_property_readonly(
          "visits_kept", [](const GroundTruthRecorder& r) { return r.visits().size(); },
          "Visits still held in memory (the others were forgotten: forget_visits_before).")
      .def("forget_visits_before", &GroundTruthRecorder::forget_visits_before, py::arg("first"),
           "Drop the visits before index first (written to disk).")
      .def(
          "timeseries",
          [](const GroundTruthRecorder& r, std::size_t first) {
            const auto& rows = r.timeseries();
            if (first < r.rows_forgotten()) {
              throw py::value_error("timeseries: rows before " +
                                    std::to_string(r.rows_forgotten()) + " were forgotten");
            }
            py::list out;
            for (std::size_t k = first - r.rows_forgotten(); k < rows.size(); ++k) {
              const SampleRow& row = rows[k];
              py::dict d;
              d["time_s"] = row.time_s;
              d["idleness_ins_s"] = row.idleness_ins_s;
              d["worst_idleness_s"] = row.worst_idleness_s;
              d["uncertainty_mean"] = row.uncertainty_mean;
              d["visits"] = row.visits;
              d["interferences"] = row.interferences;
              out.append(d);
            }
            return out;
          },
          py::arg("first") = 0, "The 1 Hz rows (dicts of TIMESERIES_COLUMNS) from index first on.")
      .def_property_readonly("row_count", &GroundTruthRecorder::row_count)
      .def("forget_rows_before", &GroundTruthRecorder::forget_rows_before, py::arg("first"),
           "Drop the 1 Hz rows before index first (written to disk).");
}

// Interference episodes and the per-vertex figures.
void wrap_figures(py::class_<GroundTruthRecorder>& rec) {
  rec.def(
         "interferences",
         [](const GroundTruthRecorder& r, std::size_t first) {
           py::list out;  // (t [s], robot a, robot b), in time order
           const auto& all = r.interferences();
           for (std::size_t k = first; k < all.size(); ++k) {
             out.append(py::make_tuple(all[k].time_s, all[k].a, all[k].b));
           }
           return out;
         },
         py::arg("first") = 0)
      .def_property_readonly("interference_count",
                             [](const GroundTruthRecorder& r) { return r.interferences().size(); })
      .def_property_readonly("interval_samples",
                             [](const GroundTruthRecorder& r) {
                               // [s] vertex by vertex in time order; filled in place (no second
                               // copy).
                               std::size_t count = 0;
                               for (const auto& times : r.vertex_times())
                                 count += times.empty() ? 0 : times.size() - 1;
                               py::array_t<double> out(static_cast<py::ssize_t>(count));
                               double* data = out.mutable_data();
                               for (const auto& times : r.vertex_times()) {
                                 for (std::size_t k = 1; k < times.size(); ++k)
                                   *data++ = times[k] - times[k - 1];
                               }
                               return out;
                             })
      .def_property_readonly("first_visit_times",
                             [](const GroundTruthRecorder& r) {
                               std::vector<double> out;  // [s] per vertex; NaN: never visited
                               for (const auto& times : r.vertex_times()) {
                                 out.push_back(times.empty() ? std::nan("") : times.front());
                               }
                               return out;
                             })
      .def_property_readonly("vertex_times",
                             [](const GroundTruthRecorder& r) {
                               py::list out;  // [s] sorted visit times per vertex
                               for (const auto& times : r.vertex_times()) {
                                 out.append(py::cast(times));
                               }
                               return out;
                             })
      .def_property_readonly("visit_counts", [](const GroundTruthRecorder& r) {
        std::vector<long long> out;
        for (const auto& times : r.vertex_times()) {
          out.push_back(static_cast<long long>(times.size()));
        }
        return out;
      });
}

// Faults, announcements, the worst idleness and sums of the summary, the field and the latest
// positions.
void wrap_faults_and_field(py::class_<GroundTruthRecorder>& rec) {
  rec.def_property_readonly(
         "deaths", [](const GroundTruthRecorder& r) { return time_robot(r.deaths()); },
         "(t [s], robot) of the recorded deaths.")
      .def(
          "final_deaths", [](const GroundTruthRecorder& r) { return time_robot(r.final_deaths()); },
          "(t [s], robot) of the deaths and of the outages never ended, in that order.")
      .def_property_readonly("outages",
                             [](const GroundTruthRecorder& r) {
                               py::list out;  // summary rows; end_s None: never heard again
                               for (const auto& o : r.outages()) {
                                 py::dict d;
                                 d["robot"] = o.robot;
                                 d["start_s"] = o.start_s;
                                 d["end_s"] = o.ended ? py::object(py::float_(o.end_s))
                                                      : py::object(py::none());
                                 d["cause"] = o.cause;
                                 out.append(d);
                               }
                               return out;
                             })
      .def_property_readonly("stalls",
                             [](const GroundTruthRecorder& r) { return time_robot(r.stalls()); })
      .def_property_readonly("announcements",
                             [](const GroundTruthRecorder& r) {
                               py::list out;  // (t [s], robot, vertex)
                               for (const auto& a : r.announcements()) {
                                 out.append(py::make_tuple(a.time_s, a.robot, a.vertex));
                               }
                               return out;
                             })
      .def("worst_idleness", &GroundTruthRecorder::worst_idleness, py::arg("end_s"))
      .def_property_readonly(
          "field_values",
          [](const GroundTruthRecorder& r) { return Eigen::VectorXd(r.field_values()); })
      .def_property_readonly("ins_sum", &GroundTruthRecorder::ins_sum)
      .def_property_readonly("x_sum", &GroundTruthRecorder::x_sum)
      .def_property_readonly("x_count", &GroundTruthRecorder::x_count)
      .def_property_readonly("positions_time",
                             [](const GroundTruthRecorder& r) -> py::object {
                               if (!r.has_positions()) return py::none();
                               return py::float_(r.positions_time());
                             })
      .def_property_readonly("positions", [](const GroundTruthRecorder& r) -> py::object {
        if (!r.has_positions()) return py::none();
        return py::cast(Points(r.positions()));
      });
}

}  // namespace
}  // namespace tpuaf

void tpuaf::bindings::bind_recorder(py::module_& m) {
  wrap_recorder_config(m);
  py::class_<GroundTruthRecorder> rec(m, "GroundTruthRecorder",
                                      "The one ground-truth recorder (SPEC section 6) of every "
                                      "runtime; tpuaf.measure.metrics.RunRecorder adapts it.");
  wrap_feed(rec);
  wrap_logs(rec);
  wrap_figures(rec);
  wrap_faults_and_field(rec);
}
