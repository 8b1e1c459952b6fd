#include "tpuaf_core/uncertainty.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace tpuaf {

bool UncertaintyModel::is_affine() const {
  for (std::size_t l = 2; l < growth_coefficients.size(); ++l) {
    if (growth_coefficients[l] != 0.0) return false;
  }
  return true;
}

double UncertaintyModel::g(double x) const {
  double value = 0.0;  // Horner evaluation of sum_l a_l x^l
  for (auto it = growth_coefficients.rbegin(); it != growth_coefficients.rend(); ++it) {
    value = value * x + *it;
  }
  return value;
}

void UncertaintyModel::validate() const {
  if (growth_coefficients.empty()) {
    throw std::invalid_argument("growth_coefficients must hold at least a_0");
  }
  for (std::size_t l = 0; l < growth_coefficients.size(); ++l) {
    if (!(growth_coefficients[l] >= 0) || !std::isfinite(growth_coefficients[l])) {
      throw std::invalid_argument("growth coefficient a_" + std::to_string(l) +
                                  " must be finite and >= 0");
    }
  }
  if (!(max_value > 0)) throw std::invalid_argument("max_value must be > 0");
  if (!(max_ode_step_s > 0)) throw std::invalid_argument("max_ode_step_s must be > 0 s");
}

// expm1(z)/z, continuous at z = 0.
static double expm1_over(double z) { return std::abs(z) < 1e-12 ? 1.0 + 0.5 * z : std::expm1(z) / z; }

double UncertaintyModel::evolve(double x0, double rate, double dt_s) const {
  if (dt_s <= 0) return x0;
  double x;
  if (is_affine()) {
    // Exact solution of dX/dt = rate (a0 + a1 X): X = X0 e^z + a0 rate dt (e^z - 1)/z, z = a1 rate dt.
    const double a0 = growth_coefficients[0];
    const double a1 = growth_coefficients.size() > 1 ? growth_coefficients[1] : 0.0;
    const double z = a1 * rate * dt_s;
    if (z > 700) return max_value;  // e^z would overflow a double
    x = x0 * std::exp(z) + a0 * rate * dt_s * expm1_over(z);
    // With rate < 0 the clamp at 0 is absorbing (g(0) = a0 >= 0), so clamping the end value is exact.
  } else {
    // RK4 on steps of at most max_ode_step_s, clamped to [0, max_value] after each step.
    const int steps = static_cast<int>(std::ceil(dt_s / max_ode_step_s));
    const double h = dt_s / steps;
    x = x0;
    for (int k = 0; k < steps; ++k) {
      const double k1 = rate * g(x);
      const double k2 = rate * g(std::max(0.0, x + 0.5 * h * k1));
      const double k3 = rate * g(std::max(0.0, x + 0.5 * h * k2));
      const double k4 = rate * g(std::max(0.0, x + h * k3));
      x = x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4);
      if (!(x > 0)) x = 0.0;  // also catches NaN
      if (x >= max_value) return max_value;
    }
  }
  if (!(x > 0)) return 0.0;
  return std::min(x, max_value);
}

UncertaintyField::UncertaintyField(const Points& targets, const Eigen::VectorXd& importance,
                                   const Eigen::VectorXd& initial, UncertaintyModel model)
    : targets_(targets), importance_(importance), values_(initial), model_(std::move(model)) {
  model_.validate();
  if (importance.size() != targets.rows() || initial.size() != targets.rows()) {
    throw std::invalid_argument("need one importance C and one initial X0 per target: got " +
                                std::to_string(targets.rows()) + " targets, " +
                                std::to_string(importance.size()) + " C, " +
                                std::to_string(initial.size()) + " X0");
  }
  for (Eigen::Index j = 0; j < targets.rows(); ++j) {
    if (!(importance[j] >= 0) || !std::isfinite(importance[j])) {
      throw std::invalid_argument("target " + std::to_string(j) + ": importance C must be >= 0");
    }
    if (!(initial[j] >= 0) || !std::isfinite(initial[j])) {
      throw std::invalid_argument("target " + std::to_string(j) + ": initial X0 must be >= 0");
    }
  }
}

