// Plan search: cyclic orders, closed walks inside vertex subsets, balanced partitions.
#include "tpuaf_core/tours.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <map>
#include <numeric>
#include <queue>
#include <stdexcept>
#include <string>
#include <utility>

#include "partition_growth.hpp"
#include "tour_directed.hpp"
#include "tour_local_search.hpp"
#include "tour_metrics.hpp"
#include "tpuaf_core/shortest_path.hpp"

namespace tpuaf {
namespace {

using namespace tour;  // NOLINT: the internal pieces of this file's search

template <class Metric>
std::vector<int> nearest_neighbour(Metric& metric, int start) {
  const int n = metric.size();
  std::vector<char> seen(n, 0);
  std::vector<int> order{start};
  seen[start] = 1;
  for (int step = 1; step < n; ++step) {
    const int best = metric.nearest_unseen(order.back(), seen);
    order.push_back(best);
    seen[best] = 1;
  }
  return order;
}

template <class Metric>
double cyclic_length(Metric& metric, const std::vector<int>& order) {
  const int m = static_cast<int>(order.size());
  if (m < 2) return 0.0;
  double total = 0.0;
  for (int i = 0; i < m; ++i) total += metric(order[i], order[(i + 1) % m]);
  return total;
}

// Double bridge A B C D -> A C B D; cuts within kKickWindow positions of a random one.
struct Bridge {
  std::vector<int> order;
  // the ends of its three new edges, in the kicked order's sequence: A|C, C|B, B|D
  int ends[6];
};

Bridge double_bridge(const std::vector<int>& order, Rng& rng) {
  const int n = static_cast<int>(order.size());
  const int window = std::min(n, kKickWindow);
  const int origin = window < n ? rng.below(n) : 0;
  int cut[3];
  do {
    for (int& c : cut) c = 1 + rng.below(window - 1);
    std::sort(cut, cut + 3);
  } while (cut[0] == cut[1] || cut[1] == cut[2]);
  auto rot = [&](int i) { return order[(origin + i) % n]; };
  Bridge out;
  out.order.reserve(n);
  const auto append = [&](int from, int to) {  // rotated positions from..to-1, in one or two runs
    const int a = (origin + from) % n, len = to - from;
    const int first_run = std::min(len, n - a);
    out.order.insert(out.order.end(), order.begin() + a, order.begin() + a + first_run);
    out.order.insert(out.order.end(), order.begin(), order.begin() + (len - first_run));
  };
  append(0, cut[0]);
  append(cut[1], cut[2]);
  append(cut[0], cut[1]);
  append(cut[2], n);
  const int ends[6] = {rot(cut[0] - 1), rot(cut[1]),     rot(cut[2] - 1),
                       rot(cut[0]),     rot(cut[1] - 1), rot(cut[2])};
  std::copy(ends, ends + 6, out.ends);
  return out;
}

// Nearest neighbour from `starts` spread indices, 2-opt + Or-opt, then `kicks` double-bridge
// kicks of the best, each kept when the local optimum it leads to is shorter.
template <class Metric>
std::vector<int> search_order(Metric& metric, const TourSearch& search) {
  const int n = metric.size();
  std::vector<int> identity(n);
  std::iota(identity.begin(), identity.end(), 0);
  if (n <= 3) return identity;
  LocalSearch<Metric> ls(metric);
  std::vector<int> best;
  double best_len = std::numeric_limits<double>::infinity();
  const int starts = std::max(1, std::min(search.starts, n));
  int previous = -1;
  for (int i = 0; i < starts; ++i) {
    // start vertices spread evenly over 0..n-1
    const int s =
        starts == 1 ? 0 : static_cast<int>((static_cast<long long>(n - 1) * i) / (starts - 1));
    if (s == previous) continue;
    previous = s;
    ls.set_order(nearest_neighbour(metric, s));
    ls.push_all();
    ls.run();
    const double len = cyclic_length(metric, ls.order());
    if (len < best_len - kEps) {
      best = ls.order();
      best_len = len;
    }
  }
  if (n >= 8) {
    Rng rng{search.seed};
    for (int kick = 0; kick < search.kicks; ++kick) {
      const Bridge kicked = double_bridge(best, rng);
      ls.set_order(kicked.order);
      for (int v : kicked.ends) ls.push(v);  // the (at most 6) vertices of the new edges
      ls.run();
      double len;
      if constexpr (Metric::kOnDemand) {
        const int* e = kicked.ends;  // new edges A|C, C|B, B|D replace A|B, B|C, C|D
        const double bridge = metric(e[0], e[1]) + metric(e[2], e[3]) + metric(e[4], e[5]) -
                              metric(e[0], e[3]) - metric(e[4], e[1]) - metric(e[2], e[5]);
        len = best_len + bridge + ls.gain();
      } else {
        len = cyclic_length(metric, ls.order());
      }
      if (len < best_len - kEps) {
        best = ls.order();
        best_len = len;
      }
    }
  }
  return best;
}

// Lengths searched on demand for this many vertices (TourSearch::metric).
bool sparse_tour(int n_vertices, const TourSearch& search) {
  return search.metric == TourMetric::kSparse ||
         (search.metric == TourMetric::kAuto && n_vertices > kDenseTourMax);
}

// Shortest paths inside a vertex subset (local indices), for a part's metric and its walk.
struct SubsetPaths {
  std::vector<int> vertices;  // sorted global indices
  std::vector<double> dist;   // k x k [m]
  std::vector<int> parent;    // k x k: parent[a * k + b] = previous local vertex of b from a
};

SubsetPaths subset_paths(const PatrolGraph& graph, const std::vector<int>& input,
                         bool with_parents) {
  SubsetPaths out;
  out.vertices = sorted_unique(input);
  const int k = static_cast<int>(out.vertices.size());
  const ArcLists adj = subset_arcs(graph, out.vertices);
  const double inf = std::numeric_limits<double>::infinity();
  out.dist.assign(static_cast<std::size_t>(k) * k, inf);
  if (with_parents) out.parent.assign(static_cast<std::size_t>(k) * k, -1);
  using Item = std::pair<double, int>;
  for (int s = 0; s < k; ++s) {
    double* row = out.dist.data() + static_cast<std::size_t>(s) * k;
    int* par = with_parents ? out.parent.data() + static_cast<std::size_t>(s) * k : nullptr;
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> heap;
    row[s] = 0.0;
    heap.push({0.0, s});
    int settled = 0;
    while (!heap.empty()) {
      const auto [du, u] = heap.top();
      heap.pop();
      if (du > row[u]) continue;
      ++settled;
      for (const Arc& arc : adj[u]) {
        const int w = arc.to;
        if (du + arc.weight < row[w] - kEps) {
          row[w] = du + arc.weight;
          if (par) par[w] = u;
          heap.push({row[w], w});
        }
      }
    }
    if (settled < k) throw_not_connected(graph, k, out.vertices[s]);
  }
  return out;
}

// Length [m] of a minimum spanning tree of the subgraph induced by the sorted `part` (Kruskal).
// (length [m], (a, b)) of the edges inside a sorted vertex set, a < b positions in it, shortest
// first (Kruskal's order).
using PartEdge = std::pair<double, std::pair<int, int>>;
std::vector<PartEdge> part_edges(const PatrolGraph& graph, const std::vector<int>& part) {
  std::vector<std::pair<double, std::pair<int, int>>> edges;
  for (int a = 0; a < static_cast<int>(part.size()); ++a) {
    for (int w : graph.neighbours(part[a])) {
      if (w <= part[a] || !std::binary_search(part.begin(), part.end(), w)) continue;
      const int b = static_cast<int>(std::lower_bound(part.begin(), part.end(), w) - part.begin());
      edges.push_back({graph.edge_length(part[a], w), {a, b}});
    }
  }
  std::sort(edges.begin(), edges.end());
  return edges;
}

double spanning_tree_length(const PatrolGraph& graph, const std::vector<int>& part) {
  const std::vector<PartEdge> edges = part_edges(graph, part);
  std::vector<int> root(part.size());
  std::iota(root.begin(), root.end(), 0);
  auto find = [&](int v) {
    while (root[v] != v) v = root[v] = root[root[v]];
    return v;
  };
  double total = 0.0;
  for (const auto& [length, ends] : edges) {
    const int a = find(ends.first), b = find(ends.second);
    if (a != b) {
      root[a] = b;
      total += length;
    }
  }
  return total;
}

}  // namespace

double order_length(const std::vector<double>& dist, int n, const std::vector<int>& order) {
  const int m = static_cast<int>(order.size());
  if (m < 2) return 0.0;
  double total = 0.0;
  for (int i = 0; i < m; ++i) {
    total += dist[static_cast<std::size_t>(order[i]) * n + order[(i + 1) % m]];
  }
  return total;
}

std::vector<int> tsp_order(const std::vector<double>& dist, int n, const TourSearch& search) {
  if (n < 0 || dist.size() != static_cast<std::size_t>(n) * n) {
    throw std::invalid_argument("tsp_order: the distance matrix is not n x n");
  }
  DenseMetric metric(dist, n);
  return search_order(metric, search);
}

ClosedWalk closed_walk(const PatrolGraph& graph, const std::vector<int>& vertices,
                       const TourSearch& search) {
  ClosedWalk out;
  if (vertices.empty()) return out;
  const std::vector<int> sorted = sorted_unique(vertices);
  const int k = static_cast<int>(sorted.size());
  if (k == 1) return shuttle_walk(graph, sorted[0]);
  if (!directed(graph) && sparse_tour(k, search)) {  // one-way arcs: dense, asymmetric search
    SparseMetric metric(graph, sorted);
    const std::vector<int> order = search_order(metric, search);
    out.length_m = cyclic_length(metric, order);
    std::vector<int> path;
    for (int i = 0; i < k; ++i) {
      const int a = order[i], b = order[(i + 1) % k];
      out.walk.push_back(sorted[a]);
      path.clear();
      metric.append_path(a, b, &path);  // after a, up to b: b starts the next step
      for (std::size_t j = 0; j + 1 < path.size(); ++j) out.walk.push_back(sorted[path[j]]);
    }
    return out;
  }
  const SubsetPaths sp = subset_paths(graph, sorted, true);
  DenseMetric metric(sp.dist, k);
  const std::vector<int> order =
      directed(graph) ? directed_order(sp.dist, k, search) : search_order(metric, search);
  out.length_m = order_length(sp.dist, k, order);
  for (int i = 0; i < k; ++i) {
    const int a = order[i], b = order[(i + 1) % k];
    std::vector<int> seg;  // b back to (not including) a
    for (int v = b; v != a; v = sp.parent[static_cast<std::size_t>(a) * k + v]) seg.push_back(v);
    out.walk.push_back(sp.vertices[a]);
    for (auto it = seg.rbegin(); it + 1 != seg.rend(); ++it) out.walk.push_back(sp.vertices[*it]);
  }
  return out;
}

double closed_walk_length(const PatrolGraph& graph, const std::vector<int>& vertices,
                          const TourSearch& search) {
  const std::vector<int> sorted = sorted_unique(vertices);
  const int k = static_cast<int>(sorted.size());
  if (k == 0) return 0.0;
  if (k == 1) return shuttle_walk(graph, sorted[0]).length_m;
  if (!directed(graph) && sparse_tour(k, search)) {
    SparseMetric metric(graph, sorted);
    return cyclic_length(metric, search_order(metric, search));
  }
  const SubsetPaths sp = subset_paths(graph, sorted, false);
  if (directed(graph)) return order_length(sp.dist, k, directed_order(sp.dist, k, search));
  DenseMetric metric(sp.dist, k);
  return order_length(sp.dist, k, search_order(metric, search));
}

std::vector<int> robots_per_part(const std::vector<double>& lengths_m, int n_robots) {
  std::vector<int> m(lengths_m.size(), 1);
  for (int extra = 0; extra < n_robots - static_cast<int>(lengths_m.size()); ++extra) {
    std::size_t worst = 0;
    for (std::size_t p = 1; p < m.size(); ++p) {
      if (lengths_m[p] / m[p] > lengths_m[worst] / m[worst]) worst = p;
    }
    ++m[worst];
  }
  return m;
}

namespace {

// A vertex's remoteness: its summed distance to every vertex (up to kDenseTourMax vertices: n
// rows), or, on larger graphs, to kLandmarks vertices spread over the indices (kLandmarks rows).
std::vector<double> remoteness(const PatrolGraph& graph) {
  const int n = graph.num_vertices();
  std::vector<double> sums(n, 0.0);
  if (n <= kDenseTourMax) {
    for (int v = 0; v < n; ++v) {  // summed in index order, as Eigen sums a matrix row
      const std::shared_ptr<const DistanceRow> row = graph.row(v);
      const std::vector<double>& d = row->distance;
      double sum = d[0];
      for (int t = 1; t < n; ++t) sum += d[t];
      sums[v] = sum;
    }
  } else {
    for (int l = 0; l < kLandmarks; ++l) {
      const int landmark = static_cast<int>(static_cast<long long>(n) * l / kLandmarks);
      const std::shared_ptr<const DistanceRow> row = graph.row(landmark);
      for (int v = 0; v < n; ++v) sums[v] += row->distance[v];
    }
  }
  return sums;
}

// k seeds by farthest-point seeding from `first`.
std::vector<int> farthest_seeds(const PatrolGraph& graph, const ArcLists& arcs, int first, int k,
                                DijkstraWorkspace& work) {
  const int n = graph.num_vertices();
  std::vector<int> seeds{first};
  std::vector<double> nearest = graph.row(first)->distance;
  while (static_cast<int>(seeds.size()) < k) {
    const int far =
        static_cast<int>(std::max_element(nearest.begin(), nearest.end()) - nearest.begin());
    seeds.push_back(far);
    if (n <= kDenseTourMax) {
      const std::shared_ptr<const DistanceRow> from = graph.row(far);
      for (int v = 0; v < n; ++v) nearest[v] = std::min(nearest[v], from->distance[v]);
    } else {  // a search from `far` that leaves no vertex it does not bring nearer: O(its cell)
      work.run_until(
          arcs, {far}, 0.0, {}, [](int) { return false; },
          [&](int v) { return work.distance(v) < nearest[v]; });
      for (int v : work.settled_order()) nearest[v] = std::min(nearest[v], work.distance(v));
    }
  }
  return seeds;
}

// Parts of a partition with their owners and costs, improved by single-vertex moves.
struct Partition {
  std::vector<std::vector<int>> parts;  // sorted vertex indices
  std::vector<int> owner;               // part of each vertex
  std::vector<double> costs;            // cost of each part [m]
};

// Part p without u stays connected (a search inside p from another vertex); mark: all 0, n long.
bool connected_without(const PatrolGraph& graph, const Partition& part, int p, int u,
                       std::vector<char>& mark) {
  const std::vector<int>& vertices = part.parts[p];
  if (vertices.size() <= 1) return false;
  const int start = vertices[0] == u ? vertices[1] : vertices[0];
  std::vector<int> stack{start}, touched{start};
  mark[start] = 1;
  while (!stack.empty()) {
    const int x = stack.back();
    stack.pop_back();
    for (int w : graph.neighbours(x)) {
      if (w != u && part.owner[w] == p && !mark[w]) {
        mark[w] = 1;
        touched.push_back(w);
        stack.push_back(w);
      }
    }
  }
  for (int w : touched) mark[w] = 0;
  return touched.size() == vertices.size() - 1;
}

// One move of a boundary vertex out of the costliest part that lowers the largest cost most;
// false when no move lowers it.
template <class Cost>
bool move_one_vertex(const PatrolGraph& graph, Partition& part, Cost& cost,
                     std::vector<char>& mark) {
  std::vector<double>& costs = part.costs;
  const int p = static_cast<int>(std::max_element(costs.begin(), costs.end()) - costs.begin());
  double best_max = costs[p] - 1e-6;
  int best_u = -1, best_q = -1;
  double best_p = 0, best_qc = 0;
  std::vector<int> best_without, best_with;
  for (int u : part.parts[p]) {  // sorted
    std::vector<int> qs;
    for (int w : graph.neighbours(u)) {
      if (part.owner[w] != p) qs.push_back(part.owner[w]);
    }
    if (qs.empty() || !connected_without(graph, part, p, u, mark)) continue;
    std::sort(qs.begin(), qs.end());
    qs.erase(std::unique(qs.begin(), qs.end()), qs.end());
    std::vector<int> without;
    without.reserve(part.parts[p].size() - 1);
    for (int v : part.parts[p]) {
      if (v != u) without.push_back(v);
    }
    const double new_p = cost(without);
    if (new_p >= best_max) continue;  // the new max is at least this
    for (int q : qs) {
      std::vector<int> with = part.parts[q];
      with.insert(std::upper_bound(with.begin(), with.end(), u), u);
      const double new_q = cost(with);
      const double new_max = std::max(new_p, new_q);
      if (new_max < best_max) {
        best_max = new_max;
        best_u = u;
        best_q = q;
        best_p = new_p;
        best_qc = new_q;
        best_without = without;
        best_with = std::move(with);
      }
    }
  }
  if (best_u < 0) return false;
  part.parts[p] = std::move(best_without);
  part.parts[best_q] = std::move(best_with);
  part.owner[best_u] = best_q;
  costs[p] = best_p;
  costs[best_q] = best_qc;
  return true;
}

// Spanning-tree scoring (large parts): a part's minimum spanning tree with, for each vertex
// that is a leaf of it, the length of its one tree edge [m] (NaN: not a leaf).
struct LeafTree {
  double length = 0.0;         // [m] the tree's length
  std::vector<double> leaf_m;  // per vertex of the part, in its order
};

LeafTree leaf_tree(const PatrolGraph& graph, const std::vector<int>& part) {
  const std::vector<PartEdge> edges = part_edges(graph, part);
  std::vector<int> root(part.size()), degree(part.size(), 0);
  std::iota(root.begin(), root.end(), 0);
  auto find = [&](int v) {
    while (root[v] != v) v = root[v] = root[root[v]];
    return v;
  };
  LeafTree tree;
  tree.leaf_m.assign(part.size(), std::numeric_limits<double>::quiet_NaN());
  std::vector<double> last_m(part.size(), 0.0);
  for (const auto& [length, ends] : edges) {
    const int a = find(ends.first), b = find(ends.second);
    if (a == b) continue;
    root[a] = b;
    tree.length += length;
    for (int v : {ends.first, ends.second}) {
      ++degree[v];
      last_m[v] = length;
    }
  }
  for (std::size_t v = 0; v < part.size(); ++v) {
    if (degree[v] == 1) tree.leaf_m[v] = last_m[v];
  }
  return tree;
}

// The tree-scored move: only leaves of the costliest part's tree move (the part stays
// connected and its new length is exact: minus the leaf's edge); a receiving part is scored
// by its length plus the shortest edge to the leaf (an upper bound), and the chosen move is
// then scored exactly. O(part) per move instead of a tree per boundary vertex; false when no
// leaf move lowers the largest length.
template <class Cost>
bool move_one_leaf(const PatrolGraph& graph, Partition& part, Cost& cost) {
  std::vector<double>& costs = part.costs;
  const int p = static_cast<int>(std::max_element(costs.begin(), costs.end()) - costs.begin());
  const std::vector<int>& vertices = part.parts[p];
  if (vertices.size() <= 1) return false;
  const LeafTree tree = leaf_tree(graph, vertices);
  double best_max = costs[p] - 1e-6;
  int best_u = -1, best_q = -1;
  for (std::size_t a = 0; a < vertices.size(); ++a) {
    if (std::isnan(tree.leaf_m[a])) continue;
    const int u = vertices[a];
    const double new_p = tree.length - tree.leaf_m[a];
    if (new_p >= best_max) continue;
    std::map<int, double> reach;  // part -> shortest edge from u [m]
    for (int w : graph.neighbours(u)) {
      const int q = part.owner[w];
      if (q == p) continue;
      const double d = graph.edge_length(u, w);
      auto it = reach.find(q);
      if (it == reach.end() || d < it->second) reach[q] = d;
    }
    for (const auto& [q, d] : reach) {
      const double new_max = std::max(new_p, costs[q] + d);
      if (new_max < best_max) {
        best_max = new_max;
        best_u = u;
        best_q = q;
      }
    }
  }
  if (best_u < 0) return false;
  std::vector<int>& from = part.parts[p];
  from.erase(std::lower_bound(from.begin(), from.end(), best_u));
  std::vector<int>& to = part.parts[best_q];
  to.insert(std::upper_bound(to.begin(), to.end(), best_u), best_u);
  part.owner[best_u] = best_q;
  costs[p] = cost(from);
  costs[best_q] = cost(to);
  return true;
}

}  // namespace

std::vector<std::vector<int>> balanced_partition(const PatrolGraph& graph, int k, int max_moves,
                                                 const TourSearch& part_search,
                                                 const Progress& progress, bool tree_score) {
  const int n = graph.num_vertices();
  if (k < 1) throw std::invalid_argument("balanced_partition: k must be >= 1");
  k = std::min(k, n);
  // Rows of shortest paths on demand (graph.row): no all-pairs matrix.
  ArcLists arcs(n);
  for (int v = 0; v < n; ++v) {
    for (int w : graph.neighbours(v)) {
      if (w != v) arcs[v].push_back({w, graph.edge_length(v, w)});
    }
  }
  std::map<std::vector<int>, double> cost_cache;  // walk scores (small parts) only
  auto cost = [&](const std::vector<int>& part) {
    if (directed(graph)) {  // one-way arcs: a part must be strongly connected to be toured
      const double infeasible = infeasible_part_m(graph, part);
      if (infeasible > 0) return infeasible;
    }
    if (tree_score) return spanning_tree_length(graph, part);  // two per move: not kept
    auto it = cost_cache.find(part);
    if (it != cost_cache.end()) return it->second;
    const double c = closed_walk_length(graph, part, part_search);
    cost_cache.emplace(part, c);
    return c;
  };
  // first seeds: the most central vertex, the most remote one, and vertex 0 (large graphs: the
  // most remote one only; each seeding costs its moves)
  const std::vector<double> sums = remoteness(graph);
  const int remote = static_cast<int>(std::max_element(sums.begin(), sums.end()) - sums.begin());
  const int central = static_cast<int>(std::min_element(sums.begin(), sums.end()) - sums.begin());
  std::vector<int> firsts =
      n <= kDenseTourMax ? std::vector<int>{remote, central, 0} : std::vector<int>{remote};
  std::sort(firsts.begin(), firsts.end());
  firsts.erase(std::unique(firsts.begin(), firsts.end()), firsts.end());

  std::vector<std::vector<int>> best_parts;
  double best_cost = std::numeric_limits<double>::infinity();
  std::vector<char> mark(n, 0);
  DijkstraWorkspace work;
  for (std::size_t f = 0; f < firsts.size(); ++f) {
    const std::vector<int> seeds = farthest_seeds(graph, arcs, firsts[f], k, work);
    Partition part;
    // big graphs: parts grown to equal tree lengths (moves cannot even out nearest-seed ones)
    part.owner =
        n > kDenseTourMax ? grow_balanced_parts(arcs, seeds) : dijkstra(arcs, seeds, kEps).source;
    part.parts.resize(k);
    for (int v = 0; v < n; ++v) part.parts[part.owner[v]].push_back(v);
    part.costs.resize(k);
    for (int p = 0; p < k; ++p) part.costs[p] = cost(part.parts[p]);
    for (int move = 0; move < max_moves; ++move) {
      if (progress) {
        progress("partition", static_cast<int>(f) * max_moves + move,
                 static_cast<int>(firsts.size()) * max_moves);
      }
      // tree scores: a leaf move when one helps, else any vertex's (exact, slower)
      const bool moved = (tree_score && move_one_leaf(graph, part, cost)) ||
                         move_one_vertex(graph, part, cost, mark);
      if (!moved) break;
    }
    const double worst = *std::max_element(part.costs.begin(), part.costs.end());
    if (worst < best_cost - kEps) {
      best_cost = worst;
      best_parts = part.parts;
    }
  }
  if (best_cost >= kInfeasiblePartM) return {};  // one-way arcs: no part set could be toured
  return best_parts;
}

}  // namespace tpuaf
