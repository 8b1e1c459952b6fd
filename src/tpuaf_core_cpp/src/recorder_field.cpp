// The ground-truth field of GroundTruthRecorder (recorder.hpp): the coverage of the targets
// by moving robots and the field's advance over one chunk of linear motion. Same arithmetic
// as UncertaintyField::advance_linear, step for step; the targets no robot covers during a
// substep (most of a big map) share one rate when every target has the same importance C,
// and are then advanced by one loop without their (zero) coverage.
#include <algorithm>
#include <cmath>
#include <limits>

#include "tpuaf_core/recorder.hpp"

namespace tpuaf {

void GroundTruthRecorder::coverage(const Points& start, const Points& end, double fraction,
                                   Eigen::VectorXd& out, std::vector<int>& touched) {
  // total_perception (Eq. 1 summed over robots) at start + fraction (end - start), robot by
  // robot in index order as there, over the targets within one cell of the robot only.
  if (out.size() != n_vertices_) {
    out.setZero(n_vertices_);
    touched.clear();
  }
  for (int j : touched) out[j] = 0.0;  // the rest is zero already
  touched.clear();
  cover_at_ = start + fraction * (end - start);
  for (Eigen::Index i = 0; i < cover_at_.rows(); ++i) {
    const double r2 = radii_[i] * radii_[i];
    const double scale = peaks_[i] / (r2 * r2);
    const double qx = cover_at_(i, 0), qy = cover_at_(i, 1);
    const double fx = std::floor((qx - target_x0_) / target_cell_);
    const double fy = std::floor((qy - target_y0_) / target_cell_);
    if (!(fx >= -1 && fx <= target_nx_ && fy >= -1 && fy <= target_ny_)) continue;  // far away
    const int cx = static_cast<int>(fx), cy = static_cast<int>(fy);
    for (int gx = std::max(cx - 1, 0); gx <= std::min(cx + 1, target_nx_ - 1); ++gx) {
      for (int gy = std::max(cy - 1, 0); gy <= std::min(cy + 1, target_ny_ - 1); ++gy) {
        const int c = gx * target_ny_ + gy;
        for (int k = target_start_[c]; k < target_start_[c + 1]; ++k) {
          const double dx = target_xy_[2 * static_cast<std::size_t>(k)] - qx;
          const double dy = target_xy_[2 * static_cast<std::size_t>(k) + 1] - qy;
          const double s2 = dx * dx + dy * dy;
          if (s2 <= r2) {
            const int j = target_index_[k];
            const double d = s2 - r2;
            out[j] += scale * d * d;
            touched.push_back(j);
          }
        }
      }
    }
  }
}

void GroundTruthRecorder::gather_covered() {
  // covered_: the targets touched at the substep's start, middle or end, each once.
  covered_mark_.resize(static_cast<std::size_t>(n_vertices_), 0);
  covered_.clear();
  for (const std::vector<int>* list : {&touched_left_, &touched_mid_, &touched_right_}) {
    for (int j : *list) {
      char& mark = covered_mark_[static_cast<std::size_t>(j)];
      if (!mark) covered_.push_back(j);
      mark = 1;
    }
  }
  for (int j : covered_) covered_mark_[static_cast<std::size_t>(j)] = 0;
}

void GroundTruthRecorder::advance_linear(double dt, const Points& start, const Points& end) {
  // UncertaintyField::advance_linear, step for step (Simpson's rule per substep, exact
  // constant-coverage solution), with the coverage through the target cells.
  const int steps = std::max(1, static_cast<int>(std::ceil(dt / max_substep_)));
  const double h = dt / steps;
  const UncertaintyModel& model = field_.model();
  const Eigen::VectorXd& importance = field_.importance();
  const bool affine = model.is_affine();
  const double a0 = model.growth_coefficients[0];
  const double a1 = model.growth_coefficients.size() > 1 ? model.growth_coefficients[1] : 0.0;
  if (uniform_importance_ < 0) {
    uniform_importance_ = (importance.array() == importance[0]).all() ? 1 : 0;
  }
  const bool shared_rate = affine && h > 0 && n_vertices_ > 0 && uniform_importance_ == 1;
  // One exp pair per distinct rate (UncertaintyModel::evolve's affine branch, remembered).
  double cached_rate = std::numeric_limits<double>::quiet_NaN(), growth = 0, offset = 0;
  bool saturated = false;
  auto next_value = [&](double x0, double rate) {
    if (!affine || !(h > 0)) return model.evolve(x0, rate, h);
    if (!(rate == cached_rate)) {
      cached_rate = rate;
      const double z = a1 * rate * h;
      saturated = z > 700;
      if (!saturated) {
        growth = std::exp(z);
        const double ratio = std::abs(z) < 1e-12 ? 1.0 + 0.5 * z : std::expm1(z) / z;
        offset = a0 * rate * h * ratio;
      }
    }
    if (saturated) return model.max_value;
    const double x = x0 * growth + offset;
    return !(x > 0) ? 0.0 : std::min(x, model.max_value);
  };
  auto rate_of = [&](int j) {
    const double mean = (cover_left_[j] + 4.0 * cover_mid_[j] + cover_right_[j]) / 6.0;
    return importance[j] - mean;
  };
  coverage(start, end, 0.0, cover_left_, touched_left_);
  for (int k = 0; k < steps; ++k) {
    coverage(start, end, (k + 0.5) / steps, cover_mid_, touched_mid_);
    coverage(start, end, (k + 1.0) / steps, cover_right_, touched_right_);
    if (!shared_rate) {
      for (Eigen::Index j = 0; j < values_.size(); ++j) {
        values_[j] = next_value(values_[j], rate_of(static_cast<int>(j)));
      }
    } else {
      gather_covered();
      covered_value_.resize(covered_.size());
      for (std::size_t i = 0; i < covered_.size(); ++i) {
        covered_value_[i] = next_value(values_[covered_[i]], rate_of(covered_[i]));
      }
      // Every other target: zero coverage, so the rate C - (0 + 4 * 0 + 0) / 6 of them all.
      next_value(0.0, importance[0] - (0.0 + 4.0 * 0.0 + 0.0) / 6.0);
      if (saturated) {
        values_.setConstant(model.max_value);
      } else {
        const double g = growth, o = offset, top = model.max_value;
        double* v = values_.data();
        for (int j = 0; j < n_vertices_; ++j) {
          const double x = v[j] * g + o;
          v[j] = !(x > 0) ? 0.0 : std::min(x, top);
        }
      }
      for (std::size_t i = 0; i < covered_.size(); ++i) values_[covered_[i]] = covered_value_[i];
    }
    cover_left_.swap(cover_right_);
    touched_left_.swap(touched_right_);
  }
}

}  // namespace tpuaf
