#include "tpuaf_core/graph.hpp"

#include "tpuaf_core/shortest_path.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <stdexcept>

namespace tpuaf {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}

std::string PatrolGraph::vertex_name(int v) const {
  if (v >= 0 && v < static_cast<int>(ids_.size())) return std::to_string(ids_[v]);
  return std::to_string(v);
}

void PatrolGraph::check_vertex(int v) const {
  if (v < 0 || v >= num_vertices()) {
    throw std::out_of_range("unknown vertex index " + std::to_string(v) + " (graph has " +
                            std::to_string(num_vertices()) + " vertices)");
  }
}

PatrolGraph::PatrolGraph(const Points& positions, const std::vector<Edge>& edges,
                         std::vector<std::int64_t> ids)
    : positions_(positions), ids_(std::move(ids)) {
  const int n = num_vertices();
  if (n == 0) throw std::invalid_argument("patrol graph has no vertices");
  if (ids_.empty()) {
    ids_.resize(n);
    for (int v = 0; v < n; ++v) ids_[v] = v;
  }
  if (static_cast<int>(ids_.size()) != n) {
    throw std::invalid_argument("need one id per vertex: " + std::to_string(ids_.size()) +
                                " ids for " + std::to_string(n) + " vertices");
  }
  for (int v = 0; v < n; ++v) {
    if (!std::isfinite(positions_(v, 0)) || !std::isfinite(positions_(v, 1))) {
      throw std::invalid_argument("vertex " + vertex_name(v) + " has a non-finite position");
    }
  }
  adjacency_.assign(n, {});
  adjacency_length_.assign(n, {});
  for (const Edge& raw : edges) {
    if (raw.u < 0 || raw.u >= n || raw.v < 0 || raw.v >= n) {
      throw std::out_of_range("edge (" + std::to_string(raw.u) + ", " + std::to_string(raw.v) +
                              ") names an unknown vertex (graph has " + std::to_string(n) +
                              " vertices)");
    }
    if (raw.u == raw.v) throw std::invalid_argument("self-loop at vertex " + vertex_name(raw.u));
    Edge e = raw;
    if (std::isnan(e.length_m)) {
      e.length_m = (positions_.row(e.u) - positions_.row(e.v)).norm();
    }
    if (!(e.length_m > 0) || !std::isfinite(e.length_m)) {
      throw std::invalid_argument("edge " + vertex_name(e.u) + "-" + vertex_name(e.v) +
                                  " has non-positive length " + std::to_string(e.length_m) +
                                  " m");
    }
    // Parallel edges: keep the shortest.
    auto& adj = adjacency_[e.u];
    auto it = std::find(adj.begin(), adj.end(), e.v);
    if (it != adj.end()) {
      const std::size_t k = static_cast<std::size_t>(it - adj.begin());
      if (e.length_m < adjacency_length_[e.u][k]) {
        adjacency_length_[e.u][k] = e.length_m;
        auto& back = adjacency_[e.v];
        const std::size_t kb =
            static_cast<std::size_t>(std::find(back.begin(), back.end(), e.u) - back.begin());
        adjacency_length_[e.v][kb] = e.length_m;
        for (Edge& kept : edges_) {
          if ((kept.u == e.u && kept.v == e.v) || (kept.u == e.v && kept.v == e.u)) {
            kept.length_m = e.length_m;
          }
        }
      }
      continue;
    }
    adjacency_[e.u].push_back(e.v);
    adjacency_length_[e.u].push_back(e.length_m);
    adjacency_[e.v].push_back(e.u);
    adjacency_length_[e.v].push_back(e.length_m);
    edges_.push_back(e);
  }
  if (edges_.empty() && n > 1) throw std::invalid_argument("patrol graph has no edges");

  // Shortest paths: Dijkstra from every vertex [m]; hop counts by breadth-first search. Each
  // source fills one contiguous column of the transposed matrices (transposed once at the end).
  Eigen::MatrixXd dist_t = Eigen::MatrixXd::Constant(n, n, kInf);
  Eigen::MatrixXi next_t = Eigen::MatrixXi::Constant(n, n, -1);
  Eigen::MatrixXi hops_t = Eigen::MatrixXi::Constant(n, n, -1);
  ArcLists arcs(n);
  for (int u = 0; u < n; ++u) {
    for (std::size_t k = 0; k < adjacency_[u].size(); ++k) {
      arcs[u].push_back({adjacency_[u][k], adjacency_length_[u][k]});
    }
  }
  std::vector<int> chain, frontier;
  for (int s = 0; s < n; ++s) {
    const ShortestPathTree tree = dijkstra(arcs, {s});
    const std::vector<int>& parent = tree.parent;
    double* dist_s = dist_t.col(s).data();
    int* next_s = next_t.col(s).data();
    for (int t = 0; t < n; ++t) dist_s[t] = tree.distance[t];
    for (int t = 0; t < n; ++t) {
      if (t == s || next_s[t] >= 0) continue;
      if (parent[t] < 0) {
        throw std::invalid_argument("patrol graph is disconnected: vertex " + vertex_name(t) +
                                    " cannot be reached from vertex " + vertex_name(s));
      }
      // The first hop after s: walk back from t to s or to a vertex whose first hop is known,
      // then hand it down the walked chain (each vertex walked once per source).
      chain.clear();
      int step = t;
      while (parent[step] != s && next_s[step] < 0) {
        chain.push_back(step);
        step = parent[step];
      }
      const int first = parent[step] == s ? step : next_s[step];
      next_s[step] = first;
      for (int v : chain) next_s[v] = first;
    }
    int* hops_s = hops_t.col(s).data();
    frontier.assign(1, s);
    hops_s[s] = 0;
    for (std::size_t head = 0; head < frontier.size(); ++head) {
      const int u = frontier[head];
      for (int w : adjacency_[u]) {
        if (hops_s[w] < 0) {
          hops_s[w] = hops_s[u] + 1;
          frontier.push_back(w);
        }
      }
    }
  }
  dist_ = dist_t.transpose();
  next_hop_ = next_t.transpose();
  hops_ = hops_t.transpose();
  for (const Edge& e : edges_) total_edge_length_ += e.length_m;
  if (!edges_.empty()) {
    mean_edge_length_ = total_edge_length_ / static_cast<double>(edges_.size());
    min_edge_length_ = kInf;
    for (const Edge& e : edges_) {
      min_edge_length_ = std::min(min_edge_length_, e.length_m);
      max_edge_length_ = std::max(max_edge_length_, e.length_m);
    }
  }
}

