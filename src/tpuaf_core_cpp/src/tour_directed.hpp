// The plan search on graphs with one-way arcs (internal to tpuaf_core_cpp, used by tours.cpp):
// there d(a, b) != d(b, a), so a cyclic order is driven in one direction only, and 2-opt's
// "reverse a segment, the tour is the same" no longer holds. tours_directed.cpp.
#pragma once

#include <vector>

#include "tpuaf_core/graph.hpp"
#include "tpuaf_core/tours.hpp"

namespace tpuaf::tour {

// A graph whose shortest paths follow one-way arcs (the asymmetric search applies).
inline bool directed(const PatrolGraph& graph) { return !graph.one_way().empty(); }

// A short cyclic order of 0..n-1 on the asymmetric metric `dist` (row-major n x n [m], d(a, b)
// the length driven from a to b): nearest neighbour from `search.starts` spread rows, then a
// local search whose moves are priced in the order's direction (Or-opt of 1-3 vertices either
// way round, segment reversal with the segment's own arcs re-priced backwards), then
// `search.kicks` double-bridge kicks (a double bridge reverses nothing: it keeps the
// direction). Deterministic (fixed-seed kicks).
std::vector<int> directed_order(const std::vector<double>& dist, int n, const TourSearch& search);

// [m] 0 when the sorted `part` induces a strongly connected subgraph (a closed walk inside it
// exists), else kInfeasiblePartM x (1 + the part's vertices not both reachable from and able
// to reach part[0] inside it): the partition search's cost of a part it cannot tour.
constexpr double kInfeasiblePartM = 1e7;
double infeasible_part_m(const PatrolGraph& graph, const std::vector<int>& part);

}  // namespace tpuaf::tour
