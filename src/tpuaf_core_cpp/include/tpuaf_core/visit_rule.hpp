// The one definition of a visit (docs/RUNTIMES.md "Visits"), for every runtime, the monitor and
// bag analysis: an arrival within visit_radius [m] of a vertex after the robot has driven there.
// A robot is armed for vertex v once it has been farther than 2 x visit_radius from v since its
// last visit of v (re-arm hysteresis); an arrival within the radius while armed is a visit and
// disarms v. Standing, dwelling or wobbling within the radius never counts again.
#pragma once

#include <vector>

#include "tpuaf_core/perception.hpp"
#include "tpuaf_core/vertex_geometry.hpp"

namespace tpuaf {

// [m] default visit radius: a TurtleBot3 stops this close to the vertex in a 0.5 m aisle.
constexpr double kDefaultVisitRadiusM = 0.15;
// Re-arm distance, in visit radii.
constexpr double kRearmFactor = 2.0;

class VisitRule {
 public:
  // positions: the vertices [m] (n x 2); visit_radius_m > 0.
  VisitRule(Points positions, double visit_radius_m);

  // The robot stands at (x, y) [m] at the start; the start vertex counts as its first visit:
  // it and every vertex within the re-arm distance are disarmed, the others armed.
  void start(int vertex, double x, double y);
  // Nothing visited yet: every vertex disarmed until the robot is seen far from it.
  void reset();
  // A position [m] of the robot: arms every vertex farther than the re-arm distance.
  void observe(double x, double y);
  // The robot ends a leg at `vertex` at (x, y) [m]: observe, then true (a visit, which
  // disarms the vertex) if within the radius and armed; false: not a visit (a dwell).
  bool arrive(int vertex, double x, double y);
  // Is (x, y) [m] within the visit radius of `vertex`?
  bool within(int vertex, double x, double y) const;
  bool armed(int vertex) const;
  double radius() const { return radius_; }
  int num_vertices() const { return static_cast<int>(armed_.size()); }
  long long visits() const { return visits_; }
  const Points& positions() const { return positions_; }  // [m] the vertices

 private:
  void check(int vertex) const;
  double distance(int vertex, double x, double y) const;

  Points positions_;
  double radius_;
  double rearm_sq_;  // [m^2] squared re-arm distance
  std::vector<char> armed_;
  // The disarmed vertices, each once: only these can change in observe(), so it costs
  // O(disarmed), not O(vertices), on a big map.
  std::vector<int> disarmed_;
  long long visits_ = 0;
};

}  // namespace tpuaf
