#include "tpuaf_core/planner.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <tuple>

namespace tpuaf {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kSqrt2 = 1.4142135623730951;
constexpr double kTol = 1e-9;  // [m] slack of the distance comparisons

bool finite(double v) { return std::isfinite(v); }

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

// Visits, in order, the cells of a unit grid crossed by segment a-b (coordinates in cells):
// visit(col, row, fraction of the segment inside the cell) returns false to stop. Passing
// through a corner also visits the two side cells (fraction 0), to be conservative.
template <class Visit>
bool walk_cells(double ax, double ay, double bx, double by, Visit&& visit) {
  int cx = static_cast<int>(std::floor(ax)), cy = static_cast<int>(std::floor(ay));
  const int ex = static_cast<int>(std::floor(bx)), ey = static_cast<int>(std::floor(by));
  const double dx = bx - ax, dy = by - ay;
  const int sx = dx > 0 ? 1 : (dx < 0 ? -1 : 0), sy = dy > 0 ? 1 : (dy < 0 ? -1 : 0);
  const double tdx = sx ? 1.0 / std::abs(dx) : kInf, tdy = sy ? 1.0 / std::abs(dy) : kInf;
  double tx = sx > 0 ? (cx + 1 - ax) / dx : (sx < 0 ? (ax - cx) / -dx : kInf);
  double ty = sy > 0 ? (cy + 1 - ay) / dy : (sy < 0 ? (ay - cy) / -dy : kInf);
  double t = 0.0;
  for (int guard = std::abs(ex - cx) + std::abs(ey - cy) + 4; guard > 0; --guard) {
    const double tn = std::min(tx, ty);
    if (tn >= 1.0 || (cx == ex && cy == ey)) return visit(cx, cy, 1.0 - t);
    if (!visit(cx, cy, tn - t)) return false;
    if (std::abs(tx - ty) <= 1e-9) {
      if (!visit(cx + sx, cy, 0.0) || !visit(cx, cy + sy, 0.0)) return false;
      cx += sx;
      cy += sy;
      tx += tdx;
      ty += tdy;
    } else if (tx < ty) {
      cx += sx;
      tx += tdx;
    } else {
      cy += sy;
      ty += tdy;
    }
    t = tn;
  }
  return true;
}

// Gap [m] between point (x, y) and the axis-aligned square [x0, x0 + s] x [y0, y0 + s].
double gap_to_square(double x, double y, double x0, double y0, double s) {
  const double dx = std::max({x0 - x, 0.0, x - (x0 + s)});
  const double dy = std::max({y0 - y, 0.0, y - (y0 + s)});
  return std::hypot(dx, dy);
}

int clamp_cell(double v, int n) {  // floor(v), kept within [-2, n + 1] (outside stays outside)
  return static_cast<int>(std::max(-2.0, std::min(static_cast<double>(n) + 1.0, std::floor(v))));
}

}  // namespace

// --- Costmap ------------------------------------------------------------------------------------

