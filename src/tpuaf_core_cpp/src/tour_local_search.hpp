// The plan search's local search over vertex orders (internal to tpuaf_core_cpp, used by
// tours.cpp): 2-opt and Or-opt over neighbour lists, on either metric of tour_metrics.hpp.
#pragma once

#include "tour_metrics.hpp"
#include "vertex_queue.hpp"

namespace tpuaf::tour {

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
    queue_.reset(n_);
    pos_.assign(n_, 0);
  }

  void set_order(const std::vector<int>& order) {
    order_ = order;
    for (int i = 0; i < n_; ++i) pos_[order_[i]] = i;
    gain_ = 0.0;
  }
  const std::vector<int>& order() const { return order_; }
  double gain() const { return gain_; }

  void push(int v) { queue_.push(v); }
  void push_all() { queue_.push_all(order_); }

  // Improves until no move from a queued vertex improves.
  void run() {
    queue_.drain([this](int a) { return two_opt(a) || or_opt(a); });
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
        Insertion best;
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
              const double limit = best.gain + base + removed + kEps;  // of each added length
              best.offer(u, D(u, s1, limit) + D(s2, w, limit) - base - removed,
                         D(u, s2, limit) + D(s1, w, limit) - base - removed);
            }
          }
        }
        if (best.after >= 0) {
          const int best_w = succ(best.after);
          move_segment(first, len, best.after, best.reversed);
          gain_ += best.gain;
          for (int v : {p, nx, s1, s2, best.after, best_w}) push(v);
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
  VertexQueue queue_;
};

}  // namespace tpuaf::tour
