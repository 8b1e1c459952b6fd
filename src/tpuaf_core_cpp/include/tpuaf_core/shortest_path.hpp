// The one shortest-path search of the project: Dijkstra over non-negative arc weights, from one
// or several sources, optionally restricted to a vertex subset. Used by PatrolGraph (all pairs),
// the reference tours (paths inside a part, nearest-seed partitions) and HPCC's weighted paths.
#pragma once

#include <vector>

namespace tpuaf {

struct Arc {
  int to;
  double weight;  // >= 0, in the caller's unit (m for lengths)
};
using ArcLists = std::vector<std::vector<Arc>>;  // outgoing arcs per vertex

struct ShortestPathTree {
  std::vector<double> distance;  // from the nearest source; +inf when unreachable
  std::vector<int> parent;       // previous vertex on the path; -1 at sources and unreachable
  std::vector<int> source;       // index into `sources` of the tree that settled it; -1 if none
};

// Vertices are settled in the order (distance, source index, vertex), so ties are decided the
// same way on every machine. A vertex not yet settled is relabelled when a path to it is shorter
// than its label plus `tolerance` (0: strictly shorter; < 0: shorter by more than -tolerance;
// > 0: also nearly equal paths compete, the settling order then picks). `allowed` (empty: all)
// masks the vertices the search may enter; the search stops once `stop_at` (>= 0) is settled.
ShortestPathTree dijkstra(const ArcLists& arcs, const std::vector<int>& sources,
                          double tolerance = 0.0, const std::vector<char>& allowed = {},
                          int stop_at = -1);

}  // namespace tpuaf
