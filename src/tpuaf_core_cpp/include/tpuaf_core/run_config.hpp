// Settings and faults of one graph-runtime run (SI units: s, m, m/s).
#pragma once

#include <tuple>
#include <vector>

#include "tpuaf_core/visit_rule.hpp"

namespace tpuaf {

struct EngineConfig {
  int robots = 1;
  double duration_s = 3600;
  double delay_s = 0;  // team message delay [s]
  double loss = 0;     // probability that one recipient loses one message
  double sample_period_s = 1.0;
  double nominal_speed_mps = 1.0;
  double stay_s = 1.0;          // dwell when the goal is the current vertex [s]
  double retry_s = 1.0;         // a waiting strategy without a wake-up decides again after [s]
  double refractory_s = 10.0;   // interference episodes of a pair closer than this merge [s]
  double max_substep_s = 0.25;  // ground-truth field substep [s]
  double field_merge_s = 0.5;   // position updates closer than this merge into one field step
  double interference_distance_m = 2.0;
  double sensing_peak = 1.0;
  double sensing_radius_m = 5.0;
  std::vector<int> start_vertices;
  // [m] a visit: an arrival this close after driving there (VisitRule)
  double visit_radius_m = kDefaultVisitRadiusM;
  // Runs with faults (GraphEngine::set_faults):
  double goal_tolerance_m =
      kDefaultGoalToleranceM;        // a stalled robot dwells only within this of its goal
  double stall_give_up_s = 60.0;     // a stalled robot's navigator gives up a drive after [s]
  double teammate_timeout_s = 10.0;  // a teammate silent this long is lost [s]
  double heartbeat_period_s = 1.0;   // every live robot sends a heartbeat this often [s]
  // Aisles one robot wide (the lane map's narrow vertices, docs/LANES.md): one robot on such a
  // vertex at a time. Arrivals there are at least narrow_headway_s apart [s], and a robot that
  // stands on one (waiting, dwelling) holds the next arrival short of it until it leaves.
  // Empty or a headway of 0: robots are points that pass through each other.
  std::vector<int> narrow_vertices;
  double narrow_headway_s = 0;
  // Turns at vertices (a timed map's turns, navigation/travel_time.py): (w, u, v, s) adds s [s]
  // to edge u -> v's duration when the robot arrived at u from w (s < 0: faster than the mean
  // the edge's length assumes). Empty: every edge in its length / speed.
  std::vector<std::tuple<int, int, int, double>> turn_times;
};

// A robot fault at time_s [s] (tpuaf.runtimes.faults): death, or stall (stops moving for good).
struct EngineFault {
  double time_s = 0;
  int robot = 0;
  bool death = true;
};

}  // namespace tpuaf
