// 2-D simulated world (see world.hpp).
#include "tpuaf_core/world.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision.h>

namespace tpuaf {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kHalfDiagonal = 0.70710678118654752;  // of a cell [cells]
constexpr double kFieldStep = 0.125;  // quantum of the clearance field [cells]; caps a leap at 31.75

double wrap_angle(double a) { return std::atan2(std::sin(a), std::cos(a)); }

// Squared 1-D distance transform of f (Felzenszwalb and Huttenlocher), in place over d.
void edt_1d(const std::vector<double>& f, int n, std::vector<double>& d, std::vector<int>& v,
            std::vector<double>& z) {
  int k = 0;
  v[0] = 0;
  z[0] = -kInf;
  z[1] = kInf;
  for (int q = 1; q < n; ++q) {
    double s;
    while (true) {
      const int p = v[k];
      s = ((f[q] + double(q) * q) - (f[p] + double(p) * p)) / (2.0 * q - 2.0 * p);
      if (s <= z[k] && k > 0) {
        --k;
      } else {
        break;
      }
    }
    if (s <= z[k]) {  // k == 0 and the parabola at q dominates everywhere
      v[0] = q;
      z[0] = -kInf;
      z[1] = kInf;
      continue;
    }
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = kInf;
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < q) ++k;
    const double dq = q - v[k];
    d[q] = dq * dq + f[v[k]];
  }
}

// Upper bound of |(x, y)| without a square root (octagon): max + (sqrt(2) - 1) min, at most 8%
// above. The square root was the slowest link of the marching loop.
inline double centre_distance_bound(double x, double y) {
  const double ax = std::abs(x), ay = std::abs(y);
  return std::max(ax, ay) + 0.41421356237309515 * std::min(ax, ay);
}

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument(what);
}

bool positive(double x) { return x > 0.0 && !std::isnan(x); }
bool finite_nonneg(double x) { return std::isfinite(x) && x >= 0.0; }

void check_specs(const RobotSpec& r, const LaserSpec& l) {
  require(std::isfinite(r.radius_m) && r.radius_m > 0, "robot radius_m must be finite and > 0");
  require(std::isfinite(r.max_linear_speed) && r.max_linear_speed > 0,
          "max_linear_speed [m/s] must be finite and > 0");
  require(std::isfinite(r.max_angular_speed) && r.max_angular_speed > 0,
          "max_angular_speed [rad/s] must be finite and > 0");
  require(positive(r.max_linear_accel), "max_linear_accel [m/s^2] must be > 0 (inf allowed)");
  require(positive(r.max_angular_accel), "max_angular_accel [rad/s^2] must be > 0 (inf allowed)");
  require(finite_nonneg(r.odom_linear_noise) && finite_nonneg(r.odom_angular_noise),
          "odometry noise must be finite and >= 0");
  require(l.beams >= 1, "laser beams must be >= 1");
  require(std::isfinite(l.angle_min_rad) && std::isfinite(l.angle_increment_rad),
          "laser angle_min and angle_increment [rad] must be finite");
  require(finite_nonneg(l.range_min_m), "laser range_min [m] must be finite and >= 0");
  require(std::isfinite(l.range_max_m) && l.range_max_m > l.range_min_m,
          "laser range_max [m] must be finite and > range_min");
  require(finite_nonneg(l.noise_std_m), "laser noise_std [m] must be finite and >= 0");
  require(std::isfinite(l.x_offset_m) && std::isfinite(l.y_offset_m) &&
              std::isfinite(l.yaw_offset_rad),
          "laser offsets must be finite");
}

}  // namespace

Eigen::Vector3d integrate_arc(const Eigen::Vector3d& pose, double v, double w, double t) {
  const double a = w * t;
  const double half = 0.5 * a;
  // Chord of the arc: 2 (v / w) sin(w t / 2) = v t sinc(w t / 2), stable as w -> 0.
  const double sinc = std::abs(half) < 1e-4 ? 1.0 - half * half / 6.0 : std::sin(half) / half;
  const double chord = v * t * sinc;
  const double heading = pose[2] + half;
  return {pose[0] + chord * std::cos(heading), pose[1] + chord * std::sin(heading),
          wrap_angle(pose[2] + a)};
}

