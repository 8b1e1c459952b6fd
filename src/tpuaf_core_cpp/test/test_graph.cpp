// Patrol graph: Dijkstra distances and paths, refusals naming the culprit.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "tpuaf_core/graph.hpp"

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
