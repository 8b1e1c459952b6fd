// Plan search on hand-checked graphs: orders, closed walks, partitions, robots per part.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

#include "tpuaf_core/graph.hpp"
#include "tpuaf_core/tours.hpp"

namespace tpuaf {
namespace {

// A path 0-1-..-(n-1) of 1 m edges along x.
PatrolGraph path_graph(int n) {
  Points p(n, 2);
  std::vector<Edge> edges;
  for (int i = 0; i < n; ++i) {
    p(i, 0) = i;
    p(i, 1) = 0;
    if (i + 1 < n) edges.push_back({i, i + 1, 1.0});
  }
  return PatrolGraph(p, edges);
}

// A cols x rows lattice of 1 m edges; vertex c * rows + r at (c, r).
PatrolGraph lattice(int cols, int rows) {
  Points p(cols * rows, 2);
  std::vector<Edge> edges;
  for (int c = 0; c < cols; ++c) {
    for (int r = 0; r < rows; ++r) {
      const int v = c * rows + r;
      p(v, 0) = c;
      p(v, 1) = r;
      if (r + 1 < rows) edges.push_back({v, v + 1, 1.0});
      if (c + 1 < cols) edges.push_back({v, v + rows, 1.0});
    }
  }
  return PatrolGraph(p, edges);
}

bool is_closed_walk(const PatrolGraph& g, const std::vector<int>& walk) {
  for (std::size_t i = 0; i < walk.size(); ++i) {
    if (!g.has_edge(walk[i], walk[(i + 1) % walk.size()])) return false;
  }
  return true;
}

TEST(Tours, OrderOfPointsOnACircleIsThePerimeterPolygon) {
  const int n = 40;
  std::vector<double> x(n), y(n);
  for (int i = 0; i < n; ++i) {  // scrambled: angle index 7 i mod 40
    const double a = 2 * M_PI * ((7 * i) % n) / n;
    x[i] = std::cos(a);
    y[i] = std::sin(a);
  }
  std::vector<double> d(n * n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) d[i * n + j] = std::hypot(x[i] - x[j], y[i] - y[j]);
  }
  const std::vector<int> order = tsp_order(d, n);
  EXPECT_EQ(std::set<int>(order.begin(), order.end()).size(), static_cast<std::size_t>(n));
  EXPECT_NEAR(order_length(d, n, order), n * 2 * std::sin(M_PI / n), 1e-9);
}

TEST(Tours, SearchIsDeterministic) {
  const PatrolGraph g = lattice(9, 7);
  std::vector<int> all(63);
  for (int v = 0; v < 63; ++v) all[v] = v;
  EXPECT_EQ(closed_walk(g, all).walk, closed_walk(g, all).walk);
}

TEST(Tours, ClosedWalkOfAPathGoesThereAndBack) {
  const PatrolGraph g = path_graph(4);
  const ClosedWalk w = closed_walk(g, {3, 1, 0, 2, 2});
  EXPECT_DOUBLE_EQ(w.length_m, 6.0);  // 0 1 2 3 2 1
  EXPECT_EQ(w.walk.size(), 6u);
  EXPECT_TRUE(is_closed_walk(g, w.walk));
  EXPECT_EQ(std::set<int>(w.walk.begin(), w.walk.end()), (std::set<int>{0, 1, 2, 3}));
}

TEST(Tours, ClosedWalkOfOneVertexDrivesToItsNearestNeighbourAndBack) {
  // Standing on a vertex makes no visit: a lone vertex's walk goes out and back, to the
  // nearer neighbour (vertex 1 at x = 1: 0 is 1 m away, 2 is 2 m away).
  Points p(3, 2);
  p << 0, 0, 1, 0, 3, 0;
  const PatrolGraph g(p, {{0, 1, 1.0}, {1, 2, 2.0}});
  const ClosedWalk w = closed_walk(g, {1});
  EXPECT_EQ(w.walk, (std::vector<int>{1, 0}));
  EXPECT_DOUBLE_EQ(w.length_m, 2.0);
  EXPECT_DOUBLE_EQ(closed_walk_length(g, {1}), 2.0);
  EXPECT_TRUE(is_closed_walk(g, w.walk));
  Points lone(1, 2);
  lone << 0, 0;
  const ClosedWalk alone = closed_walk(PatrolGraph(lone, {}), {0});  // no way out: stays
  EXPECT_EQ(alone.walk, (std::vector<int>{0}));
  EXPECT_DOUBLE_EQ(alone.length_m, 0.0);
}

TEST(Tours, ClosedWalkOfAnEvenLatticeIsAHamiltonCycle) {
  const PatrolGraph g = lattice(6, 4);  // 24 vertices: a Hamilton cycle of 24 m exists
  std::vector<int> all(24);
  for (int v = 0; v < 24; ++v) all[v] = v;
  const ClosedWalk w = closed_walk(g, all);
  EXPECT_DOUBLE_EQ(w.length_m, 24.0);
  EXPECT_EQ(w.walk.size(), 24u);
  EXPECT_TRUE(is_closed_walk(g, w.walk));
}

TEST(Tours, ClosedWalkStaysInsideItsVertices) {
  // 2 x 3 lattice: 0-1-2 / 3-4-5 columns; the subset {0, 2, 3, 5} (the columns' ends) is not
  // connected by itself, {0, 1, 2} is a path: 4 m inside it, never through 3..5.
  const PatrolGraph g = lattice(2, 3);
  EXPECT_THROW(closed_walk(g, {0, 2, 3, 5}), std::invalid_argument);
  const ClosedWalk w = closed_walk(g, {0, 1, 2});
  EXPECT_DOUBLE_EQ(w.length_m, 4.0);
  for (int v : w.walk) EXPECT_LT(v, 3);
}

TEST(Tours, PathSplitsIntoTwoEqualHalves) {
  const PatrolGraph g = path_graph(6);
  const auto parts = balanced_partition(g, 2, 100);
  ASSERT_EQ(parts.size(), 2u);
  std::set<std::vector<int>> got(parts.begin(), parts.end());
  EXPECT_EQ(got, (std::set<std::vector<int>>{{0, 1, 2}, {3, 4, 5}}));
}

TEST(Tours, SpanningTreeScoresAlsoSplitAPathInHalves) {
  const PatrolGraph g = path_graph(8);
  const auto parts = balanced_partition(g, 2, 100, {3, 4, 12345}, nullptr, true);
  std::set<std::vector<int>> got(parts.begin(), parts.end());
  EXPECT_EQ(got, (std::set<std::vector<int>>{{0, 1, 2, 3}, {4, 5, 6, 7}}));
}

TEST(Tours, LatticePartsAreConnectedAndCoverEveryVertexOnce) {
  const PatrolGraph g = lattice(8, 6);
  const auto parts = balanced_partition(g, 5, 400);
  ASSERT_EQ(parts.size(), 5u);
  std::vector<int> count(48, 0);
  double longest = 0, shortest = 1e9;
  for (const auto& part : parts) {
    for (int v : part) ++count[v];
    const double len = closed_walk(g, part).length_m;  // throws if not connected
    longest = std::max(longest, len);
    shortest = std::min(shortest, len);
  }
  for (int c : count) EXPECT_EQ(c, 1);
  // 48 vertices in 5 parts: ~9.6 each, a closed walk of ~10 m; balanced within a few m
  EXPECT_LE(longest, 14.0);
  EXPECT_LE(longest - shortest, 6.0);
}

TEST(Tours, SpanningTreeScoredLatticePartsAreConnectedAndBalanced) {
  // the large-part search moves only leaves of the costliest part's tree: parts stay connected
  const PatrolGraph g = lattice(20, 20);
  const auto parts = balanced_partition(g, 4, 400, {3, 4, 12345}, nullptr, true);
  ASSERT_EQ(parts.size(), 4u);
  std::vector<int> count(400, 0);
  std::size_t largest = 0, smallest = 400;
  for (const auto& part : parts) {
    for (int v : part) ++count[v];
    closed_walk(g, part);  // throws if not connected
    largest = std::max(largest, part.size());
    smallest = std::min(smallest, part.size());
  }
  for (int c : count) EXPECT_EQ(c, 1);
  EXPECT_LE(largest - smallest, 10u);  // 100 each at best; trees of unit edges: size - 1 m
}

TEST(Tours, MorePartsThanVerticesGiveOneVertexEach) {
  const PatrolGraph g = path_graph(3);
  const auto parts = balanced_partition(g, 5, 10);
  EXPECT_EQ(parts.size(), 3u);
  for (const auto& part : parts) EXPECT_EQ(part.size(), 1u);
}

TEST(Tours, ExtraRobotsGoToTheLongestPartPerRobot) {
  EXPECT_EQ(robots_per_part({10.0, 30.0}, 4), (std::vector<int>{1, 3}));
  EXPECT_EQ(robots_per_part({10.0, 30.0}, 5), (std::vector<int>{2, 3}));  // tie 10 / 1 = 30 / 3
  EXPECT_EQ(robots_per_part({10.0, 30.0}, 2), (std::vector<int>{1, 1}));
}

}  // namespace
}  // namespace tpuaf