World::World(const GridMask& occupied, double resolution_m, double origin_x_m, double origin_y_m,
             std::uint64_t seed)
    : width_(static_cast<int>(occupied.cols())),
      height_(static_cast<int>(occupied.rows())),
      pw_(width_ + 2),
      ph_(height_ + 2),
      res_(resolution_m),
      ox_(origin_x_m),
      oy_(origin_y_m),
      seed_(seed) {
  require(width_ > 0 && height_ > 0, "the occupancy grid is empty");
  require(std::isfinite(resolution_m) && resolution_m > 0, "resolution [m] must be finite and > 0");
  require(std::isfinite(origin_x_m) && std::isfinite(origin_y_m), "origin [m] must be finite");
  require(double(pw_) * ph_ < 2.0e9, "the occupancy grid is too large");
  // Independent noise streams derived from the seed (splitmix-style constants).
  laser_rng_.seed(seed ^ 0x9E3779B97F4A7C15ULL);
  odom_rng_.seed(seed ^ 0xBF58476D1CE4E5B9ULL);

  std::vector<std::uint8_t> occ(size_t(pw_) * ph_, 1);  // the padding ring: outside the map
  for (int r = 0; r < height_; ++r)
    for (int c = 0; c < width_; ++c) occ[size_t(r + 1) * pw_ + (c + 1)] = occupied(r, c) ? 1 : 0;

  // Euclidean distance transform between cell centres [cells], columns then rows.
  const int n = std::max(pw_, ph_);
  std::vector<double> f(n), d(n), z(n + 1), sq(size_t(pw_) * ph_);
  std::vector<int> v(n);
  const double big = 1e20;
  for (int x = 0; x < pw_; ++x) {
    for (int y = 0; y < ph_; ++y) f[y] = occ[size_t(y) * pw_ + x] ? 0.0 : big;
    edt_1d(f, ph_, d, v, z);
    for (int y = 0; y < ph_; ++y) sq[size_t(y) * pw_ + x] = d[y];
  }
  for (int y = 0; y < ph_; ++y) {
    for (int x = 0; x < pw_; ++x) f[x] = sq[size_t(y) * pw_ + x];
    edt_1d(f, pw_, d, v, z);
    for (int x = 0; x < pw_; ++x) sq[size_t(y) * pw_ + x] = d[x];
  }
  // One byte per cell: 0 = occupied, else 1 + floor((D - sqrt(2)/2) / kFieldStep), D the distance
  // between this centre and the nearest occupied centre [cells]. A point p of the cell with centre
  // c is then at least kFieldStep (code - 1) - |p - c| cells from every occupied cell (the sphere
  // tracing bound).
  field_.resize(sq.size());
  for (size_t k = 0; k < sq.size(); ++k) {
    if (occ[k]) {
      field_[k] = 0;
    } else {
      const double q = std::floor((std::sqrt(sq[k]) - kHalfDiagonal - 1e-6) / kFieldStep);
      field_[k] = static_cast<std::uint8_t>(1 + std::clamp(q, 0.0, 254.0));
    }
  }
}

void World::check_index(int i) const {
  if (i < 0 || i >= num_robots()) {
    std::ostringstream os;
    os << "robot index " << i << " out of range (world has " << num_robots() << " robots)";
    throw std::out_of_range(os.str());
  }
}

const RobotSpec& World::robot_spec(int i) const {
  check_index(i);
  return robots_[i].spec;
}

const LaserSpec& World::laser_spec(int i) const {
  check_index(i);
  return robots_[i].laser;
}

bool World::occupied_padded(int px, int py) const {
  if (px < 0 || py < 0 || px >= pw_ || py >= ph_) return true;
  return field_[size_t(py) * pw_ + px] == 0;
}

double World::clearance(double x, double y) const {
  const double gx = (x - ox_) / res_ + 1.0, gy = (y - oy_) / res_ + 1.0;
  if (!(gx >= 0 && gy >= 0 && gx < pw_ && gy < ph_)) return 0.0;
  const int ix = int(gx), iy = int(gy);
  const std::uint8_t code = field_[size_t(iy) * pw_ + ix];
  if (code == 0) return 0.0;
  const double s = kFieldStep * (code - 1) - std::hypot(gx - ix - 0.5, gy - iy - 0.5);
  return s > 0 ? s * res_ : 0.0;
}

