#include "tpuaf_core/utility.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace tpuaf {

UtilityResult tpuaf_utilities(const PatrolGraph& graph, const Eigen::VectorXd& importance,
                              const UncertaintyModel& model, const UtilityQuery& q) {
  const int n = graph.num_vertices();
  graph.check_vertex(q.current_vertex);
  if (!(q.speed_mps > 0)) throw std::invalid_argument("average speed must be > 0 m/s");
  auto check_size = [n](const Eigen::VectorXd& v, const char* name) {
    if (v.size() != n) {
      throw std::invalid_argument(std::string(name) + " needs one value per vertex (" +
                                  std::to_string(n) + "), got " + std::to_string(v.size()));
    }
  };
  check_size(importance, "importance");
  check_size(q.last_visit_s, "last_visit_s");
  check_size(q.estimate, "estimate");
  check_size(q.announced_arrival_s, "announced_arrival_s");
  check_size(q.announced_travel_s, "announced_travel_s");

  const std::size_t m = q.candidates.size();
  UtilityResult r;
  r.utility.resize(m);
  r.travel_time_s.resize(m);
  r.arrival_s.resize(m);
  r.idleness_s.resize(m);
  r.predicted.resize(m);
  const double mean_edge = graph.mean_edge_length();
  const int i = q.current_vertex;
  // The any-vertex variant reads one row of shortest paths from i (a search, or the cache's).
  const std::shared_ptr<const DistanceRow> from_i = q.use_path_length ? graph.row(i) : nullptr;
  for (std::size_t k = 0; k < m; ++k) {
    const int j = q.candidates[k];
    graph.check_vertex(j);
    // Eq. 7: d_ij = max(c_ij, c_avg); the any-vertex variant uses the shortest-path length.
    const double c = q.use_path_length ? from_i->distance[j] : graph.edge_length(i, j);
    const double d = std::max(c, mean_edge);
    const double dt = d / q.speed_mps;  // Eq. 6
    const double t_end = q.now_s + dt;  // Eq. 8
    // Eq. 9-10: an announced arrival of another robot before t_end counts as the last visit.
    const double announced = q.announced_arrival_s[j];
    const bool visited_before = std::isfinite(announced) && announced <= t_end;
    const double t_sta =
        visited_before ? std::max(q.last_visit_s[j], announced) : q.last_visit_s[j];
    const double idle = std::abs(t_end - t_sta);
    // Step 4: predicted uncertainty at arrival; an announced earlier visit clears it to 0.
    const double x_hat =
        visited_before ? model.evolve(0.0, importance[j], t_end - std::max(announced, q.now_s))
                       : model.evolve(q.estimate[j], importance[j], dt);
    double u;
    if (q.form == UtilityForm::kEq13) {
      u = x_hat * idle / dt;  // Eq. 13
    } else {
      // Eq. 14: |X^_j + (I/dt - dt'/dt) X^_i|, X^_i the current vertex predicted at t_end.
      const double x_current = model.evolve(q.estimate[i], importance[i], dt);
      const double dt_other = std::isfinite(announced) ? q.announced_travel_s[j] : 0.0;
      u = std::abs(x_hat + (idle / dt - dt_other / dt) * x_current);
    }
    r.utility[k] = u;
    r.travel_time_s[k] = dt;
    r.arrival_s[k] = t_end;
    r.idleness_s[k] = idle;
    r.predicted[k] = x_hat;
  }
  return r;
}

}  // namespace tpuaf
