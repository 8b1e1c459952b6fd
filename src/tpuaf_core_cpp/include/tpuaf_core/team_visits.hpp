// What each robot of a team knows of every vertex's visits: TpuafKnowledge's newest visit and
// its estimate's anchor (X_j at that visit), for every robot, stored vertex by vertex with the
// robots side by side. A visit heard by the whole team then touches one stretch of memory
// instead of one cache line in each robot's own copy (on a 10,000-vertex map with 100 robots,
// those misses were a fifth of a run's time). Same arithmetic as TpuafKnowledge::record_visit.
#pragma once

#include <cstddef>
#include <vector>

#include "tpuaf_core/knowledge.hpp"

namespace tpuaf {

class TeamVisits {
 public:
  TeamVisits() = default;
  // `n_robots` robots, each starting from `initial`'s state (its anchors; their times are its
  // newest visits). `initial` also gives the arithmetic of a visit (TpuafKnowledge::after_visit).
  TeamVisits(const TpuafKnowledge& initial, int n_robots);
  // Robot `robot`'s state back to the initial one.
  void reset(int robot);
  // TpuafKnowledge::record_visit for robot `robot` (a visit older than its newest one of
  // `vertex` changes nothing).
  void record(int robot, int vertex, double time_s);
  // [s] robot `robot`'s newest known visit of `vertex`.
  double last_visit(int robot, int vertex) const { return anchors_[index(robot, vertex)].time; }
  // Copies robot `robot`'s state of `vertices` into `knowledge` (for a utility over them).
  void lend(int robot, const std::vector<int>& vertices, TpuafKnowledge& knowledge) const;

 private:
  struct Anchor {
    double value = 0, time = 0;  // X_j at the newest visit, and its time [s]
  };
  std::size_t index(int robot, int vertex) const;  // checked
  const TpuafKnowledge* rule_ = nullptr;  // the prototype (outlives this: its owner's member)
  int robots_ = 0;
  std::vector<Anchor> initial_;  // per vertex
  std::vector<Anchor> anchors_;  // [vertex * robots + robot]
  // The newest result per vertex: robots applying the same visit to the same anchor take it.
  struct Result {
    double value_in = 0, time_in = 0, visit_time = 0, value_out = 0;
    bool valid = false;
  };
  std::vector<Result> results_;
};

}  // namespace tpuaf
