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

#include "tpuaf_core/shortest_path.hpp"

namespace tpuaf {
namespace {

constexpr double kEps = 1e-9;    // [m] an improvement must beat this
constexpr int kNeighbours = 16;  // candidate list length of the local search
constexpr int kKickWindow = 50;  // positions: double bridges stay local on long orders

// splitmix64: a fixed, portable sequence for the kicks.
struct Rng {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }
  int below(int bound) { return static_cast<int>(next() % static_cast<std::uint64_t>(bound)); }
};

// 2-opt and Or-opt (segments of 1-3, either orientation) over neighbour lists with a queue of
// vertices to look at ("don't-look bits"); first improvement.
class LocalSearch {
 public:
  LocalSearch(const std::vector<double>& dist, int n) : d_(dist.data()), n_(n) {
    const int k = std::min(n - 1, kNeighbours);
    k_ = k;
    nbr_.resize(static_cast<std::size_t>(n) * k);
    std::vector<int> idx;
    for (int a = 0; a < n; ++a) {
      idx.resize(n);
      std::iota(idx.begin(), idx.end(), 0);
      idx.erase(idx.begin() + a);
      std::partial_sort(idx.begin(), idx.begin() + k, idx.end(), [&](int x, int y) {
        const double dx = D(a, x), dy = D(a, y);
        return dx < dy || (dx == dy && x < y);
      });
      std::copy(idx.begin(), idx.begin() + k, nbr_.begin() + static_cast<std::size_t>(a) * k);
    }
    queued_.assign(n, 0);
    pos_.assign(n, 0);
  }

  void set_order(const std::vector<int>& order) {
    order_ = order;
    for (int i = 0; i < n_; ++i) pos_[order_[i]] = i;
  }
  const std::vector<int>& order() const { return order_; }

  void push(int v) {
    if (!queued_[v]) {
      queued_[v] = 1;
      queue_.push_back(v);
    }
  }
  void push_all() {
    for (int v : order_) push(v);
  }

  // Improves until no move from a queued vertex improves.
  void run() {
    while (!queue_.empty()) {
      const int a = queue_.front();
      queue_.pop_front();
      queued_[a] = 0;
      if (two_opt(a) || or_opt(a)) push(a);
    }
  }

 private:
  double D(int a, int b) const { return d_[static_cast<std::size_t>(a) * n_ + b]; }
  int at(int i) const { return order_[((i % n_) + n_) % n_]; }
  int succ(int v) const { return at(pos_[v] + 1); }
  int pred(int v) const { return at(pos_[v] - 1); }
  const int* nbrs(int a) const { return nbr_.data() + static_cast<std::size_t>(a) * k_; }

  // Reverses the cyclic stretch of positions i..j (forward from i), or its complement when
  // shorter (the same cyclic tour, travelled the other way).
  void reverse(int i, int j) {
    int len = ((j - i) % n_ + n_) % n_ + 1;
    if (2 * len > n_) {
      const int ni = (j + 1) % n_, nj = (i - 1 + n_) % n_;
      i = ni;
      j = nj;
      len = n_ - len;
    }
    for (int s = 0; s < len / 2; ++s) {
      std::swap(order_[i], order_[j]);
      pos_[order_[i]] = i;
      pos_[order_[j]] = j;
      i = (i + 1) % n_;
      j = (j - 1 + n_) % n_;
    }
  }

  bool two_opt(int a) {
    for (int dir = 0; dir < 2; ++dir) {
      const int b = dir == 0 ? succ(a) : pred(a);
      const double ab = D(a, b);
      const int* cs = nbrs(a);
      for (int t = 0; t < k_; ++t) {
        const int c = cs[t];
        const double ac = D(a, c);
        if (ac >= ab - kEps) break;
        const int e = dir == 0 ? succ(c) : pred(c);
        if (c == b || e == a) continue;
        const double delta = ac + D(b, e) - ab - D(c, e);
        if (delta < -kEps) {
          if (dir == 0) {
            reverse(pos_[b], pos_[c]);  // a b .. c e -> a c .. b e
          } else {
            reverse(pos_[a], pos_[e]);  // b a .. e c -> b e .. a c
          }
          push(b);
          push(c);
          push(e);
          return true;
        }
      }
    }
    return false;
  }

