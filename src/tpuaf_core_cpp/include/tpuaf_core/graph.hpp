// Patrol graph: vertices with metric positions and undirected edges with lengths [m]; optionally
// some edges one-way (a traffic orientation, docs/LANES.md): shortest paths then follow the arcs.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "tpuaf_core/perception.hpp"
#include "tpuaf_core/shortest_path.hpp"

namespace tpuaf {

struct Edge {
  int u;
  int v;
  double length_m;
};

// Shortest paths from one source: lengths [m] and the previous vertex (-1 at the source).
struct DistanceRow {
  std::vector<double> distance;
  std::vector<int> parent;
};

// Rows kept per graph (least recently used dropped beyond this): every row of a graph up to
// about 2,300 vertices, 530 rows of a 10,000-vertex one.
constexpr std::size_t kRowCacheBytes = 64u << 20;  // [B]
// Single distances d(u, v) of sources without a kept row, kept until this many (then cleared):
// strategies ask the same few pairs (a walk's steps) again and again.
constexpr std::size_t kPairCacheEntries = 1u << 20;  // ~40 MB at most

class PatrolGraph {
 public:
  // positions: one row per vertex [m]. ids: user-facing vertex ids (used in error messages),
  // defaults to 0..n-1. Edge endpoints are indices into positions. A NaN length means the
  // Euclidean distance. Parallel edges keep the shortest. Refuses self-loops, unknown vertices,
  // non-positive lengths and disconnected graphs with a message naming the culprit.
  // one_way: arcs (u, v) of edges that may be driven only from u to v (the other edges both
  // ways); then shortest paths, distances and neighbours() follow the arcs, and the graph must
  // be strongly connected (refused otherwise). Lengths, edges and hops stay undirected.
  PatrolGraph(const Points& positions, const std::vector<Edge>& edges,
              std::vector<std::int64_t> ids = {},
              const std::vector<std::pair<int, int>>& one_way = {});

  int num_vertices() const { return static_cast<int>(positions_.rows()); }
  int num_edges() const { return static_cast<int>(edges_.size()); }
  const Points& positions() const { return positions_; }
  const std::vector<Edge>& edges() const { return edges_; }
  const std::vector<std::int64_t>& ids() const { return ids_; }
  // The vertices reachable over one edge from v (with one-way edges: along their arcs).
  const std::vector<int>& neighbours(int v) const;
  const std::vector<std::pair<int, int>>& one_way() const { return one_way_; }
  // Length of edge u-v [m]; throws if there is no such edge.
  double edge_length(int u, int v) const;
  bool has_edge(int u, int v) const;
  double mean_edge_length() const { return mean_edge_length_; }
  double total_edge_length() const { return total_edge_length_; }
  double min_edge_length() const { return min_edge_length_; }
  double max_edge_length() const { return max_edge_length_; }

  // Shortest paths are searched on demand (no all-pairs matrix unless asked for): a row is
  // one Dijkstra search from its source (shortest_path.hpp), every value the same as a row of
  // the all-pairs matrix would hold.
  // Shortest-path length [m] along edges from u to v: u's cached row, else a search from u
  // stopped once v is settled.
  double distance(int u, int v) const;
  // Lengths [m] from `source` to every vertex, kept in the graph's row cache.
  std::shared_ptr<const DistanceRow> row(int source) const;
  // Lengths [m] from the nearest of `sources` to every vertex (one search from all of them;
  // not cached): the distance of every vertex to a vertex set.
  std::vector<double> distances_from_set(const std::vector<int>& sources) const;
  // All-pairs lengths [m] (n x n doubles, 8 n^2 B): built by the first call and kept, for
  // callers that need every pair (the baselines); others use row() or distance().
  const Eigen::MatrixXd& distances() const;
  // Vertex sequence of a shortest path, both ends included: each step the first hop of a
  // shortest path from the vertex reached (u's search, then the next vertex's, ...).
  std::vector<int> path(int u, int v) const;
  // Fewest edges between u and v (breadth-first search from u).
  int hops(int u, int v) const;
  // All-pairs hop counts (n x n ints): built by the first call and kept.
  const Eigen::MatrixXi& hop_matrix() const;
  // What the graph holds now: rows in its cache, and whether the all-pairs matrices were built.
  std::size_t cached_rows() const;
  bool has_dense_matrices() const;

  std::string vertex_name(int v) const;
  void check_vertex(int v) const;

 private:
  Points positions_;
  std::vector<Edge> edges_;
  std::vector<std::int64_t> ids_;
  struct PathCache;  // row cache, search labels, all-pairs matrices; shared by copies
  int first_hop(int u, int v) const;
  // Checks an edge (known ends, no self-loop, length > 0; NaN = Euclidean) and adds it; a
  // parallel edge keeps the shorter length.
  void add_edge(const Edge& raw);
  // Breadth-first levels from u (-1: not reached), stopped once stop_at (>= 0) has its level.
  std::vector<int> hop_levels(int u, int stop_at) const;

  // Refuses one-way arcs that are not edges, and a graph one cannot drive around.
  void orient(const std::vector<std::pair<int, int>>& one_way);

  std::vector<std::vector<int>> adjacency_;
  std::vector<std::vector<int>> out_;  // neighbours along the arcs (adjacency_ when none)
  std::vector<std::pair<int, int>> one_way_;
  std::vector<std::vector<double>> adjacency_length_;
  ArcLists arcs_;
  std::shared_ptr<PathCache> cache_;
  double mean_edge_length_ = 0, total_edge_length_ = 0, min_edge_length_ = 0, max_edge_length_ = 0;
};

}  // namespace tpuaf
