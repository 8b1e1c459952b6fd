// Probabilistic perception model of the TPUAF paper (SPEC section 3, Eq. 1).
#pragma once

#include <Eigen/Dense>

namespace tpuaf {

using Points = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;

// Perception of one target at distance s [m] by a sensor with peak G and radius r [m] (Eq. 1):
// M = G (s^2 - r^2)^2 / r^4 for s <= r, else 0.
double perception(double distance_m, double peak, double radius_m);

// Perception of every target (rows of `targets`, metres) by every robot (rows of `robots`).
// `peaks` and `radii_m` hold one value per robot. Returns a targets x robots matrix.
Eigen::MatrixXd perception_matrix(const Points& targets, const Points& robots,
                                  const Eigen::VectorXd& peaks, const Eigen::VectorXd& radii_m);

// Sum over robots of the perception of each target (the coverage term of Eq. 2).
Eigen::VectorXd total_perception(const Points& targets, const Points& robots,
                                 const Eigen::VectorXd& peaks, const Eigen::VectorXd& radii_m);

}  // namespace tpuaf
