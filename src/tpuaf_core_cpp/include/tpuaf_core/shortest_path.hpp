// The one shortest-path search of the project: Dijkstra over non-negative arc weights, from one
// or several sources, optionally restricted to a vertex subset. Used by PatrolGraph (single-source
// rows and paths on demand), the reference tours (paths inside a part, nearest-seed partitions)
// and HPCC's weighted paths.
#pragma once

#include <functional>
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

// Labels of repeated searches on one graph, kept between them: a search resets only the
// vertices the previous one reached, so a search stopped early (`stop_at`) costs O(the ball it
// explores), not O(vertices). Not thread-safe: one workspace per thread.
class DijkstraWorkspace {
 public:
  // Vertices are settled in the order (distance, source index, vertex), so ties are decided the
  // same way on every machine. A vertex not yet settled is relabelled when a path to it is
  // shorter than its label plus `tolerance` (0: strictly shorter; < 0: shorter by more than
  // -tolerance; > 0: also nearly equal paths compete, the settling order then picks). `allowed`
  // (empty: all) masks the vertices the search may enter; it stops once `stop_at` (>= 0) is
  // settled. A settled vertex's labels are final: those of a search without `stop_at`.
  void run(const ArcLists& arcs, const std::vector<int>& sources, double tolerance = 0.0,
           const std::vector<char>& allowed = {}, int stop_at = -1);
  // The same search, stopped once `stop(v)` is true for a vertex v just settled; a settled
  // vertex for which `expand` (when given) is false is not left (its arcs are not relaxed).
  // `potential` (when given): vertices are settled in the order (distance + potential, ...)
  // (A*); with a potential no larger than the length to the goal and consistent (p(u) <=
  // length(u, w) + p(w) on every arc), every settled label is still a shortest length.
  void run_until(const ArcLists& arcs, const std::vector<int>& sources, double tolerance,
                 const std::vector<char>& allowed, const std::function<bool(int)>& stop,
                 const std::function<bool(int)>& expand = nullptr,
                 const std::function<double(int)>& potential = nullptr);
  // Vertices the last search settled, in settling order.
  const std::vector<int>& settled_order() const { return order_; }
  double distance(int v) const { return distance_[v]; }  // +inf: not reached
  int parent(int v) const { return parent_[v]; }
  int source(int v) const { return source_[v]; }
  bool settled(int v) const { return settled_[v] != 0; }
  // The last search's labels of every vertex (O(vertices)).
  ShortestPathTree tree() const;

 private:
  template <class Stop, class Expand, class Potential>
  void search(const ArcLists& arcs, const std::vector<int>& sources, double tolerance,
              const std::vector<char>& allowed, const Stop& stop, const Expand& expand,
              const Potential& potential);
  void mark(int v) {
    if (!labelled_[v]) {
      labelled_[v] = 1;
      touched_.push_back(v);
    }
  }
  std::vector<double> distance_;
  std::vector<int> parent_, source_;
  std::vector<char> settled_, labelled_;
  std::vector<int> touched_;  // vertices the last search labelled
  std::vector<int> order_;    // vertices the last search settled, in order
};

// One search into a fresh tree (DijkstraWorkspace::run, same arguments).
ShortestPathTree dijkstra(const ArcLists& arcs, const std::vector<int>& sources,
                          double tolerance = 0.0, const std::vector<char>& allowed = {},
                          int stop_at = -1);

}  // namespace tpuaf
