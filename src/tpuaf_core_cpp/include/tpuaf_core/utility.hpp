// TPUAF utility of candidate vertices for one robot (SPEC section 4, paper Eq. 6-14).
#pragma once

#include <vector>

#include "tpuaf_core/graph.hpp"
#include "tpuaf_core/uncertainty.hpp"

namespace tpuaf {

enum class UtilityForm { kEq13, kEq14 };

struct UtilityQuery {
  double now_s = 0;             // current time [s]
  int current_vertex = 0;       // p_i
  std::vector<int> candidates;  // p_j (neighbours for the faithful TPUAF)
  double speed_mps = 1.0;       // Vel(i), average speed [m/s] (Eq. 6)
  bool use_path_length = false; // true: d = shortest path (any-vertex variant), else edge (Eq. 7)
  UtilityForm form = UtilityForm::kEq13;
  // Per vertex of the graph (size n):
  Eigen::VectorXd last_visit_s;         // t_last: latest known visit by any robot [s]
  Eigen::VectorXd estimate;             // this robot's estimate of X now
  Eigen::VectorXd announced_arrival_s;  // earliest announced arrival of another robot (+inf: none)
  Eigen::VectorXd announced_travel_s;   // that robot's announced travel time dt'_j [s] (0: none)
};

struct UtilityResult {
  Eigen::VectorXd utility;       // U_j (Eq. 13 or 14)
  Eigen::VectorXd travel_time_s; // dt_j (Eq. 6)
  Eigen::VectorXd arrival_s;     // t_end_j (Eq. 8)
  Eigen::VectorXd idleness_s;    // I_j = |t_end - t_sta| (Eq. 10)
  Eigen::VectorXd predicted;     // X^_j(t_end) (step 4)
};

// importance: C_j per vertex; model: growth law used for the prediction.
UtilityResult tpuaf_utilities(const PatrolGraph& graph, const Eigen::VectorXd& importance,
                              const UncertaintyModel& model, const UtilityQuery& query);

}  // namespace tpuaf
