// The plan search on graphs with one-way arcs: cyclic orders on an asymmetric metric, and the
// partition search's test that a part can be toured (tour_directed.hpp).
#include <algorithm>
#include <numeric>

#include "tour_directed.hpp"
#include "tour_metrics.hpp"
#include "vertex_queue.hpp"

namespace tpuaf::tour {
namespace {

// 2-opt-style segment reversal and Or-opt on an asymmetric metric, first improvement per
// vertex over candidate lists (the k nearest successors and predecessors), with a queue of
// vertices to look at. Every move is priced in the order's direction: the arcs it removes and
// adds, and a reversed segment's own arcs driven backwards (prefix sums over the order, both
// ways: O(1) per move priced, O(n) per move made).
class DirectedSearch {
 public:
  DirectedSearch(const std::vector<double>& dist, int n) : d_(dist.data()), n_(n) {
    k_ = std::min(n - 1, kNeighbours);
    out_.resize(static_cast<std::size_t>(n) * k_);
    in_.resize(static_cast<std::size_t>(n) * k_);
    std::vector<int> idx(n);
    for (int a = 0; a < n; ++a) {
      for (int way = 0; way < 2; ++way) {  // 0: a -> x, 1: x -> a
        const auto len = [&](int x) { return way == 0 ? D(a, x) : D(x, a); };
        std::iota(idx.begin(), idx.end(), 0);
        idx.erase(idx.begin() + a);
        std::partial_sort(idx.begin(), idx.begin() + k_, idx.end(), [&](int x, int y) {
          return len(x) < len(y) || (len(x) == len(y) && x < y);
        });
        std::copy(idx.begin(), idx.begin() + k_,
                  (way == 0 ? out_ : in_).begin() + static_cast<std::size_t>(a) * k_);
        idx.resize(n);
      }
    }
    queue_.reset(n);
  }

  void set_order(const std::vector<int>& order) {
    order_ = order;
    pos_.assign(n_, 0);
    for (int i = 0; i < n_; ++i) pos_[order_[i]] = i;
    fwd_.assign(2 * n_, 0.0);   // fwd_[t]: driven from position 0 to t (over two laps)
    back_.assign(2 * n_, 0.0);  // back_[t]: the same stretch driven backwards
    for (int t = 0; t + 1 < 2 * n_; ++t) {
      fwd_[t + 1] = fwd_[t] + D(at(t), at(t + 1));
      back_[t + 1] = back_[t] + D(at(t + 1), at(t));
    }
  }
  const std::vector<int>& order() const { return order_; }
  double length() const { return fwd_[n_]; }  // [m] the closed order, last -> first included
  void push(int v) { queue_.push(v); }
  void push_all() { queue_.push_all(order_); }
  void run() {
    queue_.drain([this](int a) { return reversal(a) || or_opt(a); });
  }

 private:
  double D(int a, int b) const { return d_[static_cast<std::size_t>(a) * n_ + b]; }
  int at(int i) const { return order_[((i % n_) + n_) % n_]; }
  int succ(int v) const { return at(pos_[v] + 1); }
  int pred(int v) const { return at(pos_[v] - 1); }
  int wrap(int i) const { return ((i % n_) + n_) % n_; }
  // [m] the arcs inside the `len` positions from `first` (in [0, n)), driven forwards and back
  double inside(int first, int len) const { return fwd_[first + len - 1] - fwd_[first]; }
  double inside_back(int first, int len) const { return back_[first + len - 1] - back_[first]; }

  // Change [m] of reversing the `len` positions from `first` (2 <= len <= n - 1).
  double reversal_delta(int first, int len) const {
    const int p = at(first - 1), s1 = at(first), s2 = at(first + len - 1), e = at(first + len);
    return D(p, s2) + D(s1, e) - D(p, s1) - D(s2, e) + inside_back(first, len) - inside(first, len);
  }

  // The best reversal whose new arc leaves a (a -> segment end) or enters it (start -> a).
  bool reversal(int a) {
    double best = -kEps;
    int best_first = -1, best_len = 0;
    for (int way = 0; way < 2; ++way) {
      const int* cs = (way == 0 ? out_ : in_).data() + static_cast<std::size_t>(a) * k_;
      for (int t = 0; t < k_; ++t) {
        const int c = cs[t];
        const int first = way == 0 ? wrap(pos_[a] + 1) : pos_[c];
        const int len = way == 0 ? wrap(pos_[c] - first) + 1 : wrap(pos_[a] - 1 - first) + 1;
        if (len < 2 || len > n_ - 1) continue;
        const double delta = reversal_delta(first, len);
        if (delta < best) {
          best = delta;
          best_first = first;
          best_len = len;
        }
      }
    }
    if (best_first < 0) return false;
    const int ends[4] = {at(best_first - 1), at(best_first), at(best_first + best_len - 1),
                         at(best_first + best_len)};
    std::vector<int> out = order_;
    for (int s = 0; s < best_len; ++s)
      out[wrap(best_first + s)] = at(best_first + best_len - 1 - s);
    set_order(out);
    for (int v : ends) push(v);
    return true;
  }

