// Patrol graph: vertices with metric positions and undirected edges with lengths [m].
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "tpuaf_core/perception.hpp"

namespace tpuaf {

struct Edge {
  int u;
  int v;
  double length_m;
};

class PatrolGraph {
 public:
  // positions: one row per vertex [m]. ids: user-facing vertex ids (used in error messages),
  // defaults to 0..n-1. Edge endpoints are indices into positions. A NaN length means the
  // Euclidean distance. Parallel edges keep the shortest. Refuses self-loops, unknown vertices,
  // non-positive lengths and disconnected graphs with a message naming the culprit.
  PatrolGraph(const Points& positions, const std::vector<Edge>& edges,
              std::vector<std::int64_t> ids = {});

  int num_vertices() const { return static_cast<int>(positions_.rows()); }
  int num_edges() const { return static_cast<int>(edges_.size()); }
  const Points& positions() const { return positions_; }
  const std::vector<Edge>& edges() const { return edges_; }
  const std::vector<std::int64_t>& ids() const { return ids_; }
  const std::vector<int>& neighbours(int v) const;
  // Length of edge u-v [m]; throws if there is no such edge.
  double edge_length(int u, int v) const;
  bool has_edge(int u, int v) const;
  double mean_edge_length() const { return mean_edge_length_; }
  double total_edge_length() const { return total_edge_length_; }
  double min_edge_length() const { return min_edge_length_; }
  double max_edge_length() const { return max_edge_length_; }

  // Shortest-path length [m] along edges.
  double distance(int u, int v) const;
  const Eigen::MatrixXd& distances() const { return dist_; }
  // Vertex sequence of a shortest path, both ends included.
  std::vector<int> path(int u, int v) const;
  // Fewest edges between u and v.
  int hops(int u, int v) const;
  const Eigen::MatrixXi& hop_matrix() const { return hops_; }

  std::string vertex_name(int v) const;
  void check_vertex(int v) const;

 private:
  Points positions_;
  std::vector<Edge> edges_;
  std::vector<std::int64_t> ids_;
  std::vector<std::vector<int>> adjacency_;
  std::vector<std::vector<double>> adjacency_length_;
  Eigen::MatrixXd dist_;
  Eigen::MatrixXi next_hop_;
  Eigen::MatrixXi hops_;
  double mean_edge_length_ = 0, total_edge_length_ = 0, min_edge_length_ = 0,
         max_edge_length_ = 0;
};

}  // namespace tpuaf
