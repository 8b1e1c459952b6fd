#include "tpuaf_core/graph.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <list>
#include <mutex>
#include <stdexcept>
#include <unordered_map>

#include "tpuaf_core/shortest_path.hpp"

namespace tpuaf {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}

struct PatrolGraph::PathCache {
  std::mutex mutex;
  DijkstraWorkspace work;    // labels of the searches stopped early
  std::size_t capacity = 0;  // rows kept
  std::list<int> order;      // sources, most recently used first
  std::unordered_map<int, std::pair<std::shared_ptr<const DistanceRow>, std::list<int>::iterator>>
      rows;
  std::unordered_map<std::uint64_t, double> pairs;  // (u << 32 | v) -> d(u, v) [m]
  std::unique_ptr<Eigen::MatrixXd> distances;
  std::unique_ptr<Eigen::MatrixXi> hops;
};

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

void PatrolGraph::add_edge(const Edge& raw) {
  const int n = num_vertices();
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
                                " has non-positive length " + std::to_string(e.length_m) + " m");
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
    return;
  }
  adjacency_[e.u].push_back(e.v);
  adjacency_length_[e.u].push_back(e.length_m);
  adjacency_[e.v].push_back(e.u);
  adjacency_length_[e.v].push_back(e.length_m);
  edges_.push_back(e);
}

PatrolGraph::PatrolGraph(const Points& positions, const std::vector<Edge>& edges,
                         std::vector<std::int64_t> ids,
                         const std::vector<std::pair<int, int>>& one_way)
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
  for (const Edge& raw : edges) add_edge(raw);
  if (edges_.empty() && n > 1) throw std::invalid_argument("patrol graph has no edges");

  arcs_.assign(n, {});
  for (int u = 0; u < n; ++u) {
    for (std::size_t k = 0; k < adjacency_[u].size(); ++k) {
      arcs_[u].push_back({adjacency_[u][k], adjacency_length_[u][k]});
    }
  }
  out_ = adjacency_;
  if (!one_way.empty()) orient(one_way);
  cache_ = std::make_shared<PathCache>();
  cache_->capacity = std::max<std::size_t>(
      8, kRowCacheBytes / (static_cast<std::size_t>(n) * (sizeof(double) + sizeof(int))));
  const std::shared_ptr<const DistanceRow> first = row(0);  // kept: farthest-point starts use it
  for (int t = 0; t < n; ++t) {
    if (t != 0 && first->parent[t] < 0) {
      throw std::invalid_argument("patrol graph is disconnected: vertex " + vertex_name(t) +
                                  " cannot be reached from vertex " + vertex_name(0));
    }
  }
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
  return out_[v];
}

