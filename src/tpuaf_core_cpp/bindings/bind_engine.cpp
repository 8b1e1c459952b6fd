// Bindings of the graph runtime's event loop (tpuaf_core/engine.hpp); driven by
// tpuaf.runtimes.native.
#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <cmath>
#include <memory>
#include <optional>

#include "bindings.hpp"
#include "tpuaf_core/engine.hpp"
#include "tpuaf_core/tpuaf_plus.hpp"

namespace py = pybind11;

namespace tpuaf {
namespace {

// A strategy written in Python: `team.start(robot)`, `team.decide(robot)` (int or None),
// `team.on_message(robot, message)` and, when the team has them, `team.on_goal_failed(robot,
// vertex)` and `team.on_teammate_lost(robot, lost)` of a Python object, called with the GIL
// held.
class PythonStrategy : public TeamStrategy {
 public:
  explicit PythonStrategy(py::object team)
      : team_(std::move(team)),
        start_(team_.attr("start")),
        decide_(team_.attr("decide")),
        on_message_(team_.attr("on_message")),
        on_goal_failed_(py::getattr(team_, "on_goal_failed", py::none())),
        on_teammate_lost_(py::getattr(team_, "on_teammate_lost", py::none())) {}
  void on_goal_failed(StrategyHost&, int robot, int vertex) override {
    if (!on_goal_failed_.is_none()) on_goal_failed_(robot, vertex);
  }
  void on_teammate_lost(StrategyHost&, int robot, int lost) override {
    if (!on_teammate_lost_.is_none()) on_teammate_lost_(robot, lost);
  }
  void start(StrategyHost&, int robot) override { start_(robot); }
  int decide(StrategyHost&, int robot) override {
    py::object goal = decide_(robot);
    return goal.is_none() ? -1 : goal.cast<int>();
  }
  void on_message(StrategyHost&, int robot, const TeamMessage& message) override {
    if (message.kind != TeamMessage::Kind::kOpaque || !message.opaque) {
      throw std::invalid_argument("a Python strategy received a message of a C++ strategy");
    }
    on_message_(robot, *static_cast<py::object*>(message.opaque.get()));
  }
  bool is_native() const override { return false; }

