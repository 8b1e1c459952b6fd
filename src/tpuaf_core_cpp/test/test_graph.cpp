// Patrol graph: Dijkstra distances and paths, refusals naming the culprit.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "tpuaf_core/graph.hpp"
#include "tpuaf_core/shortest_path.hpp"

namespace tpuaf {
namespace {

// A square 0-1-2-3 of side 1 m plus a long diagonal 0-2 of 5 m.
PatrolGraph square() {
  Points p(4, 2);
  p << 0, 0, 1, 0, 1, 1, 0, 1;
  return PatrolGraph(p, {{0, 1, 1.0}, {1, 2, 1.0}, {2, 3, 1.0}, {3, 0, 1.0}, {0, 2, 5.0}});
}

TEST(Graph, ShortestPathsAvoidTheLongDiagonal) {
  PatrolGraph g = square();
  EXPECT_DOUBLE_EQ(g.distance(0, 2), 2.0);
  EXPECT_EQ(g.hops(0, 2), 1);  // hops count edges, whatever their length
  std::vector<int> path = g.path(0, 2);
  ASSERT_EQ(path.size(), 3u);
  EXPECT_EQ(path.front(), 0);
  EXPECT_EQ(path.back(), 2);
}

TEST(Graph, AWorkspaceSearchStoppedEarlyThenReusedGivesAFreshSearchsLabels) {
  PatrolGraph g = square();
  ArcLists arcs(4);
  for (const Edge& e : g.edges()) {
    arcs[e.u].push_back({e.v, e.length_m});
    arcs[e.v].push_back({e.u, e.length_m});
  }
  DijkstraWorkspace work;
  work.run(arcs, {0}, 0.0, {}, 1);  // stopped once vertex 1 is settled
  EXPECT_TRUE(work.settled(1));
  EXPECT_FALSE(work.settled(2));
  work.run(arcs, {3});  // the previous labels are forgotten
  const ShortestPathTree fresh = dijkstra(arcs, {3});
  for (int v = 0; v < 4; ++v) {
    EXPECT_EQ(work.distance(v), fresh.distance[v]);
    EXPECT_EQ(work.parent(v), fresh.parent[v]);
  }
  EXPECT_FALSE(g.has_dense_matrices());
  EXPECT_EQ(g.row(2)->distance[0], g.distances()(2, 0));
  EXPECT_TRUE(g.has_dense_matrices());
}

TEST(Graph, EdgeStatistics) {
  PatrolGraph g = square();
  EXPECT_EQ(g.num_edges(), 5);
  EXPECT_DOUBLE_EQ(g.total_edge_length(), 9.0);
  EXPECT_DOUBLE_EQ(g.mean_edge_length(), 9.0 / 5.0);
  EXPECT_DOUBLE_EQ(g.min_edge_length(), 1.0);
  EXPECT_DOUBLE_EQ(g.max_edge_length(), 5.0);
}

TEST(Graph, NanLengthMeansEuclidean) {
  Points p(2, 2);
  p << 0, 0, 3, 4;
  PatrolGraph g(p, {{0, 1, std::nan("")}});
  EXPECT_DOUBLE_EQ(g.edge_length(0, 1), 5.0);
}

TEST(Graph, DisconnectedGraphIsRefusedNamingAVertex) {
  Points p(3, 2);
  p << 0, 0, 1, 0, 5, 5;
  try {
    PatrolGraph g(p, {{0, 1, 1.0}}, {10, 11, 12});
    FAIL() << "a disconnected graph was accepted";
  } catch (const std::invalid_argument& err) {
    EXPECT_NE(std::string(err.what()).find("12"), std::string::npos) << err.what();
  }
}

TEST(Graph, SelfLoopAndNonPositiveLengthAreRefused) {
  Points p(2, 2);
  p << 0, 0, 1, 0;
  EXPECT_THROW(PatrolGraph(p, {{0, 0, 1.0}, {0, 1, 1.0}}), std::invalid_argument);
  EXPECT_THROW(PatrolGraph(p, {{0, 1, 0.0}}), std::invalid_argument);
  EXPECT_THROW(PatrolGraph(p, {{0, 2, 1.0}}), std::exception);
}

}  // namespace
}  // namespace tpuaf

