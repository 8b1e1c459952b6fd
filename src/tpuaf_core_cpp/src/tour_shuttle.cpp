// A lone vertex's closed walk (tours.hpp shuttle_walk).
#include <cmath>
#include <limits>
#include <vector>

#include "tpuaf_core/tours.hpp"

namespace tpuaf {

// A lone vertex's patrol: standing on it makes no visit (the visit rule), so its closed walk
// drives out to the out-neighbour w of least edge(v, w) + d(w, v) [m] and back along a shortest
// path; [v] with length 0 when v has no way out and back.
ClosedWalk shuttle_walk(const PatrolGraph& graph, int v) {
  graph.check_vertex(v);
  ClosedWalk out;
  out.walk = {v};
  int best = -1;
  double best_m = std::numeric_limits<double>::infinity();
  for (int w : graph.neighbours(v)) {
    if (w == v) continue;
    const double m = graph.edge_length(v, w) + graph.distance(w, v);
    if (m < best_m || (m == best_m && w < best)) {
      best = w;
      best_m = m;
    }
  }
  if (best < 0 || !std::isfinite(best_m)) return out;
  const std::vector<int> back = graph.path(best, v);  // w ... v
  out.walk.insert(out.walk.end(), back.begin(), back.end() - 1);
  out.length_m = best_m;
  return out;
}

}  // namespace tpuaf
