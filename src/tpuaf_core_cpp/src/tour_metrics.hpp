// The plan search's metrics over vertex orders (internal to tpuaf_core_cpp, used by tours.cpp):
// DenseMetric (every pair in an n x n matrix) and SparseMetric (pairs searched on demand,
// memoised in PairMemo) give the same lengths [m]; constants and the kicks' Rng.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <queue>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "tpuaf_core/shortest_path.hpp"
#include "tpuaf_core/tours.hpp"

namespace tpuaf::tour {

constexpr double kEps = 1e-9;  // [m] an improvement must beat this
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kNeighbours = 16;  // candidate list length of the local search
constexpr int kKickWindow = 50;  // positions: double bridges stay local on long orders
constexpr int kLandmarks = 32;   // rows that rank vertices by remoteness on large graphs
// Pairs a sparse metric memoises (16 B each at half load: 64 MB), then it forgets them all.
constexpr std::size_t kMemoEntries = 1u << 21;

// Or-opt: the best place to reinsert a segment, after vertex u, forward or reversed; a change of
// length below -kEps to be kept (both local searches).
struct Insertion {
  double gain = -kEps;  // [m] the change of length of the best place (negative: shorter)
  int after = -1;       // u, -1: none better
  bool reversed = false;
  void offer(int u, double forward, double backward) {
    if (forward < gain) {
      gain = forward;
      after = u;
      reversed = false;
    }
    if (backward < gain) {
      gain = backward;
      after = u;
      reversed = true;
    }
  }
};

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

// Outgoing arcs of the subgraph induced by the sorted `vertices`, in local indices (each
// vertex's arcs in the graph's neighbour order).
inline ArcLists subset_arcs(const PatrolGraph& graph, const std::vector<int>& vertices) {
  const int k = static_cast<int>(vertices.size());
  std::vector<int> local(graph.num_vertices(), -1);
  for (int a = 0; a < k; ++a) {
    graph.check_vertex(vertices[a]);
    local[vertices[a]] = a;
  }
  ArcLists arcs(k);
  for (int a = 0; a < k; ++a) {
    const int v = vertices[a];
    for (int w : graph.neighbours(v)) {
      if (w != v && local[w] >= 0) arcs[a].push_back({local[w], graph.edge_length(v, w)});
    }
  }
  return arcs;
}

inline std::vector<int> sorted_unique(std::vector<int> vertices) {
  std::sort(vertices.begin(), vertices.end());
  vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
  return vertices;
}

[[noreturn]] inline void throw_not_connected(const PatrolGraph& graph, int k, int from) {
  throw std::invalid_argument("closed_walk: the " + std::to_string(k) +
                              " vertices do not induce a connected subgraph (from " +
                              graph.vertex_name(from) + ")");
}

// The metric of the orders: lengths [m] between indices 0..n-1. Two kinds with the same
// values: DenseMetric, every pair in an n x n matrix; SubsetPaths' searches on demand
// (SparseMetric) for large vertex subsets.

class DenseMetric {
 public:
  static constexpr bool kOnDemand = false;  // a tour's length summed again (O(n)), moves rebuild
  DenseMetric(const std::vector<double>& dist, int n) : d_(dist.data()), n_(n) {}
  int size() const { return n_; }
  double operator()(int a, int b) const { return d_[static_cast<std::size_t>(a) * n_ + b]; }
  double at_most(int a, int b, double /*limit*/) const { return (*this)(a, b); }
  // The k nearest others of a, by (length, index).
  std::vector<int> nearest(int a, int k) const {
    std::vector<int> idx(n_);
    std::iota(idx.begin(), idx.end(), 0);
    idx.erase(idx.begin() + a);
    std::partial_sort(idx.begin(), idx.begin() + k, idx.end(), [&](int x, int y) {
      const double dx = (*this)(a, x), dy = (*this)(a, y);
      return dx < dy || (dx == dy && x < y);
    });
    idx.resize(k);
    return idx;
  }
  // The nearest index not `seen` from `from` (the lowest among equals).
  int nearest_unseen(int from, const std::vector<char>& seen) const {
    const double* row = d_ + static_cast<std::size_t>(from) * n_;
    int best = -1;
    for (int v = 0; v < n_; ++v) {
      if (!seen[v] && (best < 0 || row[v] < row[best])) best = v;
    }
    return best;
  }