bool World::disc_hits_wall(double x, double y, double radius_m) const {
  // Broad phase 1: the distance field proves most poses free.
  if (clearance(x, y) > radius_m + 1e-9) return false;
  // Broad phase 2: occupied cells whose box overlaps the disc's bounding box; narrow phase: FCL.
  const int c0 = int(std::floor((x - radius_m - ox_) / res_)) + 1;
  const int c1 = int(std::floor((x + radius_m - ox_) / res_)) + 1;
  const int r0 = int(std::floor((y - radius_m - oy_) / res_)) + 1;
  const int r1 = int(std::floor((y + radius_m - oy_) / res_)) + 1;
  const fcl::Sphered disc(radius_m);
  const fcl::Boxd cell(res_, res_, res_);
  fcl::Transform3d disc_tf = fcl::Transform3d::Identity();
  disc_tf.translation() = fcl::Vector3d(x, y, 0.0);
  const fcl::CollisionRequestd request;
  for (int r = r0; r <= r1; ++r) {
    for (int c = c0; c <= c1; ++c) {
      if (!occupied_padded(c, r)) continue;
      fcl::Transform3d cell_tf = fcl::Transform3d::Identity();
      cell_tf.translation() =
          fcl::Vector3d(ox_ + (c - 1 + 0.5) * res_, oy_ + (r - 1 + 0.5) * res_, 0.0);
      fcl::CollisionResultd result;
      fcl::collide(&disc, disc_tf, &cell, cell_tf, request, result);
      if (result.isCollision()) return true;
    }
  }
  return false;
}

int World::disc_hits_robot(double x, double y, double radius_m, int ignore) const {
  const fcl::Sphered disc(radius_m);
  fcl::Transform3d disc_tf = fcl::Transform3d::Identity();
  disc_tf.translation() = fcl::Vector3d(x, y, 0.0);
  const fcl::CollisionRequestd request;
  for (int j = 0; j < num_robots(); ++j) {
    if (j == ignore) continue;
    const Robot& o = robots_[j];
    const double reach = radius_m + o.spec.radius_m;
    if (std::abs(o.pose[0] - x) > reach || std::abs(o.pose[1] - y) > reach) continue;
    const fcl::Sphered other(o.spec.radius_m);
    fcl::Transform3d other_tf = fcl::Transform3d::Identity();
    other_tf.translation() = fcl::Vector3d(o.pose[0], o.pose[1], 0.0);
    fcl::CollisionResultd result;
    fcl::collide(&disc, disc_tf, &other, other_tf, request, result);
    if (result.isCollision()) return j;
  }
  return -1;
}

bool World::robot_pose_free(int i, double x, double y) const {
  const double r = robots_[i].spec.radius_m;
  return !disc_hits_wall(x, y, r) && disc_hits_robot(x, y, r, i) < 0;
}

int World::add_robot(const RobotSpec& robot, const LaserSpec& laser, double x, double y,
                     double th) {
  check_specs(robot, laser);
  require(std::isfinite(x) && std::isfinite(y) && std::isfinite(th), "robot pose must be finite");
  std::ostringstream where;
  where << "robot " << num_robots() << " at (" << x << ", " << y << ") m with radius "
        << robot.radius_m << " m";
  require(!disc_hits_wall(x, y, robot.radius_m), where.str() + " overlaps a wall or the map edge");
  const int other = disc_hits_robot(x, y, robot.radius_m, -1);
  if (other >= 0) {
    std::ostringstream os;
    os << where.str() << " overlaps robot " << other;
    throw std::invalid_argument(os.str());
  }
  Robot r;
  r.spec = robot;
  r.laser = laser;
  r.pose = r.initial_pose = Eigen::Vector3d(x, y, wrap_angle(th));
  r.odom.setZero();
  robots_.push_back(r);
  return num_robots() - 1;
}

void World::set_command(int i, double v, double w) {
  check_index(i);
  require(std::isfinite(v) && std::isfinite(w), "commanded twist must be finite");
  robots_[i].cmd_v = v;
  robots_[i].cmd_w = w;
}

void World::set_commands(const Twists& commands) {
  if (commands.rows() != num_robots()) {
    std::ostringstream os;
    os << "commands has " << commands.rows() << " rows, world has " << num_robots() << " robots";
    throw std::invalid_argument(os.str());
  }
  require(commands.allFinite(), "commanded twists must be finite");
  for (int i = 0; i < num_robots(); ++i) {
    robots_[i].cmd_v = commands(i, 0);
    robots_[i].cmd_w = commands(i, 1);
  }
}

Twists World::commands() const {
  Twists out(num_robots(), 2);
  for (int i = 0; i < num_robots(); ++i) out.row(i) << robots_[i].cmd_v, robots_[i].cmd_w;
  return out;
}