Costmap::Costmap(const GridMask& occupied, double resolution_m, double origin_x_m,
                 double origin_y_m, const CostmapSpec& spec, double planning_resolution_m)
    : spec_(spec) {
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

  // Gap between squares = centre distance to the occupied cells dilated by one cell (3 x 3),
  // since min over |e| <= 1 of (d - e)^2 = max(|d| - 1, 0)^2 per axis. Padded by one occupied
  // ring: the outside of the map.
  const int pw = mw_ + 2, ph = mh_ + 2;
  auto padded_occ = [&](int pr, int pc) {
    if (pr <= 0 || pc <= 0 || pr >= ph - 1 || pc >= pw - 1) return true;
    return occ_[static_cast<std::size_t>(pr - 1) * mw_ + (pc - 1)] != 0;
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

// --- GridPlanner --------------------------------------------------------------------------------

const char* to_string(PlanStatus status) {
  switch (status) {
    case PlanStatus::ok:
      return "ok";
    case PlanStatus::start_blocked:
      return "start_blocked";
    case PlanStatus::goal_blocked:
      return "goal_blocked";
    case PlanStatus::no_path:
      return "no_path";
  }
  return "unknown";
}

class GridPlanner::DiscGuard {
 public:
  DiscGuard(GridPlanner& p, const std::vector<Disc>& obstacles) : p_(p) {
    p_.apply_discs(obstacles);
  }
  ~DiscGuard() { p_.restore_discs(); }
  DiscGuard(const DiscGuard&) = delete;
  DiscGuard& operator=(const DiscGuard&) = delete;

 private:
  GridPlanner& p_;
};

GridPlanner::GridPlanner(std::shared_ptr<const Costmap> costmap, const PlannerOptions& options)
    : cm_(std::move(costmap)) {
  if (!cm_) throw std::invalid_argument("GridPlanner: no costmap");
  set_options(options);
  pw_ = cm_->width() + 2;
  ph_ = cm_->height() + 2;
  res_ = cm_->resolution();
  ox_ = cm_->origin_x();
  oy_ = cm_->origin_y();
  weight_ = cm_->spec().cost_weight;
  const std::size_t n = static_cast<std::size_t>(pw_) * ph_;
  mult_.assign(n, kLethal);
  for (int r = 0; r < cm_->height(); ++r)
    for (int c = 0; c < cm_->width(); ++c) {
      const std::size_t i = static_cast<std::size_t>(r) * cm_->width() + c;
      if (!cm_->lethal()[i])
        mult_[padded(r, c)] = static_cast<float>(1.0 + weight_ * cm_->costs()[i]);
    }
  state_.assign(n, CellState{});
  const int dcol[8] = {1, -1, 0, 0, 1, -1, 1, -1};
  const int drow[8] = {0, 0, 1, -1, 1, 1, -1, -1};
  for (int k = 0; k < 8; ++k) {
    offsets_[k] = drow[k] * pw_ + dcol[k];
    dcol_[k] = dcol[k];
    drow_[k] = drow[k];
    side_col_[k] = dcol[k];
    side_row_[k] = drow[k] * pw_;
    steps_[k] = (k < 4 ? 1.0 : kSqrt2) * res_;
  }
}

void GridPlanner::set_options(const PlannerOptions& options) {
  if (!finite(options.snap_radius_m) || options.snap_radius_m < 0)
    throw std::invalid_argument("GridPlanner: snap_radius_m must be >= 0");
  options_ = options;
}

Eigen::Vector2d GridPlanner::centre_of(int cell) const {
  const int r = cell / pw_ - 1, c = cell % pw_ - 1;
  return {ox_ + (c + 0.5) * res_, oy_ + (r + 0.5) * res_};
}

void GridPlanner::next_generation() {
  if (++gen_ == 0) {  // wrapped: clear the stamps once every 2^32 searches
    std::fill(state_.begin(), state_.end(), CellState{});
    gen_ = 1;
  }
}

void GridPlanner::apply_discs(const std::vector<Disc>& obstacles) {
  for (const Disc& d : obstacles) {
    if (!finite(d.x_m) || !finite(d.y_m))
      throw std::invalid_argument("GridPlanner: an obstacle disc has a non-finite centre");
    if (!finite(d.radius_m) || d.radius_m <= 0)
      throw std::invalid_argument("GridPlanner: an obstacle disc radius must be > 0, got " +
                                  std::to_string(d.radius_m));
  }
  const CostmapSpec& spec = cm_->spec();
  for (const Disc& d : obstacles) {
    const double reach = d.radius_m + spec.inflation_radius_m;
    const int c0 = std::max(0, cm_->col_of(d.x_m - reach));
    const int c1 = std::min(cm_->width() - 1, cm_->col_of(d.x_m + reach));
    const int r0 = std::max(0, cm_->row_of(d.y_m - reach));
    const int r1 = std::min(cm_->height() - 1, cm_->row_of(d.y_m + reach));
    for (int r = r0; r <= r1; ++r) {
      for (int c = c0; c <= c1; ++c) {
        const double gap =
            gap_to_square(d.x_m, d.y_m, ox_ + c * res_, oy_ + r * res_, res_) - d.radius_m;
        if (gap >= spec.inflation_radius_m) continue;
        const float m = gap < spec.inscribed_radius_m - kTol
                            ? kLethal
                            : static_cast<float>(1.0 + weight_ * cm_->cost_at_distance(gap));
        const int cell = padded(r, c);
        if (m > mult_[cell]) {
          undo_.emplace_back(cell, mult_[cell]);
          mult_[cell] = m;
        }
      }
    }
  }
}

void GridPlanner::restore_discs() {
  for (auto it = undo_.rbegin(); it != undo_.rend(); ++it) mult_[it->first] = it->second;
  undo_.clear();
}

bool GridPlanner::map_visible(const Eigen::Vector2d& from, const Eigen::Vector2d& to) const {
  const Costmap& cm = *cm_;
  const double mres = cm.map_resolution();
  const int mw = cm.map_width(), mh = cm.map_height();
  bool first = true;
  return walk_cells((from.x() - ox_) / mres, (from.y() - oy_) / mres, (to.x() - ox_) / mres,
                    (to.y() - oy_) / mres, [&](int c, int r, double) {
                      if (first) {  // the cell of the point itself may be occupied
                        first = false;
                        return true;
                      }
                      if (r < 0 || c < 0 || r >= mh || c >= mw) return false;
                      return cm.map_occupancy()[static_cast<std::size_t>(r) * mw + c] == 0;
                    });
}

GridPlanner::Snap GridPlanner::snap(const Eigen::Vector2d& p) const {
  const int w = cm_->width(), h = cm_->height();
  const int c = cm_->col_of(p.x()), r = cm_->row_of(p.y());
  if (r >= 0 && c >= 0 && r < h && c < w && free_cell(padded(r, c)))
    return {padded(r, c), false, p};
  const double radius = options_.snap_radius_m;
  const int reach = static_cast<int>(std::ceil(radius / res_)) + 1;
  std::vector<std::tuple<double, int, int>> candidates;  // distance [m], row, col
  for (int rr = std::max(0, r - reach); rr <= std::min(h - 1, r + reach); ++rr)
    for (int cc = std::max(0, c - reach); cc <= std::min(w - 1, c + reach); ++cc) {
      if (!free_cell(padded(rr, cc))) continue;
      const double d = (cm_->centre(rr, cc) - p).norm();
      if (d <= radius) candidates.emplace_back(d, rr, cc);
    }
  std::sort(candidates.begin(), candidates.end());
  for (const auto& [d, rr, cc] : candidates) {
    const Eigen::Vector2d q = cm_->centre(rr, cc);
    if (map_visible(p, q)) return {padded(rr, cc), true, q};
  }
  return {};
}

int GridPlanner::search(int start, const std::vector<int>& targets) {
  next_generation();
  heap_.clear();
  int remaining = 0;
  std::vector<std::pair<int, int>> goals;  // padded (col, row) of each target
  for (int t : targets) {
    if (state_[t].target == gen_) continue;
    state_[t].target = gen_;
    ++remaining;
    goals.emplace_back(t % pw_, t / pw_);
  }
  if (remaining == 0) return 0;
  auto heuristic = [&](int c, int r) {  // octile distance to the nearest target [m]
    double best = kInf;
    for (const auto& [gc, gr] : goals) {
      const int dx = std::abs(c - gc), dy = std::abs(r - gr);
      best = std::min(best, std::max(dx, dy) + (kSqrt2 - 1.0) * std::min(dx, dy));
    }
    return best * res_;
  };
  // Min f; ties: min h (deepest first), then min cell. Stale entries are skipped when their cell
  // is closed: with a consistent heuristic the best entry of a cell pops first.
  auto later = [](const Node& a, const Node& b) {
    if (a.f != b.f) return a.f > b.f;
    if (a.h != b.h) return a.h > b.h;
    return a.cell > b.cell;
  };
  state_[start].g = 0.0;
  state_[start].parent = -1;
  state_[start].seen = gen_;
  {
    const float h = static_cast<float>(heuristic(start % pw_, start / pw_));
    heap_.push_back({h, h, start});
  }
  int expanded = 0;
  while (!heap_.empty()) {
    std::pop_heap(heap_.begin(), heap_.end(), later);
    const int u = heap_.back().cell;
    heap_.pop_back();
    CellState& su = state_[u];
    if (su.closed == gen_) continue;
    su.closed = gen_;
    ++expanded;
    if (su.target == gen_ && --remaining == 0) break;
    const int ru = u / pw_, cu = u - ru * pw_;
    const double gu = su.g, mu = mult_[u];
    for (int k = 0; k < 8; ++k) {
      const int v = u + offsets_[k];
      const float mv = mult_[v];
      CellState& sv = state_[v];
      if (mv >= kLethal || sv.closed == gen_) continue;
      if (k >= 4 && (mult_[u + side_col_[k]] >= kLethal || mult_[u + side_row_[k]] >= kLethal))
        continue;  // no corner cutting
      const double ng = gu + steps_[k] * 0.5 * (mu + mv);
      if (sv.seen == gen_ && ng >= sv.g) continue;
      sv.seen = gen_;
      sv.g = ng;
      sv.parent = u;
      const double h = heuristic(cu + dcol_[k], ru + drow_[k]);
      heap_.push_back({ng + h, static_cast<float>(h), v});
      std::push_heap(heap_.begin(), heap_.end(), later);
    }
  }
  return expanded;
}

std::vector<int> GridPlanner::cell_path(int target) const {
  std::vector<int> cells;
  for (int c = target; c >= 0; c = state_[c].parent) cells.push_back(c);
  std::reverse(cells.begin(), cells.end());
  return cells;
}

double GridPlanner::segment_cost(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                                 bool check_lethal) const {
  const double length = (b - a).norm();
  const int w = cm_->width(), h = cm_->height();
  const float worst = static_cast<float>(1.0 + weight_);
  double sum = 0.0;  // fraction-weighted multiplier
  const bool clear = walk_cells(
      (a.x() - ox_) / res_, (a.y() - oy_) / res_, (b.x() - ox_) / res_, (b.y() - oy_) / res_,
      [&](int c, int r, double fraction) {
        float m = (r < 0 || c < 0 || r >= h || c >= w) ? kLethal : mult_[padded(r, c)];
        if (m >= kLethal) {
          if (check_lethal) return false;
          m = worst;
        }
        sum += fraction * m;
        return true;
      });
  return clear ? sum * length : kInf;
}

void GridPlanner::smooth(std::vector<Eigen::Vector2d>& pts, std::size_t first) const {
  // Cheapest polyline (weighted length) whose corners are points of the cell path at most
  // kWindow apart and whose segments cross no lethal cell (dynamic programming), then tightened.
  constexpr std::size_t kWindow = 8;
  const std::size_t n = pts.size();
  if (n <= first + 2) return;
  std::vector<double> best(n, kInf);  // weighted length from pts[first] [m]
  std::vector<std::size_t> from(n, first);
  best[first] = 0.0;
  for (std::size_t j = first + 1; j < n; ++j) {
    best[j] = best[j - 1] + segment_cost(pts[j - 1], pts[j], false);  // the cell path itself
    from[j] = j - 1;
    for (std::size_t i = j > first + kWindow ? j - kWindow : first; i + 1 < j; ++i) {
      const double c = best[i] + segment_cost(pts[i], pts[j], true);
      if (c < best[j] - kTol) {
        best[j] = c;
        from[j] = i;
      }
    }
  }
  std::vector<std::size_t> corners;
  for (std::size_t j = n - 1; j > first; j = from[j]) corners.push_back(j);
  std::vector<Eigen::Vector2d> out(pts.begin(), pts.begin() + first + 1);
  for (auto it = corners.rbegin(); it != corners.rend(); ++it) out.push_back(pts[*it]);
  pts.swap(out);
  tighten(pts, first);
}

void GridPlanner::tighten(std::vector<Eigen::Vector2d>& pts, std::size_t first) const {
  // Pulls each corner towards the chord of its neighbours as far as the segments stay clear and
  // their weighted length falls (bisection), so the path hugs the lethal boundary instead of
  // the cell centres; midpoints added once become corners that can slide around a bend;
  // corners that become unnecessary are dropped.
  constexpr int kPasses = 2, kSubdivisions = 1, kBisections = 4;
  {  // drop corners on the chord of their neighbours (straight runs of the cell path)
    std::vector<Eigen::Vector2d> out(pts.begin(), pts.begin() + first + 1);
    for (std::size_t i = first + 1; i + 1 < pts.size(); ++i) {
      const Eigen::Vector2d a = out.back(), b = pts[i + 1], v = pts[i];
      const Eigen::Vector2d ab = b - a;
      const double cross = std::abs(ab.x() * (v - a).y() - ab.y() * (v - a).x());
      const bool between = (v - a).dot(ab) >= 0 && (v - b).dot(-ab) >= 0;
      if (between && cross <= 1e-9 * ab.norm()) continue;
      out.push_back(v);
    }
    out.push_back(pts.back());
    pts.swap(out);
  }
  for (int pass = 0; pass < kPasses && pts.size() > first + 2; ++pass) {
    bool moved = false;
    if (pass < kSubdivisions) {
      std::vector<Eigen::Vector2d> finer(pts.begin(), pts.begin() + first + 1);
      for (std::size_t i = first + 1; i < pts.size(); ++i) {
        finer.push_back(0.5 * (pts[i - 1] + pts[i]));
        finer.push_back(pts[i]);
      }
      pts.swap(finer);
    }
    for (std::size_t i = first + 1; i + 1 < pts.size(); ++i) {
      const Eigen::Vector2d a = pts[i - 1], b = pts[i + 1], v = pts[i];
      const Eigen::Vector2d ab = b - a;
      const double len2 = ab.squaredNorm();
      const double t = len2 > 0 ? std::clamp((v - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
      const Eigen::Vector2d q = a + t * ab;  // nearest point of the chord
      if ((q - v).squaredNorm() < kTol * kTol) continue;  // already straight
      double lo = 0.0, hi = 1.0, best = segment_cost(a, v, true) + segment_cost(v, b, true);
      for (int k = 0; k < kBisections; ++k) {
        const double mid = 0.5 * (lo + hi);
        const Eigen::Vector2d w = v + mid * (q - v);
        const double c = segment_cost(a, w, true) + segment_cost(w, b, true);
        if (c < best - kTol) {
          lo = mid;
          best = c;
        } else {
          hi = mid;
        }
      }
      if (lo > 0.0) {
        pts[i] = v + lo * (q - v);
        moved = true;
      }
    }
    for (std::size_t i = first + 1; i + 1 < pts.size(); ++i) {  // drop unnecessary corners
      const double now =
          segment_cost(pts[i - 1], pts[i], true) + segment_cost(pts[i], pts[i + 1], true);
      if (segment_cost(pts[i - 1], pts[i + 1], true) <= now + kTol * (1.0 + now)) {
        pts.erase(pts.begin() + static_cast<std::ptrdiff_t>(i));
        --i;
      }
    }
    if (!moved) break;
  }
}

Plan GridPlanner::finish(const std::vector<int>& cells, const Eigen::Vector2d& start,
                         const Snap& s, const Eigen::Vector2d& goal, const Snap& g,
                         int expanded) const {
  Plan plan;
  plan.status = PlanStatus::ok;
  plan.start_snapped = s.snapped;
  plan.goal_snapped = g.snapped;
  plan.start = s.point;
  plan.goal = g.point;
  plan.expanded = expanded;
  std::vector<Eigen::Vector2d> pts;
  pts.reserve(cells.size() + 2);
  pts.push_back(start);
  for (int c : cells) pts.push_back(centre_of(c));
  if (!g.snapped) pts.push_back(goal);
  if (options_.smooth) smooth(pts, s.snapped ? 1 : 0);
  plan.points.reserve(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i)  // drop repeated points, keep both ends
    if (i == 0 || i + 1 == pts.size() || pts[i] != plan.points.back())
      plan.points.push_back(pts[i]);
  for (std::size_t i = 1; i < plan.points.size(); ++i) {
    plan.length_m += (plan.points[i] - plan.points[i - 1]).norm();
    plan.cost_m += segment_cost(plan.points[i - 1], plan.points[i], false);
  }
  return plan;
}

Plan GridPlanner::plan(const Eigen::Vector2d& start, const Eigen::Vector2d& goal,
                       const std::vector<Disc>& obstacles) {
  if (!start.allFinite()) throw std::invalid_argument("GridPlanner.plan: non-finite start");
  if (!goal.allFinite()) throw std::invalid_argument("GridPlanner.plan: non-finite goal");
  DiscGuard guard(*this, obstacles);
  Plan plan;
  plan.start = start;
  plan.goal = goal;
  const Snap s = snap(start);
  if (s.cell < 0) {
    plan.status = PlanStatus::start_blocked;
    return plan;
  }
  const Snap g = snap(goal);
  if (g.cell < 0) {
    plan.status = PlanStatus::goal_blocked;
    return plan;
  }
  if (s.cell == g.cell) return finish({s.cell}, start, s, goal, g, 0);
  const int expanded = search(s.cell, {g.cell});
  if (!reached(g.cell)) {
    plan.status = PlanStatus::no_path;
    plan.expanded = expanded;
    return plan;
  }
  return finish(cell_path(g.cell), start, s, goal, g, expanded);
}

double GridPlanner::path_length(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                                const std::vector<Disc>& obstacles) {
  const Plan p = plan(a, b, obstacles);
  return p.ok() ? p.length_m : kInf;
}

std::vector<Plan> GridPlanner::plan_edges(
    const Points& vertices, const Eigen::Matrix<int, Eigen::Dynamic, 2, Eigen::RowMajor>& edges,
    const std::vector<Disc>& obstacles) {
  const int n = static_cast<int>(vertices.rows());
  const int m = static_cast<int>(edges.rows());
  if (!vertices.allFinite())
    throw std::invalid_argument("GridPlanner.plan_edges: non-finite vertex position");
  std::vector<std::vector<int>> incident(n);
  for (int e = 0; e < m; ++e) {
    for (int k = 0; k < 2; ++k)
      if (edges(e, k) < 0 || edges(e, k) >= n)
        throw std::invalid_argument("GridPlanner.plan_edges: edge " + std::to_string(e) +
                                    " has unknown vertex " + std::to_string(edges(e, k)) +
                                    " (" + std::to_string(n) + " vertices)");
    incident[edges(e, 0)].push_back(e);
    if (edges(e, 1) != edges(e, 0)) incident[edges(e, 1)].push_back(e);
  }
  DiscGuard guard(*this, obstacles);
  std::vector<Snap> snaps(n);
  std::vector<char> used(n, 0);
  for (int e = 0; e < m; ++e) used[edges(e, 0)] = used[edges(e, 1)] = 1;
  for (int i = 0; i < n; ++i)
    if (used[i]) snaps[i] = snap(vertices.row(i).transpose());

  std::vector<Plan> plans(m);
  std::vector<char> done(m, 0);
  std::vector<int> pending, targets;
  for (int u = 0; u < n; ++u) {
    pending.clear();
    targets.clear();
    for (int e : incident[u]) {
      if (done[e]) continue;
      pending.push_back(e);
      const int other = edges(e, 0) == u ? edges(e, 1) : edges(e, 0);
      if (snaps[u].cell >= 0 && snaps[other].cell >= 0 && snaps[other].cell != snaps[u].cell)
        targets.push_back(snaps[other].cell);
    }
    if (pending.empty()) continue;
    const int expanded = targets.empty() ? 0 : search(snaps[u].cell, targets);
    for (int e : pending) {
      done[e] = 1;
      const int a = edges(e, 0), b = edges(e, 1);
      const int other = a == u ? b : a;
      Plan& p = plans[e];
      p.start = vertices.row(a).transpose();
      p.goal = vertices.row(b).transpose();
      p.expanded = expanded;
      if (snaps[a].cell < 0) {
        p.status = PlanStatus::start_blocked;
      } else if (snaps[b].cell < 0) {
        p.status = PlanStatus::goal_blocked;
      } else if (snaps[a].cell == snaps[b].cell) {
        p = finish({snaps[a].cell}, p.start, snaps[a], p.goal, snaps[b], expanded);
      } else if (!reached(snaps[other].cell)) {
        p.status = PlanStatus::no_path;
      } else {
        std::vector<int> cells = cell_path(snaps[other].cell);
        if (u != a) std::reverse(cells.begin(), cells.end());
        p = finish(cells, p.start, snaps[a], p.goal, snaps[b], expanded);
      }
    }
  }
  return plans;
}

}  // namespace tpuaf
