// The work queue of the tour local searches (tour_local_search.hpp, tours_directed.cpp): the
// vertices whose moves are still to try, first in first out, each queued at most once.
#pragma once

#include <deque>
#include <vector>

namespace tpuaf {

class VertexQueue {
 public:
  void reset(int n) {
    queued_.assign(static_cast<std::size_t>(n), 0);
    queue_.clear();
  }
  void push(int v) {
    if (!queued_[static_cast<std::size_t>(v)]) {
      queued_[static_cast<std::size_t>(v)] = 1;
      queue_.push_back(v);
    }
  }
  void push_all(const std::vector<int>& vertices) {
    for (int v : vertices) push(v);
  }
  // Tries `improve(v)` for each queued vertex in turn, queueing it again when it improved,
  // until none is left.
  template <typename Improve>
  void drain(Improve improve) {
    while (!queue_.empty()) {
      const int a = queue_.front();
      queue_.pop_front();
      queued_[static_cast<std::size_t>(a)] = 0;
      if (improve(a)) push(a);
    }
  }

 private:
  std::vector<char> queued_;
  std::deque<int> queue_;
};

}  // namespace tpuaf
