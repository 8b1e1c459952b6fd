// Uncertainty field of the targets (SPEC section 3, paper Eq. 2-3).
//   dX_j/dt = (C_j - sum_i M_i(p_j, q_i)) * g(X_j),  g(X) = sum_l a_l X^l,  X_j >= 0.
#pragma once

#include <vector>

#include "tpuaf_core/perception.hpp"

namespace tpuaf {

struct UncertaintyModel {
  // Coefficients a_0..a_L of g(X) (a_l >= 0). Defaults: g(X) = 1 + 0.6 X, see docs/MODEL.md.
  std::vector<double> growth_coefficients{1.0, 0.6};
  // Values are clamped to [0, max_value] so that they never overflow to inf.
  double max_value = 1e12;
  // Largest ODE step [s] used when g is not affine (RK4 with clamping).
  double max_ode_step_s = 0.05;

  bool is_affine() const;
  double g(double x) const;
  void validate() const;
  // X after `dt_s` seconds at constant net rate `rate` = C - sum M, starting at x0.
  // Exact for affine g (closed form), RK4 otherwise.
  double evolve(double x0, double rate, double dt_s) const;
};

class UncertaintyField {
 public:
  // targets: positions [m]; importance: C_j >= 0; initial: X0_j >= 0.
  UncertaintyField(const Points& targets, const Eigen::VectorXd& importance,
                   const Eigen::VectorXd& initial, UncertaintyModel model = {});

  int size() const { return static_cast<int>(values_.size()); }
  const Eigen::VectorXd& values() const { return values_; }
  void set_values(const Eigen::VectorXd& values);
  const Eigen::VectorXd& importance() const { return importance_; }
  const Points& targets() const { return targets_; }
  const UncertaintyModel& model() const { return model_; }

  // Advance by dt_s seconds with robots held at `robots` (coverage constant over dt).
  void advance(double dt_s, const Points& robots, const Eigen::VectorXd& peaks,
               const Eigen::VectorXd& radii_m);
  // Advance by dt_s with robots moving linearly from `start` to `end` (rows, m). Split into
  // substeps of at most max_substep_s; each uses Simpson's rule for the mean coverage over the
  // substep and the exact constant-coverage solution.
  void advance_linear(double dt_s, const Points& start, const Points& end,
                      const Eigen::VectorXd& peaks, const Eigen::VectorXd& radii_m,
                      double max_substep_s = 0.25);
  // Advance by dt_s with no robot covering any target.
  void advance_uncovered(double dt_s);
  // Advance with a given total coverage per target (sum of M, from any source).
  void advance_with_coverage(double dt_s, const Eigen::VectorXd& coverage);

  // X_j after horizon_s more seconds without coverage (horizon_s >= 0), for every target.
  Eigen::VectorXd predict(double horizon_s) const;
  // The same for one target.
  double predict_one(int target, double horizon_s) const;

 private:
  Points targets_;
  Eigen::VectorXd importance_;
  Eigen::VectorXd values_;
  UncertaintyModel model_;
};

}  // namespace tpuaf