void World::move_robot(int i, double dt) {
  Robot& r = robots_[i];
  const RobotSpec& s = r.spec;
  const double vc = std::clamp(r.cmd_v, -s.max_linear_speed, s.max_linear_speed);
  const double wc = std::clamp(r.cmd_w, -s.max_angular_speed, s.max_angular_speed);
  const double dv = s.max_linear_accel * dt, dw = s.max_angular_accel * dt;
  const double v = r.v + std::clamp(vc - r.v, -dv, dv);
  const double w = r.w + std::clamp(wc - r.w, -dw, dw);

  // Sub-steps no longer than half the radius (and half a cell): a disc cannot cross an obstacle
  // between two checked poses, so there is no tunnelling even through a one-cell wall.
  const double path_m = std::abs(v) * dt;
  const double max_sub_m = 0.5 * std::min(s.radius_m, res_);
  const int n = path_m > 0 ? int(std::min(1e6, std::ceil(path_m / max_sub_m))) : 0;
  const Eigen::Vector3d start = r.pose;
  Eigen::Vector3d pose = integrate_arc(start, v, w, dt);
  double done = 1.0;  // fraction of dt driven
  bool contact = false;
  for (int k = 1; k <= n; ++k) {
    const double frac = double(k) / n;
    const Eigen::Vector3d p = integrate_arc(start, v, w, frac * dt);
    if (robot_pose_free(i, p[0], p[1])) continue;
    // Contact within this sub-step: bisect to the last free pose.
    double lo = double(k - 1) / n, hi = frac;
    for (int it = 0; it < 48 && (hi - lo) * path_m > 1e-9; ++it) {
      const double mid = 0.5 * (lo + hi);
      const Eigen::Vector3d q = integrate_arc(start, v, w, mid * dt);
      (robot_pose_free(i, q[0], q[1]) ? lo : hi) = mid;
    }
    done = lo;
    pose = integrate_arc(start, v, w, lo * dt);
    contact = true;
    break;
  }
  r.pose = pose;
  r.stalled = contact;

  // Odometry: the driven arc, with multiplicative Gaussian noise on distance and rotation.
  double ov = v, ow = w;
  if (s.odom_linear_noise > 0) ov *= 1.0 + std::normal_distribution<double>(0, s.odom_linear_noise)(odom_rng_);
  if (s.odom_angular_noise > 0) ow *= 1.0 + std::normal_distribution<double>(0, s.odom_angular_noise)(odom_rng_);
  r.odom = integrate_arc(r.odom, ov, ow, done * dt);
  r.odom_v = ov * done;
  r.odom_w = ow * done;
  if (contact) {
    ++r.contacts;
    r.v = r.w = 0.0;
  } else {
    r.v = v;
    r.w = w;
  }
}

void World::step(double dt) {
  require(std::isfinite(dt) && dt > 0, "step dt [s] must be finite and > 0");
  for (int i = 0; i < num_robots(); ++i) move_robot(i, dt);
  time_s_ += dt;
}

Poses World::poses() const {
  Poses out(num_robots(), 3);
  for (int i = 0; i < num_robots(); ++i) out.row(i) = robots_[i].pose.transpose();
  return out;
}

Twists World::velocities() const {
  Twists out(num_robots(), 2);
  for (int i = 0; i < num_robots(); ++i) out.row(i) << robots_[i].v, robots_[i].w;
  return out;
}

Poses World::odom_poses() const {
  Poses out(num_robots(), 3);
  for (int i = 0; i < num_robots(); ++i) out.row(i) = robots_[i].odom.transpose();
  return out;
}

Twists World::odom_velocities() const {
  Twists out(num_robots(), 2);
  for (int i = 0; i < num_robots(); ++i) out.row(i) << robots_[i].odom_v, robots_[i].odom_w;
  return out;
}

std::vector<bool> World::stalled() const {
  std::vector<bool> out(num_robots());
  for (int i = 0; i < num_robots(); ++i) out[i] = robots_[i].stalled;
  return out;
}

std::vector<std::int64_t> World::contact_counts() const {
  std::vector<std::int64_t> out(num_robots());
  for (int i = 0; i < num_robots(); ++i) out[i] = robots_[i].contacts;
  return out;
}