  bool or_opt(int a) {
    for (int len = 1; len <= 3 && len + 3 <= n_; ++len) {
      for (int side = 0; side < 2; ++side) {
        // segment of positions first..first+len-1 that starts or ends at a
        const int first = side == 0 ? pos_[a] : pos_[a] - len + 1;
        const int s1 = at(first), s2 = at(first + len - 1);
        const int p = at(first - 1), nx = at(first + len);
        const double removed = D(p, s1) + D(s2, nx) - D(p, nx);
        if (removed <= kEps) continue;
        auto in_segment = [&](int v) {
          const int off = ((pos_[v] - first) % n_ + n_) % n_;
          return off < len;
        };
        double best = -kEps;
        int best_u = -1;
        bool best_reversed = false;
        for (int end = 0; end < 2; ++end) {
          const int* cs = nbrs(end == 0 ? s1 : s2);
          for (int t = 0; t < k_; ++t) {
            const int x = cs[t];
            if (D(end == 0 ? s1 : s2, x) >= removed) break;
            if (in_segment(x)) continue;
            for (int which = 0; which < 2; ++which) {
              const int u = which == 0 ? x : pred(x);
              const int w = succ(u);
              if (in_segment(u) || in_segment(w)) continue;
              const double base = D(u, w);
              const double fwd = D(u, s1) + D(s2, w) - base - removed;
              const double rev = D(u, s2) + D(s1, w) - base - removed;
              if (fwd < best) {
                best = fwd;
                best_u = u;
                best_reversed = false;
              }
              if (rev < best) {
                best = rev;
                best_u = u;
                best_reversed = true;
              }
            }
          }
        }
        if (best_u >= 0) {
          const int best_w = succ(best_u);
          move_segment(first, len, best_u, best_reversed);
          for (int v : {p, nx, s1, s2, best_u, best_w}) push(v);
          return true;
        }
      }
    }
    return false;
  }

  // The segment of `len` positions from `first` moves between u and its successor.
  void move_segment(int first, int len, int u, bool reversed) {
    std::vector<int> seg(len);
    for (int s = 0; s < len; ++s) seg[s] = at(first + s);
    if (reversed) std::reverse(seg.begin(), seg.end());
    std::vector<int> out;
    out.reserve(n_);
    for (int s = 0; s < n_ - len; ++s) {
      const int v = at(first + len + s);
      out.push_back(v);
      if (v == u) out.insert(out.end(), seg.begin(), seg.end());
    }
    set_order(out);
  }

  const double* d_;
  int n_, k_ = 0;
  std::vector<int> nbr_, order_, pos_;
  std::vector<char> queued_;
  std::deque<int> queue_;
};

std::vector<int> nearest_neighbour(const std::vector<double>& dist, int n, int start) {
  std::vector<char> seen(n, 0);
  std::vector<int> order{start};
  seen[start] = 1;
  for (int step = 1; step < n; ++step) {
    const double* row = dist.data() + static_cast<std::size_t>(order.back()) * n;
    int best = -1;
    for (int v = 0; v < n; ++v) {
      if (!seen[v] && (best < 0 || row[v] < row[best])) best = v;
    }
    order.push_back(best);
    seen[best] = 1;
  }
  return order;
}

// Double bridge A B C D -> A C B D; cuts within kKickWindow positions of a random one.
std::vector<int> double_bridge(const std::vector<int>& order, Rng& rng) {
  const int n = static_cast<int>(order.size());
  const int window = std::min(n, kKickWindow);
  const int origin = window < n ? rng.below(n) : 0;
  int cut[3];
  do {
    for (int& c : cut) c = 1 + rng.below(window - 1);
    std::sort(cut, cut + 3);
  } while (cut[0] == cut[1] || cut[1] == cut[2]);
  std::vector<int> rot(n);
  for (int i = 0; i < n; ++i) rot[i] = order[(origin + i) % n];
  std::vector<int> out(rot.begin(), rot.begin() + cut[0]);
  out.insert(out.end(), rot.begin() + cut[1], rot.begin() + cut[2]);
  out.insert(out.end(), rot.begin() + cut[0], rot.begin() + cut[1]);
  out.insert(out.end(), rot.begin() + cut[2], rot.end());
  return out;
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
  out.vertices = input;
  std::sort(out.vertices.begin(), out.vertices.end());
  out.vertices.erase(std::unique(out.vertices.begin(), out.vertices.end()), out.vertices.end());
  const int k = static_cast<int>(out.vertices.size());
  const int n = graph.num_vertices();
  std::vector<int> local(n, -1);
  for (int a = 0; a < k; ++a) {
    graph.check_vertex(out.vertices[a]);
    local[out.vertices[a]] = a;
  }
  std::vector<std::vector<std::pair<int, double>>> adj(k);
  for (int a = 0; a < k; ++a) {
    const int v = out.vertices[a];
    for (int w : graph.neighbours(v)) {
      if (w != v && local[w] >= 0) adj[a].push_back({local[w], graph.edge_length(v, w)});
    }
  }
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
      for (const auto& [w, c] : adj[u]) {
        if (du + c < row[w] - kEps) {
          row[w] = du + c;
          if (par) par[w] = u;
          heap.push({row[w], w});
        }
      }
    }
    if (settled < k) {
      throw std::invalid_argument("closed_walk: the " + std::to_string(k) +
                                  " vertices do not induce a connected subgraph (from " +
                                  graph.vertex_name(out.vertices[s]) + ")");
    }
  }
  return out;
}

