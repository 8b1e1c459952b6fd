#include "tpuaf_core/perception.hpp"

#include <stdexcept>
#include <string>

namespace tpuaf {

double perception(double distance_m, double peak, double radius_m) {
  if (!(radius_m > 0)) throw std::invalid_argument("sensing radius must be > 0 m");
  if (!(distance_m <= radius_m)) return 0.0;
  const double r2 = radius_m * radius_m;
  const double d = distance_m * distance_m - r2;
  return peak * d * d / (r2 * r2);
}

static void check_sensors(const Points& robots, const Eigen::VectorXd& peaks,
                          const Eigen::VectorXd& radii_m) {
  if (peaks.size() != robots.rows() || radii_m.size() != robots.rows()) {
    throw std::invalid_argument("need one peak and one radius per robot: got " +
                                std::to_string(robots.rows()) + " robots, " +
                                std::to_string(peaks.size()) + " peaks, " +
                                std::to_string(radii_m.size()) + " radii");
  }
  for (Eigen::Index i = 0; i < robots.rows(); ++i) {
    if (!(radii_m[i] > 0)) {
      throw std::invalid_argument("robot " + std::to_string(i) + ": sensing radius must be > 0 m");
    }
    if (!(peaks[i] >= 0)) {
      throw std::invalid_argument("robot " + std::to_string(i) + ": peak G must be >= 0");
    }
  }
}

Eigen::MatrixXd perception_matrix(const Points& targets, const Points& robots,
                                  const Eigen::VectorXd& peaks, const Eigen::VectorXd& radii_m) {
  check_sensors(robots, peaks, radii_m);
  Eigen::MatrixXd m(targets.rows(), robots.rows());
  for (Eigen::Index i = 0; i < robots.rows(); ++i) {
    const double r2 = radii_m[i] * radii_m[i];
    const double scale = peaks[i] / (r2 * r2);
    for (Eigen::Index j = 0; j < targets.rows(); ++j) {
      const double dx = targets(j, 0) - robots(i, 0);
      const double dy = targets(j, 1) - robots(i, 1);
      const double s2 = dx * dx + dy * dy;
      const double d = s2 - r2;
      m(j, i) = s2 <= r2 ? scale * d * d : 0.0;
    }
  }
  return m;
}

Eigen::VectorXd total_perception(const Points& targets, const Points& robots,
                                 const Eigen::VectorXd& peaks, const Eigen::VectorXd& radii_m) {
  check_sensors(robots, peaks, radii_m);
  Eigen::VectorXd total = Eigen::VectorXd::Zero(targets.rows());
  for (Eigen::Index i = 0; i < robots.rows(); ++i) {
    const double r2 = radii_m[i] * radii_m[i];
    const double scale = peaks[i] / (r2 * r2);
    const double qx = robots(i, 0), qy = robots(i, 1);
    for (Eigen::Index j = 0; j < targets.rows(); ++j) {
      const double dx = targets(j, 0) - qx;
      const double dy = targets(j, 1) - qy;
      const double s2 = dx * dx + dy * dy;
      if (s2 <= r2) {
        const double d = s2 - r2;
        total[j] += scale * d * d;
      }
    }
  }
  return total;
}

}  // namespace tpuaf
