#include "tpuaf_core/shortest_path.hpp"

#include <functional>
#include <limits>
#include <queue>
#include <stdexcept>
#include <string>
#include <tuple>

namespace tpuaf {

ShortestPathTree dijkstra(const ArcLists& arcs, const std::vector<int>& sources, double tolerance,
                          const std::vector<char>& allowed, int stop_at) {
  const int n = static_cast<int>(arcs.size());
  if (!allowed.empty() && static_cast<int>(allowed.size()) != n) {
    throw std::invalid_argument("dijkstra: the allowed mask has " + std::to_string(allowed.size()) +
                                " entries for " + std::to_string(n) + " vertices");
  }
  ShortestPathTree tree{std::vector<double>(n, std::numeric_limits<double>::infinity()),
                        std::vector<int>(n, -1), std::vector<int>(n, -1)};
  std::vector<char> settled(n, 0);
  using Item = std::tuple<double, int, int>;  // distance, source index, vertex
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
  for (int k = 0; k < static_cast<int>(sources.size()); ++k) {
    const int s = sources[k];
    if (s < 0 || s >= n)
      throw std::out_of_range("dijkstra: unknown source vertex " + std::to_string(s));
    if (tree.distance[s] > 0.0) {
      tree.distance[s] = 0.0;
      queue.emplace(0.0, k, s);
    }
  }
  while (!queue.empty()) {
    const auto [d, k, u] = queue.top();
    queue.pop();
    if (settled[u]) continue;
    settled[u] = 1;
    tree.source[u] = k;
    if (u == stop_at) break;
    for (const Arc& arc : arcs[u]) {
      const int w = arc.to;
      if (w < 0 || w >= n)
        throw std::out_of_range("dijkstra: arc to unknown vertex " + std::to_string(w));
      if (settled[w] || (!allowed.empty() && !allowed[w])) continue;
      const double nd = d + arc.weight;
      if (nd < tree.distance[w] + tolerance) {
        tree.distance[w] = nd;
        tree.parent[w] = u;
        queue.emplace(nd, k, w);
      }
    }
  }
  return tree;
}

}  // namespace tpuaf