const std::vector<int>& PatrolGraph::neighbours(int v) const {
  check_vertex(v);
  return adjacency_[v];
}

bool PatrolGraph::has_edge(int u, int v) const {
  check_vertex(u);
  check_vertex(v);
  const auto& adj = adjacency_[u];
  return std::find(adj.begin(), adj.end(), v) != adj.end();
}

double PatrolGraph::edge_length(int u, int v) const {
  check_vertex(u);
  check_vertex(v);
  const auto& adj = adjacency_[u];
  auto it = std::find(adj.begin(), adj.end(), v);
  if (it == adj.end()) {
    throw std::invalid_argument("no edge between vertex " + vertex_name(u) + " and vertex " +
                                vertex_name(v));
  }
  return adjacency_length_[u][static_cast<std::size_t>(it - adj.begin())];
}

double PatrolGraph::distance(int u, int v) const {
  check_vertex(u);
  check_vertex(v);
  return dist_(u, v);
}

std::vector<int> PatrolGraph::path(int u, int v) const {
  check_vertex(u);
  check_vertex(v);
  std::vector<int> out{u};
  while (u != v) {
    u = next_hop_(u, v);
    out.push_back(u);
  }
  return out;
}

int PatrolGraph::hops(int u, int v) const {
  check_vertex(u);
  check_vertex(v);
  return hops_(u, v);
}

}  // namespace tpuaf
