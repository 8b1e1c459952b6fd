// The vertex geometry helpers (vertex_geometry.hpp), each written once.
#include <gtest/gtest.h>

#include "tpuaf_core/vertex_geometry.hpp"

namespace tpuaf {
namespace {

TEST(VertexGeometry, NearestIsTheFirstOnTies) {
  Points p(4, 2);
  p << 0, 0, 2, 0, 0, 2, 2, 2;
  EXPECT_EQ(nearest_vertex(p, 1.0, 1.0), 0);  // all four at the same distance
  EXPECT_EQ(nearest_vertex(p, 1.9, 1.2), 3);
  EXPECT_EQ(nearest_vertex(Points(0, 2), 1.0, 1.0), -1);
}

TEST(VertexGeometry, WithinCountsTheBoundary) {
  Points p(1, 2);
  p << 1, 1;
  EXPECT_DOUBLE_EQ(vertex_distance(p, 0, 4, 5), 5.0);
  EXPECT_TRUE(within_vertex(p, 0, 4, 5, 5.0));
  EXPECT_FALSE(within_vertex(p, 0, 4, 5, 4.999));
}

}  // namespace
}  // namespace tpuaf
