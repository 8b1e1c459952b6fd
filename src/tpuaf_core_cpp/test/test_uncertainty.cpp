// Uncertainty field (Eq. 2-3): closed-form growth and decay, clamping, prediction.
#include <gtest/gtest.h>

#include <cmath>

#include "tpuaf_core/uncertainty.hpp"

namespace tpuaf {
namespace {

UncertaintyField one_target(double x0, double importance, UncertaintyModel model = {}) {
  Points targets(1, 2);
  targets << 0, 0;
  return UncertaintyField(targets, Eigen::VectorXd::Constant(1, importance),
                          Eigen::VectorXd::Constant(1, x0), model);
}

TEST(Uncertainty, UncoveredAffineGrowthMatchesTheClosedForm) {
  // dX/dt = C (a0 + a1 X): X(t) = (X0 + a0/a1) exp(a1 C t) - a0/a1.
  UncertaintyField field = one_target(0.5, 0.01);
  field.advance_uncovered(100.0);
  const double expected = (0.5 + 1.0 / 0.6) * std::exp(0.6 * 0.01 * 100.0) - 1.0 / 0.6;
  EXPECT_NEAR(field.values()(0), expected, 1e-9);
}

TEST(Uncertainty, CoveredTargetDecaysAndNeverGoesNegative) {
  UncertaintyField field = one_target(1.0, 0.01);
  Points robot(1, 2);
  robot << 0, 0;
  Eigen::VectorXd peaks = Eigen::VectorXd::Constant(1, 1.0);
  Eigen::VectorXd radii = Eigen::VectorXd::Constant(1, 5.0);
  field.advance(1.0, robot, peaks, radii);
  EXPECT_LT(field.values()(0), 1.0);
  field.advance(1000.0, robot, peaks, radii);
  EXPECT_GE(field.values()(0), 0.0);
  EXPECT_FALSE(std::isnan(field.values()(0)));
}

TEST(Uncertainty, NonAffineGrowthUsesRk4AndIsMonotone) {
  UncertaintyModel model;
  model.growth_coefficients = {1.0, 0.0, 0.5};
  ASSERT_FALSE(model.is_affine());
  UncertaintyField field = one_target(0.0, 0.01, model);
  double previous = 0.0;
  for (int k = 0; k < 10; ++k) {
    field.advance_uncovered(10.0);
    EXPECT_GT(field.values()(0), previous);
    previous = field.values()(0);
  }
}

TEST(Uncertainty, ValuesAreClampedToTheMaximum) {
  UncertaintyModel model;
  model.max_value = 2.0;
  UncertaintyField field = one_target(1.0, 1.0, model);
  field.advance_uncovered(1e6);
  EXPECT_DOUBLE_EQ(field.values()(0), 2.0);
}

TEST(Uncertainty, PredictionEqualsAdvancingWithoutCoverage) {
  UncertaintyField field = one_target(0.2, 0.02);
  const double predicted = field.predict_one(0, 50.0);
  field.advance_uncovered(50.0);
  EXPECT_NEAR(predicted, field.values()(0), 1e-12);
}

TEST(Uncertainty, NegativeGrowthCoefficientIsRefused) {
  UncertaintyModel model;
  model.growth_coefficients = {1.0, -0.1};
  EXPECT_THROW(model.validate(), std::invalid_argument);
}

}  // namespace
}  // namespace tpuaf
