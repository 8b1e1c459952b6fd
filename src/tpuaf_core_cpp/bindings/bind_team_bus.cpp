// Bindings of the team bus (tpuaf_core/team_bus.hpp); tpuaf.team.bus.TeamBus holds the Python
// messages by the ids this bus carries.
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "tpuaf_core/team_bus.hpp"

namespace py = pybind11;

void tpuaf::bindings::bind_team_bus(py::module_& m) {
  py::class_<TeamBus>(m, "TeamBus",
                      "Broadcast with a fixed delay [s] and a seeded loss per recipient, of "
                      "message ids (rng: tpuaf.team.bus.bus_stream).")
      .def(py::init<int, double, double, NumpyPcg64>(), py::arg("robots"), py::arg("delay_s"),
           py::arg("loss"), py::arg("rng"))
      .def_property_readonly("robots", &TeamBus::robots)
      .def_property_readonly("delay_s", &TeamBus::delay_s)
      .def_property_readonly("loss", &TeamBus::loss)
      .def("alive", &TeamBus::alive, py::arg("robot"))
      .def("set_alive", &TeamBus::set_alive, py::arg("robot"), py::arg("alive"))
      .def_property_readonly(
          "stats",
          [](const TeamBus& b) {
            const TeamBusStats& s = b.stats();
            return py::make_tuple(s.sent, s.delivered, s.lost);
          },
          "(sent, delivered, lost)")
      .def("count_delivered", &TeamBus::count_delivered, py::arg("pairs"),
           "(message, recipient) pairs the runtime handed over.")
      .def("send", &TeamBus::send, py::arg("sender"), py::arg("message"), py::arg("now_s"),
           "Broadcast message id `message` at now_s [s]; False when nobody is to receive it.")
      .def("next_due_s", &TeamBus::next_due_s, "[s] the next message in flight is due (+inf).")
      .def_property_readonly("in_flight", &TeamBus::in_flight)
      .def_property_readonly(
          "ready_count", [](const TeamBus& b) { return b.ready().size(); },
          "Messages ready to deliver now.")
      .def("release_next", &TeamBus::release_next)
      .def("release_due", &TeamBus::release_due, py::arg("now_s"), py::arg("slack_s") = 1e-9)
      .def(
          "take_ready",
          [](TeamBus& b) {
            py::list out;  // (message id, recipients ascending), in order
            while (!b.ready().empty()) {
              const BusDelivery d = b.pop_ready();
              py::list recipients;
              d.for_each_recipient(b.robots(), [&](int r) { recipients.append(r); });
              out.append(py::make_tuple(d.message, recipients));
            }
            return out;
          },
          "Every ready message: [(message id, recipients)], in delivery order.");
}