// Length [m] of a minimum spanning tree of the subgraph induced by the sorted `part` (Kruskal).
double spanning_tree_length(const PatrolGraph& graph, const std::vector<int>& part) {
  std::vector<std::pair<double, std::pair<int, int>>> edges;
  for (int a = 0; a < static_cast<int>(part.size()); ++a) {
    for (int w : graph.neighbours(part[a])) {
      if (w <= part[a] || !std::binary_search(part.begin(), part.end(), w)) continue;
      const int b = static_cast<int>(std::lower_bound(part.begin(), part.end(), w) - part.begin());
      edges.push_back({graph.edge_length(part[a], w), {a, b}});
    }
  }
  std::sort(edges.begin(), edges.end());
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
  std::vector<int> identity(n);
  std::iota(identity.begin(), identity.end(), 0);
  if (n <= 3) return identity;
  LocalSearch ls(dist, n);
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
    ls.set_order(nearest_neighbour(dist, n, s));
    ls.push_all();
    ls.run();
    const double len = order_length(dist, n, ls.order());
    if (len < best_len - kEps) {
      best = ls.order();
      best_len = len;
    }
  }
  if (n >= 8) {
    Rng rng{search.seed};
    for (int kick = 0; kick < search.kicks; ++kick) {
      const std::vector<int> kicked = double_bridge(best, rng);
      ls.set_order(kicked);
      // the (at most 8) vertices whose edges the bridge changed
      std::vector<int> where(n);
      for (int i = 0; i < n; ++i) where[best[i]] = i;
      for (int i = 0; i < n; ++i) {
        const int v = kicked[i], next = kicked[(i + 1) % n];
        if (best[(where[v] + 1) % n] != next) {
          ls.push(v);
          ls.push(next);
        }
      }
      ls.run();
      const double len = order_length(dist, n, ls.order());
      if (len < best_len - kEps) {
        best = ls.order();
        best_len = len;
      }
    }
  }
  return best;
}