  // Or-opt: the best move of a segment of 1-3 positions that starts or ends at a, to between
  // u and its successor w, in its direction or reversed.
  bool or_opt(int a) {
    for (int len = 1; len <= 3 && len + 2 <= n_; ++len) {
      for (int side = 0; side < 2; ++side) {
        const int first = wrap(side == 0 ? pos_[a] : pos_[a] - len + 1);
        const int s1 = at(first), s2 = at(first + len - 1);
        const int p = at(first - 1), nx = at(first + len);
        const double removed = D(p, s1) + D(s2, nx) - D(p, nx);
        const double turn = inside_back(first, len) - inside(first, len);  // reversed segment
        const auto in_segment = [&](int v) { return wrap(pos_[v] - first) < len; };
        Insertion best;
        const auto consider = [&](int u) {
          const int w = succ(u);
          if (u == p || in_segment(u) || in_segment(w)) return;
          const double base = D(u, w) + removed;
          best.offer(u, D(u, s1) + D(s2, w) - base, D(u, s2) + D(s1, w) - base + turn);
        };
        for (int end : {s1, s2}) {
          const std::size_t row = static_cast<std::size_t>(end) * k_;
          for (int t = 0; t < k_; ++t) {
            consider(in_[row + t]);         // u -> end
            consider(pred(out_[row + t]));  // end -> w
          }
        }
        if (best.after >= 0) {
          const int best_w = succ(best.after);
          move_segment(first, len, best.after, best.reversed);
          for (int v : {p, nx, s1, s2, best.after, best_w}) push(v);
          return true;
        }
      }
    }
    return false;
  }

  void move_segment(int first, int len, int u, bool reversed) {
    std::vector<int> seg;
    for (int s = 0; s < len; ++s) seg.push_back(at(first + s));
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
  std::vector<int> out_, in_, order_, pos_;  // out_/in_: k nearest successors/predecessors
  std::vector<double> fwd_, back_;
  VertexQueue queue_;
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

// Double bridge A B C D -> A C B D within kKickWindow positions from a random origin (the
// order rotated there first: the same cycle). Returns the kicked order; `ends` gets the
// vertices at its new arcs.
std::vector<int> double_bridge(const std::vector<int>& order, Rng& rng, std::vector<int>* ends) {
  const int n = static_cast<int>(order.size());
  const int window = std::min(n, kKickWindow);
  const int origin = window < n ? rng.below(n) : 0;
  std::vector<int> rot(n);
  for (int i = 0; i < n; ++i) rot[i] = order[(origin + i) % n];
  int cut[3];
  do {
    for (int& c : cut) c = 1 + rng.below(window - 1);
    std::sort(cut, cut + 3);
  } while (cut[0] == cut[1] || cut[1] == cut[2]);
  std::vector<int> out(rot.begin(), rot.begin() + cut[0]);
  out.insert(out.end(), rot.begin() + cut[1], rot.begin() + cut[2]);
  out.insert(out.end(), rot.begin() + cut[0], rot.begin() + cut[1]);
  out.insert(out.end(), rot.begin() + cut[2], rot.end());
  *ends = {rot[cut[0] - 1], rot[cut[1]],     rot[cut[2] - 1],
           rot[cut[0]],     rot[cut[1] - 1], rot[cut[2] % n]};
  return out;
}

}  // namespace

std::vector<int> directed_order(const std::vector<double>& dist, int n, const TourSearch& search) {
  std::vector<int> best(n);
  std::iota(best.begin(), best.end(), 0);
  if (n <= 2) return best;
  if (n == 3) {  // two cycles: 0 1 2 and 0 2 1
    const std::vector<int> other{0, 2, 1};
    return order_length(dist, n, other) < order_length(dist, n, best) - kEps ? other : best;
  }
  DirectedSearch ls(dist, n);
  double best_len = kInf;
  const int starts = std::max(1, std::min(search.starts, n));
  int previous = -1;
  for (int i = 0; i < starts; ++i) {  // start vertices spread evenly over 0..n-1
    const int s =
        starts == 1 ? 0 : static_cast<int>((static_cast<long long>(n - 1) * i) / (starts - 1));
    if (s == previous) continue;
    previous = s;
    ls.set_order(nearest_neighbour(dist, n, s));
    ls.push_all();
    ls.run();
    if (ls.length() < best_len - kEps) {
      best = ls.order();
      best_len = ls.length();
    }
  }
  if (n >= 6) {
    Rng rng{search.seed};
    std::vector<int> ends;
    for (int kick = 0; kick < search.kicks; ++kick) {
      ls.set_order(double_bridge(best, rng, &ends));
      for (int v : ends) ls.push(v);
      ls.run();
      if (ls.length() < best_len - kEps) {
        best = ls.order();
        best_len = ls.length();
      }
    }
  }
  return best;
}

double infeasible_part_m(const PatrolGraph& graph, const std::vector<int>& part) {
  const int k = static_cast<int>(part.size());
  if (k <= 1) return 0.0;
  std::vector<std::vector<int>> out(k), in(k);
  for (int a = 0; a < k; ++a) {
    for (int w : graph.neighbours(part[a])) {
      const auto it = std::lower_bound(part.begin(), part.end(), w);
      if (it == part.end() || *it != w) continue;
      const int b = static_cast<int>(it - part.begin());
      out[a].push_back(b);
      in[b].push_back(a);
    }
  }
  std::vector<int> reached(k, 0);  // bit 1: from part[0], bit 2: to part[0]
  for (int way = 0; way < 2; ++way) {
    const int bit = 1 << way;
    const std::vector<std::vector<int>>& next = way == 0 ? out : in;
    std::vector<int> stack{0};
    reached[0] |= bit;
    while (!stack.empty()) {
      const int x = stack.back();
      stack.pop_back();
      for (int y : next[x]) {
        if (!(reached[y] & bit)) {
          reached[y] |= bit;
          stack.push_back(y);
        }
      }
    }
  }
  const int missing =
      static_cast<int>(std::count_if(reached.begin(), reached.end(), [](int r) { return r != 3; }));
  return missing == 0 ? 0.0 : kInfeasiblePartM * (1 + missing);
}

}  // namespace tpuaf::tour