namespace tpuaf {
namespace {

// A path 0 - 1 - 2 - 3 with unit arcs both ways.
ArcLists path4() {
  ArcLists arcs(4);
  for (int u = 0; u < 3; ++u) {
    arcs[u].push_back({u + 1, 1.0});
    arcs[u + 1].push_back({u, 1.0});
  }
  return arcs;
}

TEST(Dijkstra, MultiSourceSplitsAtTheMiddleAndTiesGoToTheFirstSource) {
  ShortestPathTree tree = dijkstra(path4(), {0, 3}, 1e-9);
  EXPECT_EQ(tree.source, (std::vector<int>{0, 0, 1, 1}));
  ArcLists arcs(3);  // 0 - 1 - 2: vertex 1 is equidistant from both sources
  arcs[0] = {{1, 1.0}};
  arcs[2] = {{1, 1.0}};
  EXPECT_EQ(dijkstra(arcs, {2, 0}, 1e-9).source[1], 0);  // the source listed first wins
}

TEST(Dijkstra, AllowedMaskAndEarlyStop) {
  ShortestPathTree blocked = dijkstra(path4(), {0}, 0.0, {1, 1, 0, 1});
  EXPECT_TRUE(std::isinf(blocked.distance[3]));
  EXPECT_EQ(blocked.parent[3], -1);
  ShortestPathTree stopped = dijkstra(path4(), {0}, 0.0, {}, 1);
  EXPECT_DOUBLE_EQ(stopped.distance[1], 1.0);
  EXPECT_EQ(stopped.source[2], -1);  // never settled
}

TEST(Dijkstra, PotentialSettlesFewerWithTheSameLengthsAndExpandStopsTheSearch) {
  const int side = 9;  // a unit lattice, vertex r * side + c at (c, r)
  ArcLists arcs(side * side);
  for (int r = 0; r < side; ++r) {
    for (int c = 0; c < side; ++c) {
      const int v = r * side + c;
      if (c + 1 < side) {
        arcs[v].push_back({v + 1, 1.0});
        arcs[v + 1].push_back({v, 1.0});
      }
      if (r + 1 < side) {
        arcs[v].push_back({v + side, 1.0});
        arcs[v + side].push_back({v, 1.0});
      }
    }
  }
  const int goal = 4 * side + 8;  // (8, 4), from (0, 4)
  DijkstraWorkspace plain, guided;
  plain.run(arcs, {4 * side}, 0.0, {}, goal);
  guided.run_until(
      arcs, {4 * side}, 0.0, {}, [&](int v) { return v == goal; }, nullptr,
      [&](int v) { return std::hypot(v % side - 8.0, v / side - 4.0); });
  EXPECT_DOUBLE_EQ(guided.distance(goal), 8.0);
  EXPECT_DOUBLE_EQ(plain.distance(goal), 8.0);
  EXPECT_LT(guided.settled_order().size(), plain.settled_order().size() / 2);
  for (int v : guided.settled_order()) {  // every settled label a shortest length
    EXPECT_DOUBLE_EQ(guided.distance(v), std::abs(v % side - 0.0) + std::abs(v / side - 4.0));
  }
  DijkstraWorkspace fenced;  // vertices at x >= 3 are settled but not left
  fenced.run_until(
      arcs, {0}, 0.0, {}, [](int) { return false; }, [&](int v) { return v % side < 3; });
  for (int v : fenced.settled_order()) EXPECT_LE(v % side, 3);
  EXPECT_EQ(fenced.settled_order().size(), static_cast<std::size_t>(4 * side));
}

TEST(Dijkstra, UnknownSourceIsRefused) { EXPECT_THROW(dijkstra(path4(), {9}), std::out_of_range); }

}  // namespace
}  // namespace tpuaf