 private:
  py::object team_, start_, decide_, on_message_, on_goal_failed_, on_teammate_lost_;
};

std::shared_ptr<void> wrap(py::object message) {
  // Deleted with the GIL held: Python strategies run the whole loop holding it.
  return std::shared_ptr<void>(new py::object(std::move(message)),
                               [](void* p) { delete static_cast<py::object*>(p); });
}

NumpyPcg64 pcg_from_state(py::dict state) {
  // state: numpy's PCG64 bit_generator.state dict.
  py::dict inner = state["state"];
  py::int_ s = inner["state"], inc = inner["inc"];
  py::int_ mask(0xffffffffffffffffULL);
  py::object shift = py::int_(64);
  auto part = [&](py::int_ v, bool high) {
    py::object x = high ? v.attr("__rshift__")(shift) : v;
    return x.attr("__and__")(mask).cast<std::uint64_t>();
  };
  return NumpyPcg64(part(s, true), part(s, false), part(inc, true), part(inc, false),
                    state["has_uint32"].cast<int>() != 0, state["uinteger"].cast<std::uint32_t>());
}

// NumpyPcg64 and numpy_mean: numpy's PCG64 stream and pairwise mean, bit for bit.
void wrap_numpy(py::module_& m) {
  py::class_<NumpyPcg64>(m, "NumpyPcg64",
                         "numpy's PCG64 stream in C++, seeded from a Generator's "
                         "bit_generator.state (draws the same numbers as numpy).")
      .def(py::init(&pcg_from_state), py::arg("state"))
      .def("random", &NumpyPcg64::random, "Generator.random(): one double in [0, 1).")
      .def("integers", &NumpyPcg64::integers, py::arg("n"), "Generator.integers(0, n).")
      .def("next_uint64", &NumpyPcg64::next_uint64)
      .def_property_readonly("state", [](const NumpyPcg64& g) {
        std::uint64_t sh, sl, ih, il;
        bool has;
        std::uint32_t u;
        g.get_state(sh, sl, ih, il, has, u);
        py::int_ shift(64);
        auto join = [&](std::uint64_t hi, std::uint64_t lo) {
          return py::int_(hi).attr("__lshift__")(shift).attr("__or__")(py::int_(lo));
        };
        py::dict inner;
        inner["state"] = join(sh, sl);
        inner["inc"] = join(ih, il);
        py::dict out;
        out["bit_generator"] = "PCG64";
        out["state"] = inner;
        out["has_uint32"] = has ? 1 : 0;
        out["uinteger"] = u;
        return out;
      });
  m.def(
      "numpy_mean",
      [](const Eigen::VectorXd& a) {
        return numpy_mean(a.data(), static_cast<std::size_t>(a.size()));
      },
      py::arg("values"), "Mean with numpy's pairwise summation (equal to np.mean bit for bit).");
}

// EngineConfig: the settings of one run.
void wrap_config(py::module_& m) {
  py::class_<EngineConfig>(m, "EngineConfig", "Settings of one graph-runtime run (SI units).")
      .def(py::init<>())
      .def_readwrite("robots", &EngineConfig::robots)
      .def_readwrite("duration_s", &EngineConfig::duration_s)
      .def_readwrite("delay_s", &EngineConfig::delay_s)
      .def_readwrite("loss", &EngineConfig::loss)
      .def_readwrite("sample_period_s", &EngineConfig::sample_period_s)
      .def_readwrite("nominal_speed_mps", &EngineConfig::nominal_speed_mps)
      .def_readwrite("stay_s", &EngineConfig::stay_s)
      .def_readwrite("visit_radius_m", &EngineConfig::visit_radius_m)
      .def_readwrite("retry_s", &EngineConfig::retry_s)
      .def_readwrite("refractory_s", &EngineConfig::refractory_s)
      .def_readwrite("max_substep_s", &EngineConfig::max_substep_s)
      .def_readwrite("field_merge_s", &EngineConfig::field_merge_s)
      .def_readwrite("interference_distance_m", &EngineConfig::interference_distance_m)
      .def_readwrite("sensing_peak", &EngineConfig::sensing_peak)
      .def_readwrite("sensing_radius_m", &EngineConfig::sensing_radius_m)
      .def_readwrite("start_vertices", &EngineConfig::start_vertices)
      .def_readwrite("goal_tolerance_m", &EngineConfig::goal_tolerance_m)
      .def_readwrite("stall_give_up_s", &EngineConfig::stall_give_up_s)
      .def_readwrite("teammate_timeout_s", &EngineConfig::teammate_timeout_s)
      .def_readwrite("heartbeat_period_s", &EngineConfig::heartbeat_period_s)
      .def_readwrite("narrow_vertices", &EngineConfig::narrow_vertices)
      .def_readwrite("narrow_headway_s", &EngineConfig::narrow_headway_s)
      .def_readwrite("turn_times", &EngineConfig::turn_times);
}

// HeartbeatLinks: the heartbeats of runs with faults, of the graph and physics runtimes.
void wrap_heartbeats(py::module_& m) {
  py::class_<HeartbeatLinks>(m, "HeartbeatLinks",
                             "Heartbeats of a run with faults (rngs: default_rng([seed, 4, "
                             "sender]) per sender, needed with loss; "
                             "tpuaf.team.liveness.heartbeat_links builds one).")
      .def(py::init<int, double, double, double, double, double, std::vector<NumpyPcg64>>(),
           py::arg("robots"), py::arg("duration_s"), py::arg("timeout_s"), py::arg("delay_s"),
           py::arg("loss"), py::arg("period_s"), py::arg("rngs"))
      .def("died", &HeartbeatLinks::died, py::arg("robot"), py::arg("t"))
      .def("last_arrival_s", &HeartbeatLinks::last_arrival_s, py::arg("recipient"),
           py::arg("sender"), py::arg("t"))
      .def("next_check_s",
           py::overload_cast<int, int, double, bool, double>(&HeartbeatLinks::next_check_s),
           py::arg("recipient"), py::arg("sender"), py::arg("last_heard"), py::arg("lost"),
           py::arg("now"))
      .def(
          "feed",
          [](HeartbeatLinks& h, TeammateLiveness& liveness, double now) {
            std::vector<int> back;
            h.feed(liveness, now, &back);
            return back;
          },
          py::arg("liveness"), py::arg("now"),
          "A live robot's liveness hears every teammate's last heartbeat by now [s]; returns "
          "the teammates heard again after being lost.")
      .def("next_check_of",
           py::overload_cast<const TeammateLiveness&, double>(&HeartbeatLinks::next_check_s),
           py::arg("liveness"), py::arg("now"),
           "[s] the earliest time a check of `liveness` can find a change (inf: never).")
      .def_property_readonly("period_s", &HeartbeatLinks::period_s)
      .def_property_readonly("count", &HeartbeatLinks::count)
      .def("received", &HeartbeatLinks::received, py::arg("recipient"), py::arg("sender"))
      .def("silences", &HeartbeatLinks::silences, py::arg("recipient"), py::arg("sender"));
}

// TPUAF+'s decision path; its plans come from a Python callable (TpuafPlus.core_strategy):
// plans(team, timing) -> (routes, route_of, schedule) (timing: None, or the re-timed
// PatrolGraph whose edge lengths the same walks are re-timed on) with routes [(walk, arc [m],
// L [m], robots[, gaps [m]])], route_of [route index or -1 per robot], schedule [(entry index
// or -1, departure [s]) per robot]. It is called with the GIL held (the run keeps it:
// is_native() is false).
PlusRoute route_from_python(py::handle item) {
  py::tuple t = py::reinterpret_borrow<py::tuple>(item);
  PlusRoute route;
  route.walk = t[0].cast<std::vector<int>>();
  route.arc = t[1].cast<std::vector<double>>();
  route.length = t[2].cast<double>();
  route.robots = t[3].cast<std::vector<int>>();
  if (t.size() > 4) route.gaps = t[4].cast<std::vector<double>>();
  if (!route.gaps.empty() && route.gaps.size() != route.robots.size()) {
    throw std::invalid_argument("a TPUAF+ route needs one gap per robot (or none)");
  }
  if (route.arc.size() != route.walk.size() || route.walk.empty()) {
    throw std::invalid_argument("a TPUAF+ route needs one arc position per walk vertex");
  }
  return route;
}

// A Python plan function `plans(team, timing) -> (routes, route_of, schedule)` as TPUAF+'s
// PlanSource (timing: the re-timed graph, or None).
TpuafPlusStrategy::PlanSource plan_source(py::function plans) {
  return [plans](const std::vector<int>& team, const PatrolGraph* timing) {
    py::tuple t = timing == nullptr
                      ? plans(team, py::none())
                      : plans(team, py::cast(timing, py::return_value_policy::reference));
    auto plan = std::make_shared<PlusPlan>();
    for (py::handle item : py::reinterpret_borrow<py::list>(t[0])) {
      plan->routes.push_back(route_from_python(item));
    }
    plan->route_of = t[1].cast<std::vector<int>>();
    plan->schedule = t[2].cast<std::vector<std::pair<int, double>>>();
    return std::shared_ptr<const PlusPlan>(std::move(plan));
  };
}

void wrap_tpuaf_plus(py::module_& m) {
  m.def("walk_worst_idleness", &walk_worst_idleness, py::arg("graph"), py::arg("walk"),
        py::arg("n_robots"), py::arg("speed_mps"),
        "Steady-state worst idleness [s] of a closed walk with n_robots evenly spaced at "
        "speed_mps (tours.walk_idleness(...)['worst']).");
  m.def(
      "start_schedule",
      [](const PatrolGraph& graph, py::tuple route, const std::vector<int>& starts,
         const std::vector<double>& late_m, double speed_mps,
         std::optional<std::vector<double>> idle_s) {
        const PlusRoute r = route_from_python(route);
        if (idle_s && idle_s->size() != static_cast<std::size_t>(graph.num_vertices())) {
          throw py::value_error("start_schedule: idle_s needs one value per graph vertex");
        }
        return start_schedule(graph, r, starts, late_m, speed_mps, idle_s ? &*idle_s : nullptr);
      },
      py::arg("graph"), py::arg("route"), py::arg("starts"), py::arg("late_m"),
      py::arg("speed_mps"), py::arg("idle_s") = py::none(),
      "TPUAF+'s start schedule on route (walk, arc [m], L [m], robots): per robot of the route, "
      "(entry walk index, departure [s]); starts and late_m [m] per robot of the route, idle_s "
      "[s] per graph vertex (after a loss) or None.");
  m.def(
      "retime_gap_change",
      [](py::tuple from, py::tuple to) {
        return retime_gap_change(route_from_python(from), route_from_python(to));
      },
      py::arg("before"), py::arg("after"),
      "Re-timing a walk (walk, arc [m], L [m], robots[, gaps [m]]) to the same walk on other "
      "edge lengths: the largest change of a target gap between consecutive robots, as a share "
      "of the even gap L' / m (TPUAF+ re-times above TpuafPlusParams.retime_tolerance).");
  py::class_<TpuafPlusParams>(m, "TpuafPlusParams", "TPUAF+'s resolved parameters (SI units).")
      .def(py::init<>())
      .def_readwrite("speed_mps", &TpuafPlusParams::speed_mps)
      .def_readwrite("gain", &TpuafPlusParams::gain)
      .def_readwrite("pace_weight", &TpuafPlusParams::pace_weight)
      .def_readwrite("deadband_s", &TpuafPlusParams::deadband_s)
      .def_readwrite("dwell_revisit_s", &TpuafPlusParams::dwell_revisit_s)
      .def_readwrite("stay_s", &TpuafPlusParams::stay_s)
      .def_readwrite("retime", &TpuafPlusParams::retime)
      .def_readwrite("retime_tolerance", &TpuafPlusParams::retime_tolerance);
  py::class_<TpuafPlusStrategy, TeamStrategy>(
      m, "TpuafPlusStrategy", "TPUAF+'s decision path in C++ (tpuaf.policies.tpuaf_plus).")
      .def(
          py::init([](const TpuafKnowledge& knowledge, TpuafPlusParams params, py::function plans) {
            return std::make_unique<TpuafPlusStrategy>(knowledge, std::move(params),
                                                       plan_source(plans));
          }),
          py::arg("knowledge"), py::arg("params"), py::arg("plans"))
      .def(
          "replan",
          [](TpuafPlusStrategy& s, PolicyHost& h, py::function plans) {
            s.replan(h, h.robot(), plan_source(plans));
          },
          py::arg("host"), py::arg("plans"),
          "The host's graph changed (a lane blocked): plan on `plans` and the host's graph.")
      .def("walk", &TpuafPlusStrategy::walk, py::arg("robot"), "Robot `robot`'s current walk.")
      .def(
          "timing",
          [](const TpuafPlusStrategy& s, int robot) {
            const PlusRoute& r = s.route(robot);
            return py::make_tuple(r.arc, r.length, r.gaps);
          },
          py::arg("robot"),
          "Robot `robot`'s walk timing: (arc position [m] of each walk entry, L [m], target "
          "gaps [m] or [] for even).")
      .def("team", &TpuafPlusStrategy::team, py::arg("robot"),
           "The robots `robot` believes alive (itself included).");
}

// TeamStrategy and its Python, TPUAF, GBS and DTAG (TPUAF+: above) decision paths.
void wrap_strategies(py::module_& m) {
  py::class_<TeamStrategy> strategy(m, "TeamStrategy", "A team's decision makers, one per robot.");
  tpuaf::bindings::bind_strategy_calls(strategy);
  strategy.def_property_readonly("is_native", &TeamStrategy::is_native,
                                 "True if it never calls back into Python (the run may release "
                                 "the GIL).");
  py::class_<PythonStrategy, TeamStrategy>(
      m, "PythonStrategy",
      "Calls team.start(robot), team.decide(robot) -> int | None, team.on_message(robot, msg).")
      .def(py::init<py::object>(), py::arg("team"));
  py::class_<TpuafStrategy, TeamStrategy>(m, "TpuafStrategy",
                                          "TPUAF's decision path in C++ (tpuaf.policies.tpuaf).")
      .def(py::init([](const TpuafKnowledge& knowledge, UtilityForm form, bool any_vertex,
                       std::vector<NumpyPcg64> rngs, bool colocation) {
             return std::make_unique<TpuafStrategy>(knowledge, form, any_vertex, std::move(rngs),
                                                    colocation);
           }),
           py::arg("knowledge"), py::arg("form"), py::arg("any_vertex"), py::arg("rngs"),
           py::arg("colocation") = true)
      .def("knowledge", &TpuafStrategy::knowledge, py::arg("robot"),
           "What robot `robot` knows (a copy).")
      .def_property_readonly("shares_knowledge", &TpuafStrategy::shares_knowledge,
                             "True if the team holds one knowledge (a bus without loss and "
                             "delay).");

  wrap_tpuaf_plus(m);
}

// GraphEngine: construction, strategy, the run, the robots and the bus (the recorder: below).
// Over 80 lines on purpose: one .def per bound member, in the order of the C++ header; split,
// one class's binding would be scattered.
// long: one pybind11 declaration per bound name, read top to bottom; no logic
py::class_<GraphEngine> wrap_engine(py::module_& m) {
  py::class_<GraphEngine> engine(
      m, "GraphEngine", "Event loop of the graph runtime (tpuaf.runtimes.native drives it).");
  engine
      .def(py::init<const PatrolGraph&, Points, EngineConfig, UncertaintyField, NumpyPcg64>(),
           py::arg("graph"), py::arg("positions"), py::arg("config"), py::arg("field"),
           py::arg("bus_rng"), py::keep_alive<1, 2>())
      .def("set_strategy", &GraphEngine::set_strategy, py::arg("strategy"), py::keep_alive<1, 2>())
      .def(
          "run",
          [](GraphEngine& e, py::object progress, bool native) {
            std::function<void(double)> call;
            if (!progress.is_none()) {
              call = [progress](double now) {
                py::gil_scoped_acquire acquire;
                progress(now);
              };
            }
            if (native) {
              py::gil_scoped_release release;
              e.run(call);
            } else {
              e.run(call);
            }
          },
          py::arg("progress") = py::none(), py::arg("release_gil") = false,
          "Simulate to duration_s. release_gil only for C++ strategies.")
      .def("finish", &GraphEngine::finish, "Bring the recorder to now (robots held still).")
      .def_property_readonly("now", &GraphEngine::now)
      .def_property_readonly("events", &GraphEngine::events)
      .def("current_vertex", &GraphEngine::current_vertex, py::arg("robot"))
      .def("start_vertex", &GraphEngine::start_vertex, py::arg("robot"))
      .def("goal", &GraphEngine::goal, py::arg("robot"))
      .def("travelled_m", &GraphEngine::travelled_m, py::arg("robot"))
      .def("travel_time_s", &GraphEngine::travel_time_s, py::arg("robot"))
      .def("average_speed", &GraphEngine::average_speed, py::arg("robot"))
      .def(
          "position",
          [](const GraphEngine& e, int robot) {
            double x, y;
            e.position(robot, e.now(), x, y);
            return py::make_tuple(x, y);
          },
          py::arg("robot"), "True position [m] of a robot now.")
      .def(
          "send",
          [](GraphEngine& e, int robot, py::object message, int announced) {
            TeamMessage m;
            m.kind = TeamMessage::Kind::kOpaque;
            m.announced = announced;
            // The sender its recipients' liveness hears: getattr(message, "robot", -1).
            py::object sender = py::getattr(message, "robot", py::none());
            m.robot = -1;
            if (!sender.is_none()) {
              try {
                m.robot = sender.cast<int>();
              } catch (const py::cast_error&) {
                m.robot = -1;
              }
            }
            m.opaque = wrap(std::move(message));
            e.send(robot, std::move(m));
          },
          py::arg("robot"), py::arg("message"), py::arg("announced") = -1,
          "Broadcast a Python message (announced: the destination it announces, -1: none).")
      .def(
          "set_faults",
          [](GraphEngine& e, const std::vector<double>& times, const std::vector<int>& robots,
             const std::vector<bool>& deaths, std::vector<NumpyPcg64> heartbeat_rngs) {
            if (times.size() != robots.size() || times.size() != deaths.size()) {
              throw py::value_error("set_faults: times, robots and deaths differ in length");
            }
            std::vector<EngineFault> faults;
            for (std::size_t k = 0; k < times.size(); ++k) {
              faults.push_back({times[k], robots[k], static_cast<bool>(deaths[k])});
            }
            e.set_faults(std::move(faults), std::move(heartbeat_rngs));
          },
          py::arg("times_s"), py::arg("robots"), py::arg("deaths"), py::arg("heartbeat_rngs"),
          "The run's faults in time order (death or stall) and the heartbeat streams.")
      .def_property_readonly(
          "team", [](const GraphEngine& e) { return e.team(); },
          py::return_value_policy::reference_internal,
          "The team's liveness and fault steps (TeamLiveness, the physics runtime's too); "
          "None without faults.")
      .def("alive", &GraphEngine::alive, py::arg("robot"))
      .def("stalled", &GraphEngine::stalled, py::arg("robot"))
      .def_property_readonly("losses",
                             [](const GraphEngine& e) {
                               py::list out;  // (t [s], observer, lost teammate)
                               for (const auto& l : e.losses()) {
                                 out.append(py::make_tuple(l.time_s, l.observer, l.lost));
                               }
                               return out;
                             })
      .def("wake_at", &GraphEngine::wake_at, py::arg("robot"), py::arg("time_s"))
      .def("change_goal", &GraphEngine::change_goal, py::arg("robot"), py::arg("vertex"))
      .def_property_readonly("bus_stats", [](const GraphEngine& e) {
        const TeamBusStats& s = e.bus_stats();
        return py::make_tuple(s.sent, s.delivered, s.lost);
      });
  return engine;
}

// GraphEngine's recorder (bind_recorder: GroundTruthRecorder) and the robots' visit rules.
void wrap_recorder(py::class_<GraphEngine>& engine) {
  engine
      .def_property_readonly(
          "recorder", [](GraphEngine& e) -> GroundTruthRecorder& { return e.recorder(); },
          py::return_value_policy::reference_internal, "The run's ground-truth recorder.")
      .def("visit_rule", &GraphEngine::visit_rule, py::arg("robot"), py::return_value_policy::copy,
           "A copy of robot's VisitRule now.");
}

}  // namespace
}  // namespace tpuaf

void tpuaf::bindings::bind_engine(py::module_& m) {
  wrap_numpy(m);
  wrap_config(m);
  wrap_heartbeats(m);
  wrap_strategies(m);
  py::class_<GraphEngine> engine = wrap_engine(m);
  wrap_recorder(engine);
}
