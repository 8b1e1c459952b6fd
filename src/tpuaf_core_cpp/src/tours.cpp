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

constexpr double kEps = 1e-9;  // [m] an improvement must beat this
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kNeighbours = 16;  // candidate list length of the local search
constexpr int kKickWindow = 50;  // positions: double bridges stay local on long orders
constexpr int kLandmarks = 32;   // rows that rank vertices by remoteness on large graphs
// Pairs a sparse metric memoises (16 B each at half load: 64 MB), then it forgets them all.
constexpr std::size_t kMemoEntries = 1u << 21;

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
ArcLists subset_arcs(const PatrolGraph& graph, const std::vector<int>& vertices) {
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

std::vector<int> sorted_unique(std::vector<int> vertices) {
  std::sort(vertices.begin(), vertices.end());
  vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
  return vertices;
}

[[noreturn]] void throw_not_connected(const PatrolGraph& graph, int k, int from) {
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

// 2-opt and Or-opt (segments of 1-3, either orientation) over neighbour lists with a queue of
// vertices to look at ("don't-look bits"); first improvement. `gain()`: the summed length
// change [m] of the moves made since `set_order`.
template <class Metric>
class LocalSearch {
 public:
  explicit LocalSearch(Metric& metric) : m_(&metric), n_(metric.size()) {
    const int k = std::min(n_ - 1, kNeighbours);
    k_ = k;
    nbr_.resize(static_cast<std::size_t>(n_) * k);
    for (int a = 0; a < n_; ++a) {
      const std::vector<int> near = metric.nearest(a, k);
      std::copy(near.begin(), near.end(), nbr_.begin() + static_cast<std::size_t>(a) * k);
    }
    queued_.assign(n_, 0);
    pos_.assign(n_, 0);
  }

  void set_order(const std::vector<int>& order) {
    order_ = order;
    for (int i = 0; i < n_; ++i) pos_[order_[i]] = i;
    gain_ = 0.0;
  }
  const std::vector<int>& order() const { return order_; }
  double gain() const { return gain_; }

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
  double D(int a, int b) const { return (*m_)(a, b); }
  // The length a -> b when below `limit` [m], else the length or +inf (no move with it is kept).
  double D(int a, int b, double limit) const { return m_->at_most(a, b, limit); }
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
        const double ce = D(c, e);
        const double delta = ac + D(b, e, ab + ce - ac + kEps) - ab - ce;
        if (delta < -kEps) {
          if (dir == 0) {
            reverse(pos_[b], pos_[c]);  // a b .. c e -> a c .. b e
          } else {
            reverse(pos_[a], pos_[e]);  // b a .. e c -> b e .. a c
          }
          gain_ += delta;
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
        const double ps1 = D(p, s1), s2nx = D(s2, nx);
        const double removed = ps1 + s2nx - D(p, nx, ps1 + s2nx + kEps);
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
              const double limit = best + base + removed + kEps;  // of each added length
              const double fwd = D(u, s1, limit) + D(s2, w, limit) - base - removed;
              const double rev = D(u, s2, limit) + D(s1, w, limit) - base - removed;
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
          gain_ += best;
          for (int v : {p, nx, s1, s2, best_u, best_w}) push(v);
          return true;
        }
      }
    }
    return false;
  }

  // The segment of `len` positions from `first` moves between u and its successor: the order
  // rebuilt from the segment's successor on (dense: O(n)), or, for large orders, in place,
  // shifting the shorter stretch between the segment and its new place (O(that stretch)).
  void move_segment(int first, int len, int u, bool reversed) {
    int seg[3];
    for (int s = 0; s < len; ++s) seg[s] = at(first + s);
    if (reversed) std::reverse(seg, seg + len);
    if constexpr (Metric::kOnDemand) {
      const int wrap_first = ((first % n_) + n_) % n_;
      const int after = (pos_[u] - (wrap_first + len - 1) + n_) % n_;  // entries after it to u
      const int before = (wrap_first - pos_[succ(u)] + n_) % n_;       // from u's successor
      if (after <= before) {  // the `after` entries move back by len, the segment ends at u
        for (int s = 0; s < after; ++s) place(wrap_first + s, order_[(wrap_first + len + s) % n_]);
        for (int s = 0; s < len; ++s) place(wrap_first + after + s, seg[s]);
      } else {  // the `before` entries move on by len, the segment starts at u's successor
        for (int s = before - 1; s >= 0; --s) {
          place(wrap_first - before + s + len, order_[(wrap_first - before + s + n_) % n_]);
        }
        for (int s = 0; s < len; ++s) place(wrap_first - before + s, seg[s]);
      }
      return;
    }
    std::vector<int> out;
    out.reserve(n_);
    for (int s = 0; s < n_ - len; ++s) {
      const int v = at(first + len + s);
      out.push_back(v);
      if (v == u) out.insert(out.end(), seg, seg + len);
    }
    const double gain = gain_;
    set_order(out);
    gain_ = gain;
  }

  void place(int i, int v) {  // v at position i (mod n)
    i = ((i % n_) + n_) % n_;
    order_[i] = v;
    pos_[v] = i;
  }

  Metric* m_;
  int n_, k_ = 0;
  double gain_ = 0.0;
  std::vector<int> nbr_, order_, pos_;
  std::vector<char> queued_;
  std::deque<int> queue_;
};

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
  DenseMetric metric(dist, n);
  return search_order(metric, search);
}

ClosedWalk closed_walk(const PatrolGraph& graph, const std::vector<int>& vertices,
                       const TourSearch& search) {
  ClosedWalk out;
  if (vertices.empty()) return out;
  const std::vector<int> sorted = sorted_unique(vertices);
  const int k = static_cast<int>(sorted.size());
  if (k == 1) {
    graph.check_vertex(sorted[0]);
    out.walk = sorted;
    return out;
  }
  if (sparse_tour(k, search)) {
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
  const std::vector<int> order = search_order(metric, search);
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
  if (k <= 1) return 0.0;
  if (sparse_tour(k, search)) {
    SparseMetric metric(graph, sorted);
    return cyclic_length(metric, search_order(metric, search));
  }
  const SubsetPaths sp = subset_paths(graph, sorted, false);
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
  // first seeds: the most central vertex, the most remote one, and vertex 0; a vertex's
  // remoteness is its summed distance to every vertex (up to kDenseTourMax vertices: n rows),
  // or, on larger graphs, to kLandmarks vertices spread over the indices (kLandmarks rows)
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
  const int remote = static_cast<int>(std::max_element(sums.begin(), sums.end()) - sums.begin());
  const int central = static_cast<int>(std::min_element(sums.begin(), sums.end()) - sums.begin());
  // (large graphs: the most remote one only; each seeding costs its moves)
  std::vector<int> firsts =
      n <= kDenseTourMax ? std::vector<int>{remote, central, 0} : std::vector<int>{remote};
  std::sort(firsts.begin(), firsts.end());
  firsts.erase(std::unique(firsts.begin(), firsts.end()), firsts.end());

  std::vector<std::vector<int>> best_parts;
  double best_cost = std::numeric_limits<double>::infinity();
  std::vector<char> mark(n, 0);
  DijkstraWorkspace work;
  for (std::size_t f = 0; f < firsts.size(); ++f) {
    std::vector<int> seeds{firsts[f]};
    std::vector<double> nearest(n);
    nearest = graph.row(firsts[f])->distance;
    while (static_cast<int>(seeds.size()) < k) {  // farthest-point seeding
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
