// The graph runtime's event loop (engine.hpp): numpy-compatible streams and sums, motion,
// dwell and retry timing, the bus (delay, loss), visits and interference episodes.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tpuaf_core/engine.hpp"

namespace tpuaf {
namespace {

// numpy.random.default_rng([3, 1]).bit_generator.state
NumpyPcg64 numpy_3_1() {
  return NumpyPcg64(0x5965f3094fb76bc0ULL, 0xdb1c9d97f130a0d4ULL, 0xe7a1a505a2178266ULL,
                    0xb8a537f40efcf881ULL);
}

TEST(Engine, Pcg64DrawsNumpysStream) {
  NumpyPcg64 g = numpy_3_1();
  EXPECT_EQ(g.random(), 0.25325307785026463);
  EXPECT_EQ(g.random(), 0.40719719128199483);
  EXPECT_EQ(g.integers(7), 5);
  EXPECT_EQ(g.integers(7), 2);
  EXPECT_EQ(g.random(), 0.4274453739986771);
  EXPECT_THROW(g.integers(0), std::invalid_argument);
}

TEST(Engine, PairwiseSumIsExactOnIntegersAndSplitsLikeNumpy) {
  std::vector<double> a(20000);
  for (std::size_t i = 0; i < a.size(); ++i) a[i] = static_cast<double>(i % 97);
  double exact = 0;
  for (double x : a) exact += x;
  EXPECT_EQ(numpy_sum(a.data(), a.size()), exact);  // small integers: every order is exact
  const double tiny[3] = {1.0, 1e-16, 1e-16};
  EXPECT_EQ(numpy_pairwise_sum(tiny, 3), (1.0 + 1e-16) + 1e-16);  // < 8: left to right
}

// Four vertices on a line 0 - 1 - 2 - 3, 10 m apart; robots walk back and forth.
PatrolGraph line_graph() {
  Points p(4, 2);
  p << 0, 0, 10, 0, 20, 0, 30, 0;
  return PatrolGraph(p, {{0, 1, NAN}, {1, 2, NAN}, {2, 3, NAN}});
}

UncertaintyField field_of(const PatrolGraph& g) {
  return UncertaintyField(g.positions(), Eigen::VectorXd::Constant(g.num_vertices(), 0.01),
                          Eigen::VectorXd::Ones(g.num_vertices()));
}

// A scripted strategy: each robot's goals in turn (-1 = wait), messages counted.
class Script : public TeamStrategy {
 public:
  std::vector<std::vector<int>> goals;
  std::vector<std::size_t> k;
  std::vector<std::vector<double>> decide_times, heard_times;
  bool talk = false;
  void start(StrategyHost& e, int) override {
    k.resize(static_cast<std::size_t>(e.robots()));
    decide_times.resize(k.size());
    heard_times.resize(k.size());
  }
  int decide(StrategyHost& e, int robot) override {
    const auto r = static_cast<std::size_t>(robot);
    decide_times[r].push_back(e.now());
    if (talk) {
      TeamMessage m;
      m.kind = TeamMessage::Kind::kVisit;
      m.robot = robot;
      e.send(robot, m);
    }
    return k[r] < goals[r].size() ? goals[r][k[r]++] : -1;
  }
  void on_message(StrategyHost& e, int robot, const TeamMessage&) override {
    heard_times[static_cast<std::size_t>(robot)].push_back(e.now());
  }
};

EngineConfig config(int robots, double duration_s, std::vector<int> starts) {
  EngineConfig c;
  c.robots = robots;
  c.duration_s = duration_s;
  c.nominal_speed_mps = 2.0;
  c.start_vertices = std::move(starts);
  return c;
}

TEST(Engine, DrivesEdgesAtNominalSpeedDwellsAndRetries) {
  const PatrolGraph g = line_graph();
  GraphEngine engine(g, g.positions(), config(1, 40.0, {0}), field_of(g), numpy_3_1());
  Script s;
  s.goals = {{3, 3, -1}};  // 30 m at 2 m/s, then a dwell (goal = here), then waiting
  engine.set_strategy(&s);
  engine.run();
  const auto& visits = engine.recorder().visits();
  ASSERT_EQ(visits.size(), 2u);  // the start vertex, then 3 at 15 s; the dwell is no visit
  EXPECT_EQ(visits[1].vertex, 3);
  EXPECT_DOUBLE_EQ(visits[1].time_s, 15.0);  // pass-through vertices 1, 2 are no visits
  EXPECT_EQ(engine.recorder().dwells(), 1);
  EXPECT_DOUBLE_EQ(engine.recorder().dwell_time_s(), 1.0);  // STAY_S = 1 s
  // Waiting without a wake-up: asked again every retry_s = 1 s.
  const auto& t = s.decide_times[0];
  ASSERT_GE(t.size(), 5u);
  EXPECT_DOUBLE_EQ(t[3] - t[2], 1.0);
  EXPECT_DOUBLE_EQ(engine.travelled_m(0), 30.0);
  EXPECT_DOUBLE_EQ(engine.average_speed(0), 2.0);
  EXPECT_EQ(engine.recorder().timeseries().size(), 40u);  // 1 Hz rows t = 1..40 s
}

// Arrival times at `vertex` of `robot` in the recorder's visits.
std::vector<double> visit_times(const GraphEngine& engine, int robot, int vertex) {
  std::vector<double> out;
  for (const auto& v : engine.recorder().visits()) {
    if (v.robot == robot && v.vertex == vertex) out.push_back(v.time_s);
  }
  return out;
}

TEST(Engine, NarrowVerticesSpaceArrivalsByTheHeadway) {
  // Both robots leave vertex 0 for 3 at once; 1 and 2 are one robot wide, 3 s headway: the
  // second passes each of them 3 s after the first (5 s edges at 2 m/s).
  const PatrolGraph g = line_graph();
  EngineConfig c = config(2, 40.0, {0, 0});
  c.narrow_vertices = {1, 2};
  c.narrow_headway_s = 3.0;
  GraphEngine engine(g, g.positions(), c, field_of(g), numpy_3_1());
  Script s;
  s.goals = {{3, -1}, {3, -1}};
  engine.set_strategy(&s);
  engine.run();
  EXPECT_EQ(visit_times(engine, 0, 3), std::vector<double>({15.0}));
  EXPECT_EQ(visit_times(engine, 1, 3), std::vector<double>({18.0}));
  // points that pass through each other without the narrow vertices
  GraphEngine points(g, g.positions(), config(2, 40.0, {0, 0}), field_of(g), numpy_3_1());
  Script s2;
  s2.goals = s.goals;
  points.set_strategy(&s2);
  points.run();
  EXPECT_EQ(visit_times(points, 1, 3), std::vector<double>({15.0}));
}

TEST(Engine, ARobotStandingOnANarrowVertexHoldsTheNextShortOfIt) {
  // Robot 1 stands on narrow vertex 1 until its tenth decision; robot 0, bound for 3 through
  // it, waits short of it and passes a headway after robot 1 drove off.
  const PatrolGraph g = line_graph();
  EngineConfig c = config(2, 60.0, {0, 1});
  c.narrow_vertices = {1};
  c.narrow_headway_s = 3.0;
  GraphEngine engine(g, g.positions(), c, field_of(g), numpy_3_1());
  Script s;
  s.goals = {{3, -1}, std::vector<int>(10, -1)};
  s.goals[1].push_back(3);
  s.goals[1].push_back(-1);
  engine.set_strategy(&s);
  engine.run();
  ASSERT_GE(s.decide_times[1].size(), 11u);
  const double left = s.decide_times[1][10];  // robot 1 drives off vertex 1
  EXPECT_GT(left, 5.0);                       // after robot 0 reached it at 5 s
  EXPECT_EQ(visit_times(engine, 1, 3), std::vector<double>({left + 10.0}));
  EXPECT_EQ(visit_times(engine, 0, 3), std::vector<double>({left + 3.0 + 10.0}));
}

TEST(Engine, ARobotHeldShortOfANarrowVertexTooLongFailsItsGoal) {
  // Robot 1 never leaves narrow vertex 1: robot 0's goal through it fails after the give-up
  // time (the navigator's in physics), and it decides anew from the vertex nearest to it.
  const PatrolGraph g = line_graph();
  EngineConfig c = config(2, 60.0, {0, 1});
  c.narrow_vertices = {1};
  c.narrow_headway_s = 3.0;
  c.stall_give_up_s = 20.0;
  GraphEngine engine(g, g.positions(), c, field_of(g), numpy_3_1());
  Script s;
  s.goals = {{3, 0, -1}, std::vector<int>(200, -1)};
  engine.set_strategy(&s);
  engine.run();
  EXPECT_EQ(engine.protocol(0).failures(), 1);
  EXPECT_TRUE(visit_times(engine, 0, 3).empty());
  ASSERT_GE(s.decide_times[0].size(), 2u);
  EXPECT_DOUBLE_EQ(s.decide_times[0][1], 25.0);  // held at 5 s, gave up 20 s later
  double x, y;
  engine.position(0, 60.0, x, y);
  EXPECT_DOUBLE_EQ(x, 0.0);  // then drove back to vertex 0 (it waited 5 m short of 1)
}

TEST(Engine, ForgottenVisitsKeepIndicesAndPerVertexTimes) {
  const PatrolGraph g = line_graph();
  GraphEngine engine(g, g.positions(), config(1, 40.0, {0}), field_of(g), numpy_3_1());
  Script s;
  s.goals = {{3, 0, -1}};  // visits: 0 at 0 s, 3 at 15 s, 0 at 30 s
  engine.set_strategy(&s);
  engine.run();
  GroundTruthRecorder& rec = engine.recorder();
  rec.forget_visits_before(2);
  EXPECT_EQ(rec.visit_count(), 3u);
  EXPECT_EQ(rec.visits_forgotten(), 2u);
  ASSERT_EQ(rec.visits().size(), 1u);  // only the last one is still held
  EXPECT_DOUBLE_EQ(rec.visits()[0].time_s, 30.0);
  EXPECT_DOUBLE_EQ(rec.visit_idleness()[0], 30.0);  // 30 s - 0 s
  rec.forget_visits_before(1);                      // already forgotten: nothing changes
  EXPECT_EQ(rec.visits_forgotten(), 2u);
  rec.forget_visits_before(10);  // past the end: all of them
  EXPECT_TRUE(rec.visits().empty());
  EXPECT_EQ(rec.visit_count(), 3u);
  EXPECT_EQ(rec.vertex_times()[0].size(), 2u);  // what the summary reads stays
}

TEST(Engine, BusDelaysAndLosesMessages) {
  const PatrolGraph g = line_graph();
  EngineConfig c = config(3, 30.0, {0, 1, 2});
  c.delay_s = 2.5;
  GraphEngine engine(g, g.positions(), c, field_of(g), numpy_3_1());
  Script s;
  s.goals = {{1}, {2}, {3}};
  s.talk = true;
  engine.set_strategy(&s);
  engine.run();
  // Robot 0 decided at 0 s and at its arrival at 5 s; the others hear both 2.5 s later.
  ASSERT_GE(s.heard_times[1].size(), 2u);
  EXPECT_DOUBLE_EQ(s.heard_times[1][0], 2.5);
  long long heard = 0;
  for (const auto& h : s.heard_times) {
    heard += static_cast<long long>(h.size());
    for (double t : h) EXPECT_GE(t, 2.5);
  }
  EXPECT_EQ(engine.bus_stats().delivered, heard);
  // Every message reaches the 2 others, except those still in flight at the end (sent in the
  // last 2.5 s: the waiting robots ask again every second).
  EXPECT_LT(engine.bus_stats().delivered, 2 * engine.bus_stats().sent);
  EXPECT_GE(engine.bus_stats().delivered, 2 * (engine.bus_stats().sent - 3 * 3));
  EXPECT_EQ(engine.bus_stats().lost, 0);

  c.loss = 1.0;
  GraphEngine lossy(g, g.positions(), c, field_of(g), numpy_3_1());
  Script quiet;
  quiet.goals = {{1}, {2}, {3}};
  quiet.talk = true;
  lossy.set_strategy(&quiet);
  lossy.run();
  EXPECT_EQ(lossy.bus_stats().delivered, 0);
  EXPECT_EQ(lossy.bus_stats().lost, 2 * lossy.bus_stats().sent);
}

TEST(Engine, InterferenceEntryIsTheExactCrossingTime) {
  const PatrolGraph g = line_graph();
  EngineConfig c = config(2, 30.0, {0, 3});
  c.interference_distance_m = 2.0;
  GraphEngine engine(g, g.positions(), c, field_of(g), numpy_3_1());
  Script s;
  s.goals = {{3}, {0}};  // head-on along the line, 2 m/s each: 30 m apart at t = 0
  engine.set_strategy(&s);
  engine.run();
  const auto& episodes = engine.recorder().interferences();
  ASSERT_EQ(episodes.size(), 1u);                             // they pass each other once
  EXPECT_NEAR(episodes[0].time_s, (30.0 - 2.0) / 4.0, 1e-9);  // 2 m apart at 7 s
  EXPECT_EQ(episodes[0].a, 0);
  EXPECT_EQ(episodes[0].b, 1);
}

// A 6 x 5 lattice, 4 m apart, with irregular extra lengths: TPUAF has ties and long edges.
PatrolGraph lattice_graph() {
  Points p(30, 2);
  std::vector<Edge> edges;
  for (int c = 0; c < 6; ++c) {
    for (int r = 0; r < 5; ++r) {
      const int v = c * 5 + r;
      p(v, 0) = 4.0 * c;
      p(v, 1) = 4.0 * r;
      if (r < 4) edges.push_back({v, v + 1, (v % 3 == 0) ? 9.0 : NAN});
      if (c < 5) edges.push_back({v, v + 5, NAN});
    }
  }
  return PatrolGraph(p, edges);
}

struct TpuafRun {
  std::vector<VisitRecord> visits;
  std::vector<SampleRow> rows;
  long long delivered = 0;
  bool shared = false;
};

// TPUAF with 8 robots for 900 s; a short intention timeout so that intentions go stale (dropped by
// some robots' decisions and not by others').
TpuafRun run_tpuaf(double loss, bool any_vertex, UtilityForm form) {
  const PatrolGraph g = lattice_graph();
  const int n = 8;
  EngineConfig c = config(n, 900.0, {0, 0, 7, 12, 12, 19, 24, 29});
  c.nominal_speed_mps = 1.0;
  c.loss = loss;
  GraphEngine engine(g, g.positions(), c, field_of(g), numpy_3_1());
  const TpuafKnowledge prototype(Eigen::VectorXd::Constant(30, 0.01),
                                 Eigen::VectorXd::Constant(30, 0.5), {}, 0.2, 2.0, 1.5);
  std::vector<NumpyPcg64> rngs;
  for (int i = 0; i < n; ++i) rngs.push_back(NumpyPcg64(7, 11 + i, 13, 2 * i + 1));
  TpuafStrategy strategy(prototype, form, any_vertex, rngs);
  engine.set_strategy(&strategy);
  engine.run();
  engine.finish();
  return {engine.recorder().visits(), engine.recorder().timeseries(), engine.bus_stats().delivered,
          strategy.shares_knowledge()};
}

TEST(Engine, TeamKnowledgeWithoutLossOrDelayGivesTheRunOfPerRobotCopies) {
  // loss = 1e-300 never loses a message but makes the bus deliver recipient by recipient
  // into every robot's own copy: the same run, to the last digit.
  for (const bool any_vertex : {false, true}) {
    for (const UtilityForm form : {UtilityForm::kEq13, UtilityForm::kEq14}) {
      const TpuafRun team = run_tpuaf(0.0, any_vertex, form);
      const TpuafRun copies = run_tpuaf(1e-300, any_vertex, form);
      EXPECT_TRUE(team.shared);
      EXPECT_FALSE(copies.shared);
      EXPECT_EQ(team.delivered, copies.delivered);
      ASSERT_EQ(team.visits.size(), copies.visits.size());
      ASSERT_GT(team.visits.size(), 100u);
      for (std::size_t k = 0; k < team.visits.size(); ++k) {
        EXPECT_EQ(team.visits[k].time_s, copies.visits[k].time_s) << k;
        EXPECT_EQ(team.visits[k].robot, copies.visits[k].robot) << k;
        ASSERT_EQ(team.visits[k].vertex, copies.visits[k].vertex) << k;
      }
      ASSERT_EQ(team.rows.size(), copies.rows.size());
      EXPECT_EQ(team.rows.back().uncertainty_mean, copies.rows.back().uncertainty_mean);
    }
  }
}

}  // namespace
}  // namespace tpuaf