void PatrolGraph::orient(const std::vector<std::pair<int, int>>& one_way) {
  const int n = num_vertices();
  for (const auto& [u, v] : one_way) {
    if (u < 0 || u >= n || v < 0 || v >= n || !has_edge(u, v)) {
      throw std::invalid_argument("one-way arc " + vertex_name(u) + " -> " + vertex_name(v) +
                                  " is not an edge");
    }
    auto& back = arcs_[v];  // drop the arc v -> u
    back.erase(
        std::remove_if(back.begin(), back.end(), [u = u](const Arc& a) { return a.to == u; }),
        back.end());
    auto& out = out_[v];
    out.erase(std::remove(out.begin(), out.end(), u), out.end());
    one_way_.push_back({u, v});
  }
  // Strongly connected: every vertex reaches vertex 0 (the constructor checks the converse).
  std::vector<std::vector<int>> into(static_cast<std::size_t>(n));
  for (int u = 0; u < n; ++u) {
    for (int w : out_[u]) into[w].push_back(u);
  }
  std::vector<char> seen(static_cast<std::size_t>(n), 0);
  std::vector<int> stack{0};
  seen[0] = 1;
  while (!stack.empty()) {
    const int x = stack.back();
    stack.pop_back();
    for (int w : into[x]) {
      if (!seen[w]) {
        seen[w] = 1;
        stack.push_back(w);
      }
    }
  }
  for (int t = 0; t < n; ++t) {
    if (!seen[t]) {
      throw std::invalid_argument("one-way edges: vertex " + vertex_name(t) +
                                  " cannot drive back to vertex " + vertex_name(0));
    }
  }
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

std::shared_ptr<const DistanceRow> PatrolGraph::row(int source) const {
  check_vertex(source);
  PathCache& c = *cache_;
  std::lock_guard<std::mutex> lock(c.mutex);
  auto it = c.rows.find(source);
  if (it != c.rows.end()) {
    c.order.splice(c.order.begin(), c.order, it->second.second);
    return it->second.first;
  }
  c.work.run(arcs_, {source});
  const int n = num_vertices();
  auto made = std::make_shared<DistanceRow>();
  made->distance.resize(n);
  made->parent.resize(n);
  for (int t = 0; t < n; ++t) {
    made->distance[t] = c.work.distance(t);
    made->parent[t] = c.work.parent(t);
  }
  if (c.rows.size() >= c.capacity) {
    c.rows.erase(c.order.back());
    c.order.pop_back();
  }
  c.order.push_front(source);
  c.rows.emplace(source, std::make_pair(made, c.order.begin()));
  return made;
}

std::vector<double> PatrolGraph::distances_from_set(const std::vector<int>& sources) const {
  for (int s : sources) check_vertex(s);
  return dijkstra(arcs_, sources).distance;
}

double PatrolGraph::distance(int u, int v) const {
  check_vertex(u);
  check_vertex(v);
  PathCache& c = *cache_;
  std::lock_guard<std::mutex> lock(c.mutex);
  auto it = c.rows.find(u);
  if (it != c.rows.end()) return it->second.first->distance[v];
  const std::uint64_t key = (static_cast<std::uint64_t>(u) << 32) | static_cast<std::uint32_t>(v);
  const auto known = c.pairs.find(key);
  if (known != c.pairs.end()) return known->second;
  c.work.run(arcs_, {u}, 0.0, {}, v);  // the same label as the whole row's (settled: final)
  if (c.pairs.size() >= kPairCacheEntries) c.pairs.clear();
  return c.pairs.emplace(key, c.work.distance(v)).first->second;
}

int PatrolGraph::first_hop(int u, int v) const {
  PathCache& c = *cache_;
  std::lock_guard<std::mutex> lock(c.mutex);
  auto it = c.rows.find(u);
  if (it != c.rows.end()) {
    const std::vector<int>& parent = it->second.first->parent;
    int step = v;
    while (parent[step] != u) step = parent[step];
    return step;
  }
  c.work.run(arcs_, {u}, 0.0, {}, v);
  int step = v;
  while (c.work.parent(step) != u) step = c.work.parent(step);
  return step;
}

const Eigen::MatrixXd& PatrolGraph::distances() const {
  PathCache& c = *cache_;
  std::lock_guard<std::mutex> lock(c.mutex);
  if (!c.distances) {
    const int n = num_vertices();
    auto m = std::make_unique<Eigen::MatrixXd>(n, n);  // row s = search from s (column, then
    for (int s = 0; s < n; ++s) {                      // transposed: contiguous writes)
      c.work.run(arcs_, {s});
      double* col = m->col(s).data();
      for (int t = 0; t < n; ++t) col[t] = c.work.distance(t);
    }
    m->transposeInPlace();
    c.distances = std::move(m);
  }
  return *c.distances;
}

const Eigen::MatrixXi& PatrolGraph::hop_matrix() const {
  PathCache& c = *cache_;
  std::lock_guard<std::mutex> lock(c.mutex);
  if (!c.hops) {
    const int n = num_vertices();
    auto m = std::make_unique<Eigen::MatrixXi>(n, n);
    for (int s = 0; s < n; ++s) {
      const std::vector<int> level = hop_levels(s, -1);
      std::copy(level.begin(), level.end(), m->col(s).data());
    }
    m->transposeInPlace();
    c.hops = std::move(m);
  }
  return *c.hops;
}

std::size_t PatrolGraph::cached_rows() const {
  std::lock_guard<std::mutex> lock(cache_->mutex);
  return cache_->rows.size();
}

bool PatrolGraph::has_dense_matrices() const {
  std::lock_guard<std::mutex> lock(cache_->mutex);
  return cache_->distances != nullptr || cache_->hops != nullptr;
}

std::vector<int> PatrolGraph::path(int u, int v) const {
  check_vertex(u);
  check_vertex(v);
  std::vector<int> out{u};
  while (u != v) {
    u = first_hop(u, v);
    out.push_back(u);
  }
  return out;
}

std::vector<int> PatrolGraph::hop_levels(int u, int stop_at) const {
  std::vector<int> level(static_cast<std::size_t>(num_vertices()), -1);
  std::vector<int> frontier{u};
  level[u] = 0;
  for (std::size_t head = 0; head < frontier.size() && (stop_at < 0 || level[stop_at] < 0);
       ++head) {
    const int x = frontier[head];
    for (int w : adjacency_[x]) {
      if (level[w] < 0) {
        level[w] = level[x] + 1;
        frontier.push_back(w);
      }
    }
  }
  return level;
}

int PatrolGraph::hops(int u, int v) const {
  check_vertex(u);
  check_vertex(v);
  return hop_levels(u, v)[v];
}

}  // namespace tpuaf
