// One robot's patrol protocol, the state machine every runtime drives (docs/RUNTIMES.md): the
// graph runtime's event loop (GraphEngine, a C++ driver) and, through tpuaf.robot.machine's
// RobotMachine (a Python driver), the physics runtime and the ROS agents.
//
//   start --decide--> DRIVING(goal) --vertex passed--> DRIVING (same route, or a redirect)
//                |        |--goal vertex reached--> REACHED (a visit) or DWELL: decide again
//                |        |--navigator gave up----> FAILED: on_goal_failed, decide again
//                |--goal == here, robot on it--> DWELLING(stay_s) --end--> DWELL: decide again
//                |--no goal--> WAITING --wake time--> decide
//   any state --death--> DEAD (no motion, no decisions)
//
// The driver owns the clock, the transport, the motion and the policy; the protocol calls it
// back to move, dwell, halt, schedule wake-ups and ask the policy, and reports what happened
// with emit(kind, ...) (the AgentEvent kinds of tpuaf.topics). Times in seconds of run time,
// positions in metres, vertices graph indices.
#pragma once

#include <vector>

#include "tpuaf_core/perception.hpp"
#include "tpuaf_core/teammate_liveness.hpp"
#include "tpuaf_core/visit_rule.hpp"

namespace tpuaf {

// What a robot's protocol reports (tpuaf.topics: START, GOAL, REACHED, FAILED, DWELL).
namespace robot_event {
constexpr int kStart = 0;    // the start vertex's first visit
constexpr int kGoal = 1;     // a new goal
constexpr int kReached = 2;  // a visit (VisitRule)
constexpr int kFailed = 3;   // the motion gave up on the goal
constexpr int kDwell = 5;    // a goal ended without a visit
}  // namespace robot_event

// What a runtime provides to its robots' protocols (robot: the protocol's index; one driver may
// serve the whole team).
class RobotDriver {
 public:
  virtual ~RobotDriver() = default;
  virtual double now() const = 0;                                    // [s] run time
  virtual void position(int robot, double& x, double& y) const = 0;  // [m] map frame
  // Does the robot stand on `vertex` (it dwells there rather than drive)?
  virtual bool at_vertex(int robot, int vertex) const = 0;
  virtual void schedule_wake(int robot, double time_s) = 0;  // call on_wake at time_s
  // Follow the shortest path from from_vertex: call on_vertex at every vertex of it, or
  // on_goal_failed.
  virtual void drive(int robot, int from_vertex, int goal) = 0;
  // Stand still duration_s, then call on_vertex(vertex, true).
  virtual void dwell(int robot, int vertex, double duration_s) = 0;
  virtual void halt(int robot) = 0;  // no goal: stand still
  // The robot's policy: its start hook, its decision (-1: wait), its goal-failed and
  // teammate-lost hooks.
  virtual void policy_start(int robot) = 0;
  virtual int policy_decide(int robot) = 0;
  virtual void policy_goal_failed(int robot, int vertex) = 0;
  virtual void policy_teammate_lost(int robot, int teammate) = 0;
  // What happened (robot_event kinds) at run time t [s].
  virtual void emit(int robot, int kind, int vertex, int from_vertex, double t) = 0;
};

struct ProtocolConfig {
  int robot = 0, robots = 1;
  double stay_s = 1.0;               // [s] a robot whose goal is its own vertex dwells this long
  double retry_s = 1.0;              // [s] a waiting policy without a wake-up decides again after
  double teammate_timeout_s = 10.0;  // [s] a teammate silent this long is lost
  double visit_radius_m = kDefaultVisitRadiusM;
  double goal_tolerance_m = kDefaultGoalToleranceM;  // [m] within this of its goal: dwell there
};

class RobotProtocol {
 public:
  // positions: the map's vertices [m] (the visit rule's); driver: must outlive the protocol.
  RobotProtocol(RobotDriver& driver, const Points& positions, ProtocolConfig config);

