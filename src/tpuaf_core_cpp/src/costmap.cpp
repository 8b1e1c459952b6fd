#include "tpuaf_core/costmap.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "grid_geometry.hpp"

namespace tpuaf {

using grid::clamp_cell;
using grid::finite;
using grid::kInf;
using grid::kTol;

namespace {

// Squared distance transform of one line: d[x] = min_q f[q] + (x - q)^2, by the lower envelope
// of the parabolas rooted at the finite samples. v, z: scratch of n and n + 1 entries.
void edt_line(const double* f, int n, double* d, int* v, double* z) {
  int k = -1;
  for (int q = 0; q < n; ++q) {
    if (!(f[q] < kInf)) continue;
    const double fq = f[q] + static_cast<double>(q) * q;
    double s = -kInf;
    while (k >= 0) {
      const int p = v[k];
      s = (fq - (f[p] + static_cast<double>(p) * p)) / (2.0 * (q - p));
      if (s <= z[k]) {
        --k;
        s = -kInf;
      } else {
        break;
      }
    }
    ++k;
    v[k] = q;
    z[k] = s;
  }
  if (k < 0) {
    std::fill(d, d + n, kInf);
    return;
  }
  z[k + 1] = kInf;
  int j = 0;
  for (int x = 0; x < n; ++x) {
    while (z[j + 1] < x) ++j;
    const double dx = x - v[j];
    d[x] = dx * dx + f[v[j]];
  }
}

void check_inputs(const GridMask& occupied, double resolution_m, double origin_x_m,
                  double origin_y_m, const CostmapSpec& spec, double planning_resolution_m) {
  if (occupied.rows() == 0 || occupied.cols() == 0)
    throw std::invalid_argument("Costmap: the occupancy grid is empty");
  if (!finite(resolution_m) || resolution_m <= 0)
    throw std::invalid_argument("Costmap: resolution_m must be > 0, got " +
                                std::to_string(resolution_m));
  if (!finite(origin_x_m) || !finite(origin_y_m))
    throw std::invalid_argument("Costmap: the origin must be finite");
  if (!finite(spec.inscribed_radius_m) || spec.inscribed_radius_m < 0)
    throw std::invalid_argument("Costmap: inscribed_radius_m must be >= 0");
  if (!finite(spec.inflation_radius_m) || spec.inflation_radius_m < spec.inscribed_radius_m)
    throw std::invalid_argument("Costmap: inflation_radius_m must be >= inscribed_radius_m");
  if (!finite(spec.cost_scaling_per_m) || spec.cost_scaling_per_m < 0)
    throw std::invalid_argument("Costmap: cost_scaling_per_m must be >= 0");
  if (!finite(spec.cost_weight) || spec.cost_weight < 0)
    throw std::invalid_argument("Costmap: cost_weight must be >= 0");
  if (!finite(planning_resolution_m) || planning_resolution_m < 0)
    throw std::invalid_argument("Costmap: planning_resolution_m must be >= 0 (0: the map's)");
}

// Squared distance [cells^2] from each cell of the grid padded by one occupied ring (the
// outside of the map; (mh + 2) x (mw + 2), row-major) to the nearest occupied square's edge.
std::vector<double> squared_gaps(const std::vector<std::uint8_t>& occ, int mw, int mh) {
  // Gap between squares = centre distance to the occupied cells dilated by one cell (3 x 3),
  // since min over |e| <= 1 of (d - e)^2 = max(|d| - 1, 0)^2 per axis. Padded by one occupied
  // ring: the outside of the map.
  const int pw = mw + 2, ph = mh + 2;
  auto padded_occ = [&](int pr, int pc) {
    if (pr <= 0 || pc <= 0 || pr >= ph - 1 || pc >= pw - 1) return true;
    return occ[static_cast<std::size_t>(pr - 1) * mw + (pc - 1)] != 0;
  };
  std::vector<double> f(static_cast<std::size_t>(pw) * ph, kInf);
  for (int pr = 0; pr < ph; ++pr) {
    for (int pc = 0; pc < pw; ++pc) {
      if (!padded_occ(pr, pc)) continue;
      for (int dr = -1; dr <= 1; ++dr)
        for (int dc = -1; dc <= 1; ++dc) {
          const int r = pr + dr, c = pc + dc;
          if (r >= 0 && c >= 0 && r < ph && c < pw) f[static_cast<std::size_t>(r) * pw + c] = 0.0;
        }
    }
  }
  const int n = std::max(pw, ph);
  std::vector<double> line(n), out(n), z(n + 1);
  std::vector<int> v(n);
  for (int pc = 0; pc < pw; ++pc) {  // along columns
    for (int pr = 0; pr < ph; ++pr) line[pr] = f[static_cast<std::size_t>(pr) * pw + pc];
    edt_line(line.data(), ph, out.data(), v.data(), z.data());
    for (int pr = 0; pr < ph; ++pr) f[static_cast<std::size_t>(pr) * pw + pc] = out[pr];
  }
  for (int pr = 0; pr < ph; ++pr) {  // along rows
    double* row = f.data() + static_cast<std::size_t>(pr) * pw;
    edt_line(row, pw, out.data(), v.data(), z.data());
    std::copy(out.begin(), out.begin() + pw, row);
  }
  return f;
}

}  // namespace

Costmap::Costmap(const GridMask& occupied, double resolution_m, double origin_x_m,
                 double origin_y_m, const CostmapSpec& spec, double planning_resolution_m)
    : spec_(spec) {
  check_inputs(occupied, resolution_m, origin_x_m, origin_y_m, spec, planning_resolution_m);

  mh_ = static_cast<int>(occupied.rows());
  mw_ = static_cast<int>(occupied.cols());
  mres_ = resolution_m;
  ox_ = origin_x_m;
  oy_ = origin_y_m;
  k_ = std::max(1, static_cast<int>(std::lround(planning_resolution_m / resolution_m)));
  res_ = k_ * mres_;
  w_ = (mw_ + k_ - 1) / k_;
  h_ = (mh_ + k_ - 1) / k_;

  occ_.resize(static_cast<std::size_t>(mw_) * mh_);
  for (int r = 0; r < mh_; ++r)
    for (int c = 0; c < mw_; ++c) occ_[static_cast<std::size_t>(r) * mw_ + c] = occupied(r, c);

  const int pw = mw_ + 2;
  const std::vector<double> f = squared_gaps(occ_, mw_, mh_);
  dist_.resize(occ_.size());
  std::vector<float> fine_cost(occ_.size());
  std::vector<std::uint8_t> fine_lethal(occ_.size());
  for (int r = 0; r < mh_; ++r) {
    for (int c = 0; c < mw_; ++c) {
      const std::size_t i = static_cast<std::size_t>(r) * mw_ + c;
      const double d = std::sqrt(f[static_cast<std::size_t>(r + 1) * pw + c + 1]) * mres_;
      dist_[i] = static_cast<float>(d);
      fine_lethal[i] = d < spec_.inscribed_radius_m - kTol;
      fine_cost[i] = static_cast<float>(cost_at_distance(d));
    }
  }

  // Planning cells: worst of their k x k map cells; a block overhanging the map is lethal.
  cost_.assign(static_cast<std::size_t>(w_) * h_, 0.0f);
  lethal_.assign(cost_.size(), 0);
  for (int R = 0; R < h_; ++R) {
    for (int C = 0; C < w_; ++C) {
      const std::size_t i = static_cast<std::size_t>(R) * w_ + C;
      if ((R + 1) * k_ > mh_ || (C + 1) * k_ > mw_) {
        lethal_[i] = 1;
        cost_[i] = 1.0f;
        continue;
      }
      float worst = 0.0f;
      std::uint8_t leth = 0;
      for (int r = R * k_; r < (R + 1) * k_; ++r)
        for (int c = C * k_; c < (C + 1) * k_; ++c) {
          const std::size_t j = static_cast<std::size_t>(r) * mw_ + c;
          worst = std::max(worst, fine_cost[j]);
          leth |= fine_lethal[j];
        }
      lethal_[i] = leth;
      cost_[i] = leth ? 1.0f : worst;
    }
  }
}

double Costmap::cost_at_distance(double d) const {
  if (d < spec_.inscribed_radius_m - kTol) return 1.0;
  if (d >= spec_.inflation_radius_m) return 0.0;
  return std::exp(-spec_.cost_scaling_per_m * std::max(0.0, d - spec_.inscribed_radius_m));
}

int Costmap::col_of(double x) const { return clamp_cell((x - ox_) / res_, w_); }
int Costmap::row_of(double y) const { return clamp_cell((y - oy_) / res_, h_); }

Eigen::Vector2d Costmap::centre(int row, int col) const {
  return {ox_ + (col + 0.5) * res_, oy_ + (row + 0.5) * res_};
}

double Costmap::distance_to_obstacle(double x, double y) const {
  const int c = clamp_cell((x - ox_) / mres_, mw_), r = clamp_cell((y - oy_) / mres_, mh_);
  if (r < 0 || c < 0 || r >= mh_ || c >= mw_) return 0.0;
  return dist_[static_cast<std::size_t>(r) * mw_ + c];
}

bool Costmap::map_occupied(double x, double y) const {
  const int c = clamp_cell((x - ox_) / mres_, mw_), r = clamp_cell((y - oy_) / mres_, mh_);
  if (r < 0 || c < 0 || r >= mh_ || c >= mw_) return true;
  return occ_[static_cast<std::size_t>(r) * mw_ + c] != 0;
}

bool Costmap::is_lethal(double x, double y) const {
  const int c = col_of(x), r = row_of(y);
  if (r < 0 || c < 0 || r >= h_ || c >= w_) return true;
  return lethal_[static_cast<std::size_t>(r) * w_ + c] != 0;
}

double Costmap::cost(double x, double y) const {
  const int c = col_of(x), r = row_of(y);
  if (r < 0 || c < 0 || r >= h_ || c >= w_) return 1.0;
  return cost_[static_cast<std::size_t>(r) * w_ + c];
}

}  // namespace tpuaf