void UncertaintyField::set_values(const Eigen::VectorXd& values) {
  if (values.size() != values_.size()) {
    throw std::invalid_argument("expected " + std::to_string(values_.size()) + " values, got " +
                                std::to_string(values.size()));
  }
  for (Eigen::Index j = 0; j < values.size(); ++j) {
    if (!(values[j] >= 0) || !std::isfinite(values[j])) {
      throw std::invalid_argument("target " + std::to_string(j) + ": X must be finite and >= 0");
    }
  }
  values_ = values;
}

void UncertaintyField::advance_with_coverage(double dt_s, const Eigen::VectorXd& coverage) {
  if (!(dt_s >= 0)) throw std::invalid_argument("dt must be >= 0 s");
  if (coverage.size() != values_.size()) {
    throw std::invalid_argument("need one coverage value per target");
  }
  for (Eigen::Index j = 0; j < values_.size(); ++j) {
    values_[j] = model_.evolve(values_[j], importance_[j] - coverage[j], dt_s);
  }
}

void UncertaintyField::advance(double dt_s, const Points& robots, const Eigen::VectorXd& peaks,
                               const Eigen::VectorXd& radii_m) {
  advance_with_coverage(dt_s, total_perception(targets_, robots, peaks, radii_m));
}

void UncertaintyField::advance_linear(double dt_s, const Points& start, const Points& end,
                                      const Eigen::VectorXd& peaks, const Eigen::VectorXd& radii_m,
                                      double max_substep_s) {
  if (!(dt_s >= 0)) throw std::invalid_argument("dt must be >= 0 s");
  if (!(max_substep_s > 0)) throw std::invalid_argument("max_substep_s must be > 0 s");
  if (start.rows() != end.rows()) {
    throw std::invalid_argument("start and end positions need the same number of robots");
  }
  if (dt_s == 0) return;
  const int steps = std::max(1, static_cast<int>(std::ceil(dt_s / max_substep_s)));
  const double h = dt_s / steps;
  Points at(start.rows(), 2);
  auto coverage_at = [&](double fraction) {
    at = start + fraction * (end - start);
    return total_perception(targets_, at, peaks, radii_m);
  };
  Eigen::VectorXd left = coverage_at(0.0);
  for (int k = 0; k < steps; ++k) {
    const Eigen::VectorXd mid = coverage_at((k + 0.5) / steps);
    const Eigen::VectorXd right = coverage_at((k + 1.0) / steps);
    const Eigen::VectorXd mean = (left + 4.0 * mid + right) / 6.0;  // Simpson's rule
    for (Eigen::Index j = 0; j < values_.size(); ++j) {
      values_[j] = model_.evolve(values_[j], importance_[j] - mean[j], h);
    }
    left = right;
  }
}

void UncertaintyField::advance_uncovered(double dt_s) {
  advance_with_coverage(dt_s, Eigen::VectorXd::Zero(values_.size()));
}

Eigen::VectorXd UncertaintyField::predict(double horizon_s) const {
  if (!(horizon_s >= 0)) throw std::invalid_argument("prediction horizon must be >= 0 s");
  Eigen::VectorXd out(values_.size());
  for (Eigen::Index j = 0; j < values_.size(); ++j) {
    out[j] = model_.evolve(values_[j], importance_[j], horizon_s);
  }
  return out;
}

double UncertaintyField::predict_one(int target, double horizon_s) const {
  if (target < 0 || target >= size()) {
    throw std::out_of_range("unknown target " + std::to_string(target) + " (have " +
                            std::to_string(size()) + ")");
  }
  if (!(horizon_s >= 0)) throw std::invalid_argument("prediction horizon must be >= 0 s");
  return model_.evolve(values_[target], importance_[target], horizon_s);
}

}  // namespace tpuaf
