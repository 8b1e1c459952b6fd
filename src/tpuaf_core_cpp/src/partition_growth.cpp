#include "partition_growth.hpp"

#include <functional>
#include <queue>
#include <tuple>

namespace tpuaf::tour {

std::vector<int> grow_balanced_parts(const ArcLists& arcs, const std::vector<int>& seeds) {
  const int n = static_cast<int>(arcs.size());
  const int k = static_cast<int>(seeds.size());
  std::vector<int> owner(static_cast<std::size_t>(n), -1);
  // Per part: (distance from its seed [m], vertex, arc length [m]) of its frontier, nearest
  // first (ties: the lower vertex).
  using Item = std::tuple<double, int, double>;
  using Frontier = std::priority_queue<Item, std::vector<Item>, std::greater<Item>>;
  std::vector<Frontier> frontier(static_cast<std::size_t>(k));
  std::vector<double> tree_m(static_cast<std::size_t>(k), 0.0);
  auto take = [&](int p, int v, double distance) {
    owner[static_cast<std::size_t>(v)] = p;
    for (const Arc& arc : arcs[static_cast<std::size_t>(v)]) {
      if (owner[static_cast<std::size_t>(arc.to)] < 0) {
        frontier[static_cast<std::size_t>(p)].push({distance + arc.weight, arc.to, arc.weight});
      }
    }
  };
  for (int p = 0; p < k; ++p) {
    if (owner[static_cast<std::size_t>(seeds[static_cast<std::size_t>(p)])] < 0) {
      take(p, seeds[static_cast<std::size_t>(p)], 0.0);
    }
  }
  for (;;) {
    int grow = -1;  // the part of shortest tree with a frontier (the lower index on ties)
    for (int p = 0; p < k; ++p) {
      Frontier& f = frontier[static_cast<std::size_t>(p)];
      while (!f.empty() && owner[static_cast<std::size_t>(std::get<1>(f.top()))] >= 0) f.pop();
      if (!f.empty() && (grow < 0 || tree_m[static_cast<std::size_t>(p)] <
                                         tree_m[static_cast<std::size_t>(grow)])) {
        grow = p;
      }
    }
    if (grow < 0) break;
    const auto [distance, v, arc_m] = frontier[static_cast<std::size_t>(grow)].top();
    frontier[static_cast<std::size_t>(grow)].pop();
    tree_m[static_cast<std::size_t>(grow)] += arc_m;
    take(grow, v, distance);
  }
  return owner;
}

}  // namespace tpuaf::tour