void World::set_pose(int i, double x, double y, double th, bool reset_odometry) {
  check_index(i);
  require(std::isfinite(x) && std::isfinite(y) && std::isfinite(th), "robot pose must be finite");
  const double rad = robots_[i].spec.radius_m;
  std::ostringstream where;
  where << "robot " << i << " at (" << x << ", " << y << ") m";
  require(!disc_hits_wall(x, y, rad), where.str() + " would overlap a wall or the map edge");
  const int other = disc_hits_robot(x, y, rad, i);
  if (other >= 0) {
    std::ostringstream os;
    os << where.str() << " would overlap robot " << other;
    throw std::invalid_argument(os.str());
  }
  Robot& r = robots_[i];
  r.pose = Eigen::Vector3d(x, y, wrap_angle(th));
  r.stalled = false;
  if (reset_odometry) {
    r.v = r.w = r.odom_v = r.odom_w = 0.0;
    r.odom.setZero();
  }
}

void World::reset() {
  for (Robot& r : robots_) {
    r.pose = r.initial_pose;
    r.odom.setZero();
    r.v = r.w = r.cmd_v = r.cmd_w = r.odom_v = r.odom_w = 0.0;
    r.stalled = false;
    r.contacts = 0;
  }
}

// First occupied cell along n rays from (gx, gy) in padded grid units (directions dx, dy unit,
// limits tmax [cells]); writes the entry distance [cells] or +inf beyond the limit to t_out.
// Each iteration moves a ray by the larger of two safe amounts: the sphere-tracing bound of the
// distance field (wide open space) and the exit of the current cell (exact cell walking near
// walls). The loop is latency-bound, so kLanes rays are interleaved; a hit is then refined to
// the exact entry of the ray into the occupied cell.
void World::march_many(double gx, double gy, const double* dx, const double* dy,
                       const double* tmax, int n, double* t_out) const {
  if (!(gx >= 0 && gy >= 0 && gx < pw_ && gy < ph_)) {  // the laser is outside the map
    for (int b = 0; b < n; ++b) t_out[b] = 0.0;
    return;
  }
  constexpr int kLanes = 8;
  constexpr double kNudge = 1e-9;  // [cells] into the next cell
  const std::uint8_t* field = field_.data();
  const size_t stride = static_cast<size_t>(pw_);
  // Every ray leaps at once over the free disc around the origin.
  double t_start = 0.0;
  {
    const int ix = static_cast<int>(gx), iy = static_cast<int>(gy);
    const std::uint8_t code = field[static_cast<size_t>(iy) * stride + ix];
    const double cx = gx - ix - 0.5, cy = gy - iy - 0.5;
    if (code > 0) t_start = std::max(0.0, kFieldStep * (code - 1) - std::sqrt(cx * cx + cy * cy));
  }
  double t[kLanes], ddx[kLanes], ddy[kLanes], inx[kLanes], iny[kLanes], bx[kLanes], by[kLanes],
      lim[kLanes];
  int beam[kLanes];
  int next = 0, active = 0;
  auto load = [&](int k) {
    if (next >= n) {
      beam[k] = -1;
      return;
    }
    const int b = next++;
    beam[k] = b;
    ++active;
    t[k] = t_start;
    // Avoid exact zeros: 0 * inf below. The change of direction is below 1e-12 rad.
    ddx[k] = std::abs(dx[b]) < 1e-12 ? (std::signbit(dx[b]) ? -1e-12 : 1e-12) : dx[b];
    ddy[k] = std::abs(dy[b]) < 1e-12 ? (std::signbit(dy[b]) ? -1e-12 : 1e-12) : dy[b];
    inx[k] = 1.0 / ddx[k];
    iny[k] = 1.0 / ddy[k];
    bx[k] = ddx[k] > 0 ? 1.0 : 0.0;
    by[k] = ddy[k] > 0 ? 1.0 : 0.0;
    lim[k] = tmax[b];
  };
  for (int k = 0; k < kLanes; ++k) load(k);
  while (active > 0) {
    for (int k = 0; k < kLanes; ++k) {
      if (beam[k] < 0) continue;
      const double px = gx + t[k] * ddx[k], py = gy + t[k] * ddy[k];
      const int ix = static_cast<int>(px), iy = static_cast<int>(py);  // px, py >= 0 here
      const std::uint8_t code = field[static_cast<size_t>(iy) * stride + ix];
      if (code == 0 || t[k] > lim[k]) {
        double hit = kInf;
        if (code == 0) {  // exact entry into this cell: the later of the two slab entries
          const double ex = ((ddx[k] > 0 ? ix : ix + 1) - gx) * inx[k];
          const double ey = ((ddy[k] > 0 ? iy : iy + 1) - gy) * iny[k];
          hit = std::max(0.0, std::max(ex, ey));
          if (hit > lim[k]) hit = kInf;
        }
        t_out[beam[k]] = hit;
        --active;
        load(k);
        continue;
      }
      const double ux = px - ix, uy = py - iy;  // in [0, 1)
      const double leap = kFieldStep * (code - 1) - centre_distance_bound(ux - 0.5, uy - 0.5);
      const double exit = std::min((bx[k] - ux) * inx[k], (by[k] - uy) * iny[k]);
      t[k] += std::max(leap, exit) + kNudge;
    }
  }
}

