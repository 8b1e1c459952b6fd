// Plan search with one-way arcs: closed walks drive every arc only its way, are as short as a
// brute force over the orders, and partitions are strongly connected (or none).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <set>
#include <stdexcept>
#include <utility>

#include "tpuaf_core/graph.hpp"
#include "tpuaf_core/tours.hpp"

namespace tpuaf {
namespace {

using Arcs = std::vector<std::pair<int, int>>;

// The lab's figure eight: rows 0-4 (top), 5-9 (middle), 10-14 (bottom), 1 m apart, the rows
// joined at both ends; every edge one way: top 0 -> 4, down 4 -> 9, middle 9 -> 5, up 5 -> 0,
// down 5 -> 10, bottom 10 -> 14, up 14 -> 9 (both loops share the middle row).
PatrolGraph figure_eight(Arcs* arcs_out = nullptr) {
  Points p(15, 2);
  std::vector<Edge> edges;
  Arcs arcs;
  for (int row = 0; row < 3; ++row) {
    for (int c = 0; c < 5; ++c) {
      p(5 * row + c, 0) = c;
      p(5 * row + c, 1) = 2 - row;
    }
  }
  for (int c = 0; c < 4; ++c) {
    arcs.push_back({c, c + 1});            // top, left to right
    arcs.push_back({5 + c + 1, 5 + c});    // middle, right to left
    arcs.push_back({10 + c, 10 + c + 1});  // bottom, left to right
  }
  arcs.insert(arcs.end(), {{4, 9}, {5, 0}, {5, 10}, {14, 9}});
  for (const auto& [u, v] : arcs) edges.push_back({u, v, 1.0});
  if (arcs_out) *arcs_out = arcs;
  return PatrolGraph(p, edges, {}, arcs);
}

// Every step of the closed walk is an edge driven its way (an arc, or a two-way edge).
bool drives_arcs(const PatrolGraph& g, const std::vector<int>& walk) {
  const std::set<std::pair<int, int>> arcs(g.one_way().begin(), g.one_way().end());
  for (std::size_t i = 0; i < walk.size(); ++i) {
    const int a = walk[i], b = walk[(i + 1) % walk.size()];
    if (!g.has_edge(a, b) || arcs.count({b, a})) return false;
  }
  return true;
}

TEST(DirectedTours, OneVertexWalkGoesRoundItsShortestDirectedCycle) {
  // vertex 0 leaves only to 1 (top row) and is entered only from 5: 0 1 2 3 4 9 8 7 6 5
  const PatrolGraph g = figure_eight();
  const ClosedWalk w = closed_walk(g, {0});
  EXPECT_EQ(w.walk, (std::vector<int>{0, 1, 2, 3, 4, 9, 8, 7, 6, 5}));
  EXPECT_DOUBLE_EQ(w.length_m, 10.0);
  EXPECT_TRUE(drives_arcs(g, w.walk));
}

TEST(DirectedTours, FigureEightWalkDrivesBothLoopsTheirWay) {
  const PatrolGraph g = figure_eight();
  std::vector<int> all(15);
  std::iota(all.begin(), all.end(), 0);
  const ClosedWalk w = closed_walk(g, all);
  EXPECT_TRUE(drives_arcs(g, w.walk));
  EXPECT_EQ(std::set<int>(w.walk.begin(), w.walk.end()).size(), 15u);
  EXPECT_NEAR(w.length_m, 20.0, 1e-9);  // both loops once: the shortest covering closed walk
  EXPECT_NEAR(closed_walk_length(g, all), 20.0, 1e-9);
}

TEST(DirectedTours, OneWayArcOnARingSetsTheDirection) {
  // a ring 0..7 with chords 0-4 and 2-6 (two-way), and one one-way arc 3 -> 2
  Points p(8, 2);
  std::vector<Edge> edges;
  for (int i = 0; i < 8; ++i) {
    p(i, 0) = std::cos(i * M_PI / 4);
    p(i, 1) = std::sin(i * M_PI / 4);
    edges.push_back({i, (i + 1) % 8, std::numeric_limits<double>::quiet_NaN()});
  }
  edges.push_back({0, 4, 2.0});
  edges.push_back({2, 6, 2.0});
  const PatrolGraph two_way(p, edges);
  const PatrolGraph g(p, edges, {}, {{3, 2}});
  const std::vector<int> all{0, 1, 2, 3, 4, 5, 6, 7};
  const ClosedWalk w = closed_walk(g, all);
  EXPECT_TRUE(drives_arcs(g, w.walk));
  bool drives_lane = false;
  for (std::size_t i = 0; i < w.walk.size(); ++i) {
    drives_lane |= w.walk[i] == 3 && w.walk[(i + 1) % w.walk.size()] == 2;
  }
  EXPECT_TRUE(drives_lane);  // the ring, driven the lane's way round
  EXPECT_NEAR(w.length_m, closed_walk(two_way, all).length_m, 1e-9);  // no longer: the ring
}

// Brute force: the shortest cyclic order of all vertices on the directed shortest paths.
double brute_force(const PatrolGraph& g) {
  const int n = g.num_vertices();
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  double best = std::numeric_limits<double>::infinity();
  do {
    double len = 0.0;
    for (int i = 0; i < n; ++i) len += g.distance(order[i], order[(i + 1) % n]);
    best = std::min(best, len);
  } while (std::next_permutation(order.begin() + 1, order.end()));
  return best;
}

TEST(DirectedTours, WalksMatchBruteForceOnRandomOneWayGraphs) {
  std::uint64_t state = 7;
  const auto next = [&]() {  // a small LCG: the graphs are the same on every machine
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<int>(state >> 33);
  };
  int checked = 0;
  for (int trial = 0; trial < 40 && checked < 12; ++trial) {
    const int n = 8;
    Points p(n, 2);
    std::vector<Edge> edges;
    Arcs arcs;
    for (int i = 0; i < n; ++i) {
      p(i, 0) = next() % 100;
      p(i, 1) = next() % 100;
    }
    for (int i = 0; i < n; ++i) {  // a ring plus random chords, some of them one way
      edges.push_back({i, (i + 1) % n, 1.0 + next() % 9});
      if (next() % 2) arcs.push_back({i, (i + 1) % n});
      const int j = next() % n;
      if (j != i && j != (i + 1) % n && (j + 1) % n != i) {
        edges.push_back({i, j, 1.0 + next() % 9});
        if (next() % 2) arcs.push_back({j, i});
      }
    }
    try {
      const PatrolGraph g(p, edges, {}, arcs);
      if (g.one_way().empty()) continue;
      std::vector<int> all(n);
      std::iota(all.begin(), all.end(), 0);
      const ClosedWalk w = closed_walk(g, all);
      EXPECT_TRUE(drives_arcs(g, w.walk));
      EXPECT_EQ(std::set<int>(w.walk.begin(), w.walk.end()).size(), static_cast<size_t>(n));
      EXPECT_NEAR(w.length_m, brute_force(g), 1e-9) << "trial " << trial;
      ++checked;
    } catch (const std::invalid_argument&) {  // not strongly connected (or a parallel arc)
    }
  }
  EXPECT_GE(checked, 8);
}

TEST(DirectedTours, PartitionsAreStronglyConnectedOrNone) {
  // the figure eight: every directed cycle runs through the middle row: no two parts
  EXPECT_TRUE(balanced_partition(figure_eight(), 2, 50).empty());
  // a 4 x 3 lattice with one one-way arc: two parts, each toured inside itself its way
  Points p(12, 2);
  std::vector<Edge> edges;
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 3; ++r) {
      const int v = c * 3 + r;
      p(v, 0) = c;
      p(v, 1) = r;
      if (r + 1 < 3) edges.push_back({v, v + 1, 1.0});
      if (c + 1 < 4) edges.push_back({v, v + 3, 1.0});
    }
  }
  const PatrolGraph g(p, edges, {}, {{0, 1}});
  const auto parts = balanced_partition(g, 2, 50);
  ASSERT_EQ(parts.size(), 2u);
  for (const auto& part : parts) {
    const ClosedWalk w = closed_walk(g, part);  // throws when not strongly connected
    EXPECT_TRUE(drives_arcs(g, w.walk));
  }
}

}  // namespace
}  // namespace tpuaf