  // --- inputs from the driver ---
  void place(int vertex);  // the robot stands at its start vertex (before start)
  // START (the start vertex's first visit), then the policy's start hook; decide comes next.
  void start();
  void decide();   // ask the policy for the next goal and head there (none: wait for a wake-up)
  void on_wake();  // a wake-up is due (ignored while the robot has a goal)
  // The robot reached `vertex` of its route (at_goal: the route's last one, or the end of a
  // dwell); true when the driver should go on along the same route.
  bool on_vertex(int vertex, bool at_goal);
  // The motion gave up on goal `vertex`; the robot is nearest to nearest_vertex.
  void on_goal_failed(int vertex, int nearest_vertex);
  void observe(double x, double y) { rule_.observe(x, y); }  // every pose [m]: the visit rule
  // Is the robot (the driver's position) within the goal tolerance of `vertex`?
  bool within_goal_tolerance(int vertex) const;
  // The vertex nearest (x, y) [m] (the first on ties).
  int nearest_vertex(double x, double y) const {
    return tpuaf::nearest_vertex(rule_.positions(), x, y);
  }
  // Teammate `robot` heard at run time t [s]; true when it had been lost (it is back).
  bool hear(int robot, double t) { return alive_ && liveness_.heard(robot, t); }
  // Teammates silent for the timeout by now [s], each reported once; the policy's
  // teammate-lost hook is called for each (after the start).
  std::vector<int> check_liveness(double now);
  void on_teammate_lost(int robot);
  void die();    // no motion, no decisions from now on (teammates are not told)
  void stall();  // stops moving for good; keeps deciding and talking

  // --- what the policy asks of the robot ---
  void wake_at(double time_s);   // decide at time_s (not before now) while without a goal
  void change_goal(int vertex);  // redirect: at the next vertex passed, head to `vertex`

  // --- state ---
  int robot() const { return config_.robot; }
  int current_vertex() const { return current_; }
  int start_vertex() const { return start_; }
  int goal() const { return goal_; }  // -1: none
  int redirect() const { return redirect_; }
  bool alive() const { return alive_; }
  bool started() const { return started_; }
  bool stalled() const { return stalled_; }
  bool dwelling() const { return dwelling_; }
  bool wake_pending() const { return wake_pending_; }
  // Messages are heard (alive and started).
  bool listening() const { return alive_ && started_; }
  long long visits() const { return visits_; }
  long long dwells() const { return dwells_; }  // goals ended without a visit
  long long failures() const { return failures_; }
  long long decisions() const { return decisions_; }
  double dwell_time_s() const { return dwell_time_s_; }  // [s] standing in dwells
  double last_dwell_s() const { return last_dwell_s_; }  // [s] of the last DWELL (0: not one)
  // The goal's leg (set at a new goal, until its end): from vertex and departure time [s]
  // (-1: none); a driver reads them at REACHED / DWELL to measure Vel(i).
  int leg_from() const { return leg_from_; }
  double leg_start_s() const { return leg_start_s_; }
  const VisitRule& visit_rule() const { return rule_; }
  const TeammateLiveness& liveness() const { return liveness_; }
  // The liveness to feed with heartbeats (HeartbeatLinks::feed) while the robot is alive.
  TeammateLiveness& liveness() { return liveness_; }

 private:
  void set_goal(int goal);
  void reach(int vertex);
  void check_vertex(int vertex) const;

  RobotDriver& driver_;
  ProtocolConfig config_;
  VisitRule rule_;
  TeammateLiveness liveness_;
  int start_ = -1, current_ = -1, goal_ = -1, redirect_ = -1;
  bool wake_pending_ = false, dwelling_ = false, started_ = false;
  bool alive_ = true, stalled_ = false;
  long long visits_ = 0, dwells_ = 0, failures_ = 0, decisions_ = 0;
  double dwell_since_s_ = 0, dwell_time_s_ = 0, last_dwell_s_ = 0;
  int leg_from_ = -1;
  double leg_start_s_ = 0;
  std::vector<int> lost_scratch_;
};

}  // namespace tpuaf