ClosedWalk closed_walk(const PatrolGraph& graph, const std::vector<int>& vertices,
                       const TourSearch& search) {
  ClosedWalk out;
  if (vertices.empty()) return out;
  const SubsetPaths sp = subset_paths(graph, vertices, true);
  const int k = static_cast<int>(sp.vertices.size());
  if (k == 1) {
    out.walk = sp.vertices;
    return out;
  }
  const std::vector<int> order = tsp_order(sp.dist, k, search);
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
  const SubsetPaths sp = subset_paths(graph, vertices, false);
  const int k = static_cast<int>(sp.vertices.size());
  if (k <= 1) return 0.0;
  return order_length(sp.dist, k, tsp_order(sp.dist, k, search));
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
  std::map<std::vector<int>, double> cost_cache;
  auto cost = [&](const std::vector<int>& part) {
    auto it = cost_cache.find(part);
    if (it != cost_cache.end()) return it->second;
    const double c = tree_score ? spanning_tree_length(graph, part)
                                : closed_walk_length(graph, part, part_search);
    cost_cache.emplace(part, c);
    return c;
  };
  // first seeds: the most central vertex, the most remote one, and vertex 0
  std::vector<double> sums(n, 0.0);
  for (int v = 0; v < n; ++v) {  // summed in index order, as Eigen sums a matrix row
    const std::shared_ptr<const DistanceRow> row = graph.row(v);
    const std::vector<double>& d = row->distance;
    double sum = d[0];
    for (int t = 1; t < n; ++t) sum += d[t];
    sums[v] = sum;
  }
  const int remote = static_cast<int>(std::max_element(sums.begin(), sums.end()) - sums.begin());
  const int central = static_cast<int>(std::min_element(sums.begin(), sums.end()) - sums.begin());
  std::vector<int> firsts{remote, central, 0};
  std::sort(firsts.begin(), firsts.end());
  firsts.erase(std::unique(firsts.begin(), firsts.end()), firsts.end());

  std::vector<std::vector<int>> best_parts;
  double best_cost = std::numeric_limits<double>::infinity();
  std::vector<char> mark(n, 0);
  for (std::size_t f = 0; f < firsts.size(); ++f) {
    std::vector<int> seeds{firsts[f]};
    std::vector<double> nearest(n);
    nearest = graph.row(firsts[f])->distance;
    while (static_cast<int>(seeds.size()) < k) {  // farthest-point seeding
      const int far =
          static_cast<int>(std::max_element(nearest.begin(), nearest.end()) - nearest.begin());
      seeds.push_back(far);
      const std::shared_ptr<const DistanceRow> from = graph.row(far);
      for (int v = 0; v < n; ++v) nearest[v] = std::min(nearest[v], from->distance[v]);
    }
    std::vector<int> owner = dijkstra(arcs, seeds, kEps).source;
    std::vector<std::vector<int>> parts(k);
    for (int v = 0; v < n; ++v) parts[owner[v]].push_back(v);
    std::vector<double> costs(k);
    for (int p = 0; p < k; ++p) costs[p] = cost(parts[p]);

    // part p without u stays connected (BFS inside p from another vertex)
    auto connected_without = [&](int p, int u) {
      const std::vector<int>& part = parts[p];
      if (part.size() <= 1) return false;
      const int start = part[0] == u ? part[1] : part[0];
      std::vector<int> stack{start};
      mark[start] = 1;
      std::size_t seen = 1;
      std::vector<int> touched{start};
      while (!stack.empty()) {
        const int x = stack.back();
        stack.pop_back();
        for (int w : graph.neighbours(x)) {
          if (w != u && owner[w] == p && !mark[w]) {
            mark[w] = 1;
            touched.push_back(w);
            stack.push_back(w);
            ++seen;
          }
        }
      }
      for (int w : touched) mark[w] = 0;
      return seen == part.size() - 1;
    };

    for (int move = 0; move < max_moves; ++move) {
      if (progress) {
        progress("partition", static_cast<int>(f) * max_moves + move,
                 static_cast<int>(firsts.size()) * max_moves);
      }
      const int p = static_cast<int>(std::max_element(costs.begin(), costs.end()) - costs.begin());
      double best_max = costs[p] - 1e-6;
      int best_u = -1, best_q = -1;
      double best_p = 0, best_qc = 0;
      std::vector<int> best_without, best_with;
      for (int u : parts[p]) {  // sorted
        std::vector<int> qs;
        for (int w : graph.neighbours(u)) {
          if (owner[w] != p) qs.push_back(owner[w]);
        }
        if (qs.empty() || !connected_without(p, u)) continue;
        std::sort(qs.begin(), qs.end());
        qs.erase(std::unique(qs.begin(), qs.end()), qs.end());
        std::vector<int> without;
        without.reserve(parts[p].size() - 1);
        for (int v : parts[p]) {
          if (v != u) without.push_back(v);
        }
        const double new_p = cost(without);
        if (new_p >= best_max) continue;  // the new max is at least this
        for (int q : qs) {
          std::vector<int> with = parts[q];
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
      if (best_u < 0) break;
      parts[p] = std::move(best_without);
      parts[best_q] = std::move(best_with);
      owner[best_u] = best_q;
      costs[p] = best_p;
      costs[best_q] = best_qc;
    }
    const double worst = *std::max_element(costs.begin(), costs.end());
    if (worst < best_cost - kEps) {
      best_cost = worst;
      best_parts = parts;
    }
  }
  return best_parts;
}

}  // namespace tpuaf
