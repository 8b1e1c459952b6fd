#include "tpuaf_core/shortest_path.hpp"

#include <functional>
#include <limits>
#include <queue>
#include <stdexcept>
#include <string>
#include <tuple>

namespace tpuaf {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}

void DijkstraWorkspace::run(const ArcLists& arcs, const std::vector<int>& sources, double tolerance,
                            const std::vector<char>& allowed, int stop_at) {
  search(
      arcs, sources, tolerance, allowed, [stop_at](int v) { return v == stop_at; },
      [](int) { return true; }, [](int) { return 0.0; });
}

void DijkstraWorkspace::run_until(const ArcLists& arcs, const std::vector<int>& sources,
                                  double tolerance, const std::vector<char>& allowed,
                                  const std::function<bool(int)>& stop,
                                  const std::function<bool(int)>& expand,
                                  const std::function<double(int)>& potential) {
  const auto everywhere = [](int) { return true; };
  const auto none = [](int) { return 0.0; };
  if (expand && potential) {
    search(arcs, sources, tolerance, allowed, stop, expand, potential);
  } else if (expand) {
    search(arcs, sources, tolerance, allowed, stop, expand, none);
  } else if (potential) {
    search(arcs, sources, tolerance, allowed, stop, everywhere, potential);
  } else {
    search(arcs, sources, tolerance, allowed, stop, everywhere, none);
  }
}

template <class Stop, class Expand, class Potential>
void DijkstraWorkspace::search(const ArcLists& arcs, const std::vector<int>& sources,
                               double tolerance, const std::vector<char>& allowed, const Stop& stop,
                               const Expand& expand, const Potential& potential) {
  const int n = static_cast<int>(arcs.size());
  if (!allowed.empty() && static_cast<int>(allowed.size()) != n) {
    throw std::invalid_argument("dijkstra: the allowed mask has " + std::to_string(allowed.size()) +
                                " entries for " + std::to_string(n) + " vertices");
  }
  if (static_cast<int>(distance_.size()) != n) {
    distance_.assign(n, kInf);
    parent_.assign(n, -1);
    source_.assign(n, -1);
    settled_.assign(n, 0);
    labelled_.assign(n, 0);
    touched_.clear();
  }
  for (int v : touched_) {  // forget the previous search
    distance_[v] = kInf;
    parent_[v] = source_[v] = -1;
    settled_[v] = labelled_[v] = 0;
  }
  touched_.clear();
  order_.clear();
  using Item = std::tuple<double, int, int>;  // distance, source index, vertex
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
  for (int k = 0; k < static_cast<int>(sources.size()); ++k) {
    const int s = sources[k];
    if (s < 0 || s >= n)
      throw std::out_of_range("dijkstra: unknown source vertex " + std::to_string(s));
    if (distance_[s] > 0.0) {
      mark(s);
      distance_[s] = 0.0;
      queue.emplace(0.0 + potential(s), k, s);
    }
  }
  while (!queue.empty()) {
    const auto [key, k, u] = queue.top();
    queue.pop();
    if (settled_[u]) continue;
    settled_[u] = 1;
    source_[u] = k;
    order_.push_back(u);
    if (stop(u)) break;
    if (!expand(u)) continue;
    for (const Arc& arc : arcs[u]) {
      const int w = arc.to;
      if (w < 0 || w >= n)
        throw std::out_of_range("dijkstra: arc to unknown vertex " + std::to_string(w));
      if (settled_[w] || (!allowed.empty() && !allowed[w])) continue;
      const double nd = distance_[u] + arc.weight;
      if (nd < distance_[w] + tolerance) {
        mark(w);
        distance_[w] = nd;
        parent_[w] = u;
        queue.emplace(nd + potential(w), k, w);
      }
    }
  }
}

ShortestPathTree DijkstraWorkspace::tree() const { return {distance_, parent_, source_}; }

ShortestPathTree dijkstra(const ArcLists& arcs, const std::vector<int>& sources, double tolerance,
                          const std::vector<char>& allowed, int stop_at) {
  DijkstraWorkspace work;
  work.run(arcs, sources, tolerance, allowed, stop_at);
  return work.tree();
}

}  // namespace tpuaf
