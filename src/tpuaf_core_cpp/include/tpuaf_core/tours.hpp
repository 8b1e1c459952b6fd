// Plan search for the reference tours and tpuaf_plus (SPEC sec. 5): cyclic orders on a metric
// (nearest neighbour + 2-opt + Or-opt with neighbour lists, iterated with double-bridge kicks),
// closed walks through a vertex subset moving only inside it, and balanced connected partitions
// of a patrol graph. Every search is deterministic: the kicks draw from a fixed-seed generator
// of our own (not std::distributions, whose output differs between standard libraries), so
// every robot of a team computes the same plan on any machine.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "tpuaf_core/graph.hpp"

namespace tpuaf {

// Vertex subsets up to this size are toured on the k x k matrix of their shortest paths (8 k^2 B
// of lengths, 4 k^2 B of parents); larger ones on lengths searched on demand (the same
// candidate lists; other pairs by A*, bounded by what a move could gain, memoised; no k x k
// matrix): the same search over the same lengths up to their last bits, with Or-opt moves made
// in place. The effort (starts, kicks) is the caller's: tours._effort lowers it by size.
constexpr int kDenseTourMax = 1000;  // vertices

enum class TourMetric { kAuto, kDense, kSparse };  // kAuto: by size (kDenseTourMax)

struct TourSearch {
  int starts = 12;             // nearest-neighbour starts (spread over the indices)
  int kicks = 30;              // double-bridge kicks of the best local optimum
  std::uint64_t seed = 12345;  // of the kicks
  TourMetric metric = TourMetric::kAuto;
};

// Called now and then by long searches: (stage name, done, total). May throw to abort.
using Progress = std::function<void(const char* stage, int done, int total)>;

// Cyclic order of 0..n-1 on the symmetric metric `dist` (row-major n x n, [m]) found short.
std::vector<int> tsp_order(const std::vector<double>& dist, int n, const TourSearch& search = {});

// Length [m] of the cyclic order on `dist` (last -> first included).
double order_length(const std::vector<double>& dist, int n, const std::vector<int>& order);

struct ClosedWalk {
  std::vector<int> walk;  // vertex indices, consecutive ones adjacent, last -> first too;
                          // the first vertex is not repeated
  double length_m = 0.0;
};

// Shortest closed walk found through `vertices` (any order, duplicates ignored), moving only
// inside their induced subgraph. Throws std::invalid_argument when that subgraph is not
// connected. On a graph with one-way arcs the walk drives every arc only its way (the dense,
// asymmetric search of tour_directed.hpp at any size; the subgraph must be strongly connected).
// One vertex: standing on it makes no visit, so its walk drives to its nearest way out and back
// (out of the set: the one exception to moving inside it).
ClosedWalk closed_walk(const PatrolGraph& graph, const std::vector<int>& vertices,
                       const TourSearch& search = {});

// A lone vertex v's patrol (standing on it makes no visit): out to the out-neighbour w of least
// edge(v, w) + d(w, v) [m] and back along a shortest path; [v] with length 0 when v has no way
// out and back.
ClosedWalk shuttle_walk(const PatrolGraph& graph, int v);

// Length [m] only (same search as closed_walk).
double closed_walk_length(const PatrolGraph& graph, const std::vector<int>& vertices,
                          const TourSearch& search = {});

// min(k, |V|) connected parts (sorted vertex lists) balanced by the length of their closed walks:
// nearest-seed parts from farthest-point seeds (three first seeds; above kDenseTourMax
// vertices one, and parts grown together to equal tree lengths instead), then single-vertex moves
// from the part of the longest walk to an adjacent part while that lowers the longest walk,
// at most `max_moves` moves per seeding (part walks scored with `part_search`). The seeding
// with the lowest longest walk wins. `tree_score`: parts are scored by the length of their
// minimum spanning tree instead (large parts: a walk search per boundary vertex is too slow).
// With one-way arcs a part must be strongly connected (one that is not costs a penalty the
// moves lower); empty when no seeding ends with every part strongly connected.
std::vector<std::vector<int>> balanced_partition(const PatrolGraph& graph, int k, int max_moves,
                                                 const TourSearch& part_search = {3, 4, 12345},
                                                 const Progress& progress = nullptr,
                                                 bool tree_score = false);

// Robots per part: one each, every extra robot to the part of largest length / robots.
std::vector<int> robots_per_part(const std::vector<double>& lengths_m, int n_robots);

}  // namespace tpuaf
