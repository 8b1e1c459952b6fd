// What one TPUAF robot knows (SPEC section 4, steps 3, 6 and 7): the shared set Q of visits and
// announced intentions, with stale entries dropped, and its own estimate of every X_j.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "tpuaf_core/utility.hpp"

namespace tpuaf {

struct Intention {
  int robot = -1;
  int from_vertex = -1;
  int vertex = -1;
  double expected_arrival_s = 0;
  double travel_time_s = 0;
  double sent_s = 0;
};

class TpuafKnowledge {
 public:
  // importance C_j and initial X0_j per vertex; a known visit applies one straight pass at
  // nominal speed: X <- evolve(X, C - pass_coverage, pass_time_s) (mean M over the pass).
  TpuafKnowledge(const Eigen::VectorXd& importance, const Eigen::VectorXd& initial,
                 UncertaintyModel model, double pass_coverage, double pass_time_s,
                 double intention_timeout_s);

  // A visit of `vertex` at `time_s` (own or heard). Visits older than the newest known one of
  // that vertex only update nothing but the idleness clock when newer.
  void record_visit(int vertex, double time_s);
  // A Visit message of `robot`: records the visit and clears that robot's
  // intention if it was for this vertex.
  void hear_visit(int robot, int vertex, double time_s);
  // X_j of `vertex` after a visit at visit_time_s, from its estimate `value` at `time_s`:
  // record_visit's arithmetic (Eq. 2 up to the visit, then one straight pass).
  double after_visit(int vertex, double value, double time_s, double visit_time_s) const;
  // The estimate's anchor of `vertex`: X_j at its newest applied visit, and that time [s].
  double anchor_value(int vertex) const;
  double anchor_time(int vertex) const;
  // Sets `vertex`'s anchor and newest visit to (value, time_s): a state kept elsewhere
  // (TeamVisits) lent back for a utility.
  void set_visit_state(int vertex, double value, double time_s);
  // An Intention message; the newest intention per robot wins.
  void hear_intention(const Intention& intention);
  void forget_intention(int robot);
  // Drops intentions whose expected arrival passed more than intention_timeout_s ago. A silent
  // robot's intention goes when the runtime's liveness rule reports it lost (forget_intention).
  void drop_stale(double now_s);

  Eigen::VectorXd estimate(double now_s) const;
  const Eigen::VectorXd& last_visit() const { return last_visit_; }
  // The held intentions, in the order they were first heard.
  std::vector<Intention> intentions() const;
  // Earliest announced arrival per vertex (+inf: none) and that robot's travel time.
  void announced(Eigen::VectorXd& arrival_s, Eigen::VectorXd& travel_s) const;
  int size() const { return static_cast<int>(last_visit_.size()); }
  // Copies made after this call share the results of record_visit: a robot applying a visit
  // to the same estimate as another robot did (same value, time and visit time) takes that
  // result instead of evaluating Eq. 2 again. Same numbers, one evaluation per team.
  void share_visit_results();

  // --- One knowledge for a whole team whose bus has no loss and no delay: every robot hears
  // every teammate's message at once, so all robots know the same except their own intention
  // (left out of their own utilities). The sender applies its visit with record_visit; its
  // teammates take the messages through these two calls, once for the team. Each returns false
  // if the messages leave the pattern that keeps the robots' copies equal: a robot's intention
  // is closed by its visit of that vertex before its next intention (otherwise robots that
  // dropped the intention as stale and robots that did not would disagree).
  bool hear_team_visit(int robot, int vertex);
  bool hear_team_intention(const Intention& intention);
  // A copy as robot `robot` holds it: without its own intention.
  TpuafKnowledge as_robot(int robot) const;

  // Eq. 6-14 for `candidates` with this knowledge (stale entries dropped first); the intention
  // of `exclude_robot` (>= 0: the deciding robot in a team knowledge) is not counted.
  UtilityResult utilities(const PatrolGraph& graph, double now_s, int current_vertex,
                          const std::vector<int>& candidates, double speed_mps, UtilityForm form,
                          bool use_path_length, int exclude_robot = -1);

 private:
  void check_vertex(int v) const;
  Eigen::VectorXd importance_, last_visit_;
  // The estimate of X_j: its value at its anchor time (both in one cache line).
  struct Anchor {
    double value = 0, time = 0;
  };
  std::vector<Anchor> anchor_;
  UncertaintyModel model_;
  double pass_coverage_, pass_time_s_, intention_timeout_s_;
  // At most one intention per robot, held in the robot's slot; `order` is when the slot was
  // filled (ties of announced() go to the earlier one). O(1) per message, O(robots) per
  // decision.
  struct Slot {
    Intention intention;
    std::uint64_t order = 0;
    bool held = false;
    bool open = false;  // an intention not yet closed by the robot's visit of its vertex
  };
  Slot* slot(int robot);
  struct VisitResult {
    double value_in = 0, time_in = 0, visit_time = 0, value_out = 0;
    bool valid = false;
  };
  std::shared_ptr<std::vector<VisitResult>> shared_visits_;
  std::vector<Slot> slots_;
  std::uint64_t next_order_ = 0;
  Eigen::VectorXd scratch_estimate_, scratch_arrival_, scratch_travel_;
  std::vector<std::uint64_t> scratch_order_;
};

}  // namespace tpuaf