 private:
  const double* d_;
  int n_;
};

// Lengths [m] of ordered pairs (a, b) of 0..n-1: open addressing, linear probing; at most
// kMemoEntries.
class PairMemo {
 public:
  explicit PairMemo(int n) : n_(static_cast<std::uint64_t>(n)) { resize(1u << 12); }
  const double* find(int a, int b) const {
    const std::uint64_t k = key(a, b);
    for (std::size_t i = slot(k);; i = (i + 1) & mask_) {
      if (keys_[i] == k) return &values_[i];
      if (keys_[i] == kEmpty) return nullptr;
    }
  }
  double put(int a, int b, double value) {
    if (size_ >= kMemoEntries) {  // full: forget (a value asked again is searched again)
      std::fill(keys_.begin(), keys_.end(), kEmpty);
      size_ = 0;
    }
    if (2 * (size_ + 1) > keys_.size()) resize(2 * keys_.size());
    const std::uint64_t k = key(a, b);
    std::size_t i = slot(k);
    while (keys_[i] != kEmpty && keys_[i] != k) i = (i + 1) & mask_;
    if (keys_[i] == kEmpty) ++size_;
    keys_[i] = k;
    values_[i] = value;
    return value;
  }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  std::uint64_t key(int a, int b) const {
    return static_cast<std::uint64_t>(a) * n_ + static_cast<std::uint64_t>(b);
  }
  std::size_t slot(std::uint64_t k) const {
    return static_cast<std::size_t>((k * 0x9E3779B97F4A7C15ULL) >> shift_);
  }
  void resize(std::size_t capacity) {  // a power of two
    std::vector<std::uint64_t> keys(capacity, kEmpty);
    std::vector<double> values(capacity);
    mask_ = capacity - 1;
    shift_ = 64;
    for (std::size_t c = capacity; c > 1; c >>= 1) --shift_;
    for (std::size_t i = 0; i < keys_.size(); ++i) {
      if (keys_[i] == kEmpty) continue;
      std::size_t j = slot(keys_[i]);
      while (keys[j] != kEmpty) j = (j + 1) & mask_;
      keys[j] = keys_[i];
      values[j] = values_[i];
    }
    keys_.swap(keys);
    values_.swap(values);
  }
  std::uint64_t n_;
  std::vector<std::uint64_t> keys_;
  std::vector<double> values_;
  std::size_t size_ = 0, mask_ = 0;
  int shift_ = 64;
};

// Shortest paths inside a large vertex subset, searched on demand (DijkstraWorkspace, relabelled
// when shorter by more than kEps, as the dense rows). Each vertex's kNeighbours nearest (a
// search settling 17 vertices: the dense candidate lists) and their lengths are kept; another
// pair (a, b) is taken in either direction when known, else searched from a by A* towards b,
// stopped once it cannot beat the caller's limit, and every label that search settled is
// memoised (the local search asks pairs near each other). Lengths are shortest-path lengths
// (a sum over an equally short path may differ from the dense entry in the last bits).
// Memory O(edges + kMemoEntries).
class SparseMetric {
 public:
  // a tour's length kept up to date move by move, Or-opt moves made in place
  static constexpr bool kOnDemand = true;
  SparseMetric(const PatrolGraph& graph, const std::vector<int>& vertices)
      : arcs_(subset_arcs(graph, vertices)),
        n_(static_cast<int>(vertices.size())),
        k_(std::min(n_ - 1, kNeighbours)),
        memo_(n_) {
    xy_.resize(static_cast<std::size_t>(n_));
    for (int a = 0; a < n_; ++a) {
      xy_[a] = {graph.positions()(vertices[a], 0), graph.positions()(vertices[a], 1)};
    }
    for (int a = 0; a < n_; ++a) {
      for (const Arc& arc : arcs_[a]) {
        const double straight = straight_m(a, arc.to);
        if (straight > 0) stretch_ = std::min(stretch_, arc.weight / straight);
      }
    }
    work_.run(arcs_, {0}, -kEps);  // connected?
    if (static_cast<int>(work_.settled_order().size()) < n_) {
      throw_not_connected(graph, n_, vertices[0]);
    }
    near_.resize(static_cast<std::size_t>(n_) * k_);
    near_length_.resize(near_.size());
    for (int a = 0; a < n_; ++a) {
      work_.run_until(arcs_, {a}, -kEps, {},
                      [&](int) { return static_cast<int>(work_.settled_order().size()) > k_; });
      for (int t = 0; t < k_; ++t) {
        const int x = work_.settled_order()[static_cast<std::size_t>(t) + 1];
        near_[static_cast<std::size_t>(a) * k_ + t] = x;
        near_length_[static_cast<std::size_t>(a) * k_ + t] = work_.distance(x);
      }
    }
  }
  int size() const { return n_; }
  double operator()(int a, int b) { return at_most(a, b, kInf); }
  // The length a -> b, or +inf when it is not below `limit` [m] (the search stops there).
  double at_most(int a, int b, double limit) {
    const int* near = near_.data() + static_cast<std::size_t>(a) * k_;
    for (int t = 0; t < k_; ++t) {
      if (near[t] == b) return near_length_[static_cast<std::size_t>(a) * k_ + t];
    }
    if (a == b) return 0.0;
    if (const double* hit = memo_.find(a, b)) return *hit;
    // the other direction when known: the same path's length, summed the other way round
    const int* from_b = near_.data() + static_cast<std::size_t>(b) * k_;
    for (int t = 0; t < k_; ++t) {
      if (from_b[t] == a) return near_length_[static_cast<std::size_t>(b) * k_ + t];
    }
    if (const double* hit = memo_.find(b, a)) return *hit;
    if (stretch_ * straight_m(a, b) >= limit) return kInf;  // no path that short
    // A* towards b (the straight line times stretch_ is a consistent potential): stopped at b,
    // or once nothing left can reach b below `limit`
    const auto to_b = [&](int v) { return stretch_ * straight_m(v, b); };
    work_.run_until(
        arcs_, {a}, -kEps, {},
        [&](int v) { return v == b || work_.distance(v) + to_b(v) >= limit; }, nullptr, to_b);
    for (int v : work_.settled_order()) memo_.put(a, v, work_.distance(v));  // final labels
    return work_.settled(b) ? work_.distance(b) : kInf;
  }
  // The k nearest others of a, by (length, index) (k <= kNeighbours).
  std::vector<int> nearest(int a, int k) const {
    const auto first = near_.begin() + static_cast<std::ptrdiff_t>(a) * k_;
    return std::vector<int>(first, first + k);
  }
  int nearest_unseen(int from, const std::vector<char>& seen) {
    work_.run_until(arcs_, {from}, -kEps, {}, [&](int v) { return !seen[v]; });
    const int v = work_.settled_order().back();
    if (seen[v]) return -1;
    memo_.put(from, v, work_.distance(v));
    return v;
  }
  // The vertices of a shortest path from a to b after a, b included (local indices).
  void append_path(int a, int b, std::vector<int>* out) {
    work_.run(arcs_, {a}, -kEps, {}, b);
    const std::size_t first = out->size();
    for (int v = b; v != a; v = work_.parent(v)) out->push_back(v);
    std::reverse(out->begin() + static_cast<std::ptrdiff_t>(first), out->end());
  }

 private:
  ArcLists arcs_;
  int n_, k_;
  std::vector<int> near_;            // n x k_: the nearest others of each vertex
  std::vector<double> near_length_;  // their lengths [m]
  double straight_m(int a, int b) const {
    return std::hypot(xy_[a].first - xy_[b].first, xy_[a].second - xy_[b].second);
  }
  PairMemo memo_;
  DijkstraWorkspace work_;
  std::vector<std::pair<double, double>> xy_;  // [m] positions
  double stretch_ = 1.0;  // the least length / straight line of an edge: paths are no shorter
};

}  // namespace tpuaf::tour