double World::cast_ray(double x, double y, double th, double max_range_m) const {
  const double dx = std::cos(th), dy = std::sin(th), lim = max_range_m / res_;
  double t;
  march_many((x - ox_) / res_ + 1.0, (y - oy_) / res_ + 1.0, &dx, &dy, &lim, 1, &t);
  return std::isinf(t) ? kInf : t * res_;
}

void World::scan(int i, float* out) {
  check_index(i);
  const Robot& r = robots_[i];
  const LaserSpec& l = r.laser;
  const double c = std::cos(r.pose[2]), s = std::sin(r.pose[2]);
  const double lx = r.pose[0] + c * l.x_offset_m - s * l.y_offset_m;
  const double ly = r.pose[1] + s * l.x_offset_m + c * l.y_offset_m;
  const int nb = l.beams;
  std::vector<double> buf(5 * size_t(nb));
  double *dx = buf.data(), *dy = dx + nb, *lim = dy + nb, *t = lim + nb, *robot = t + nb;

  // Beam directions: exact now and then, incremental rotation in between.
  const double a0 = r.pose[2] + l.yaw_offset_rad + l.angle_min_rad;
  const double ci = std::cos(l.angle_increment_rad), si = std::sin(l.angle_increment_rad);
  for (int b = 0; b < nb; ++b) {
    if (b % 32 == 0) {
      dx[b] = std::cos(a0 + b * l.angle_increment_rad);
      dy[b] = std::sin(a0 + b * l.angle_increment_rad);
    } else {
      dx[b] = dx[b - 1] * ci - dy[b - 1] * si;
      dy[b] = dx[b - 1] * si + dy[b - 1] * ci;
    }
    robot[b] = kInf;
  }
  // Other robots in reach: analytic ray-circle hits [m] become the limits of the grid march.
  for (int j = 0; j < num_robots(); ++j) {
    if (j == i) continue;
    const Robot& o = robots_[j];
    const double ox = o.pose[0] - lx, oy = o.pose[1] - ly, r2 = o.spec.radius_m * o.spec.radius_m;
    const double reach = l.range_max_m + o.spec.radius_m;
    const double d2 = ox * ox + oy * oy;
    if (d2 > reach * reach) continue;
    for (int b = 0; b < nb; ++b) {
      const double proj = dx[b] * ox + dy[b] * oy;
      const double disc = proj * proj - (d2 - r2);
      if (disc < 0) continue;
      const double th = proj - std::sqrt(disc);
      if (th >= 0 && th < robot[b]) robot[b] = th;
    }
  }
  for (int b = 0; b < nb; ++b) lim[b] = std::min(robot[b], l.range_max_m) / res_;
  march_many((lx - ox_) / res_ + 1.0, (ly - oy_) / res_ + 1.0, dx, dy, lim, nb, t);

  std::normal_distribution<double> noise(0.0, l.noise_std_m > 0 ? l.noise_std_m : 1.0);
  for (int b = 0; b < nb; ++b) {
    // A wall hit, else the robot hit that limited the march, else no return.
    const double hit_m = std::min(std::isinf(t[b]) ? kInf : t[b] * res_, robot[b]);
    double range;
    if (!(hit_m <= l.range_max_m)) {
      range = l.no_return_range;
    } else {
      range = hit_m;
      if (l.noise_std_m > 0) range += noise(laser_rng_);
      range = std::clamp(range, l.range_min_m, l.range_max_m);
    }
    out[b] = static_cast<float>(range);
  }
}

int World::total_beams() const {
  int n = 0;
  for (const Robot& r : robots_) n += r.laser.beams;
  return n;
}

void World::scan_all(float* out) {
  for (int i = 0; i < num_robots(); ++i) {
    scan(i, out);
    out += robots_[i].laser.beams;
  }
}

}  // namespace tpuaf
