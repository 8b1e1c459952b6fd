// 2-D simulated world: occupancy grid, differential-drive disc robots, 2-D lasers, FCL contacts.
//
// Frames and units: the map frame, metres, seconds, radians. Grid row 0 is the BOTTOM row
// (y up); cell (row r, column c) covers x in [ox + c res, ox + (c+1) res), y in
// [oy + r res, oy + (r+1) res). Everything outside the grid is occupied (a bounded world).
// Deterministic for a seed: the laser noise and the odometry noise use separate streams.
#pragma once

#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>

namespace tpuaf {

using GridMask = Eigen::Matrix<bool, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using Poses = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;     // x [m], y [m], th [rad]
using Twists = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;    // v [m/s], w [rad/s]

// A disc robot with differential drive. Limits must be > 0; accelerations may be +inf.
struct RobotSpec {
  double radius_m = 0.105;                 // TurtleBot3 Burger-like
  double max_linear_speed = 0.22;          // [m/s]
  double max_angular_speed = 2.84;         // [rad/s]
  double max_linear_accel = 2.5;           // [m/s^2]
  double max_angular_accel = 3.2;          // [rad/s^2]
  double odom_linear_noise = 0.0;          // std of the relative error of odometry distance [-]
  double odom_angular_noise = 0.0;         // std of the relative error of odometry rotation [-]
};

// A planar laser. Beam k points at angle_min + k angle_increment in the laser frame, which is
// offset by (x, y, yaw) from the robot centre. Returns beyond range_max read no_return_range;
// returns closer than range_min read range_min. Noise: Gaussian, std noise_std_m, on returns only,
// clamped to [range_min, range_max].
struct LaserSpec {
  int beams = 360;
  double angle_min_rad = 0.0;
  double angle_increment_rad = 0.017453292519943295;  // 1 degree
  double range_min_m = 0.12;
  double range_max_m = 3.5;
  double noise_std_m = 0.0;
  double no_return_range = std::numeric_limits<double>::infinity();
  double x_offset_m = 0.0;
  double y_offset_m = 0.0;
  double yaw_offset_rad = 0.0;
};

// Pose reached after driving the constant twist (v, w) for t seconds from (x, y, th): the exact arc.
Eigen::Vector3d integrate_arc(const Eigen::Vector3d& pose, double v, double w, double t);

class World {
 public:
  // occupied: height x width, row 0 at the bottom; resolution_m > 0; origin: lower-left corner
  // of cell (0, 0) [m]; seed for the noise streams.
  World(const GridMask& occupied, double resolution_m, double origin_x_m, double origin_y_m,
        std::uint64_t seed = 0);

  // Adds a robot at (x, y, th); throws std::invalid_argument if the spec is invalid or the disc
  // touches a wall or another robot. Returns its index.
  int add_robot(const RobotSpec& robot, const LaserSpec& laser, double x, double y, double th);

  int num_robots() const { return static_cast<int>(robots_.size()); }
  int width() const { return width_; }
  int height() const { return height_; }
  double resolution() const { return res_; }
  double origin_x() const { return ox_; }
  double origin_y() const { return oy_; }
  double time() const { return time_s_; }
  std::uint64_t seed() const { return seed_; }
  const RobotSpec& robot_spec(int i) const;
  const LaserSpec& laser_spec(int i) const;

  // Commanded twist (clamped to the limits at the next step).
  void set_command(int i, double v, double w);
  void set_commands(const Twists& commands);
  Twists commands() const;

  // Advances by dt [s]: acceleration-limited velocities, exact arcs, sub-stepped contact checks
  // (FCL). A contact stops the robot just before the contact and flags it as stalled.
  void step(double dt);

  Poses poses() const;            // ground truth, map frame
  Twists velocities() const;      // ground truth, robot frame (v, w)
  Poses odom_poses() const;       // odometry, odom frame (starts at 0 where the robot starts)
  Twists odom_velocities() const; // measured (noisy) twist, robot frame
  std::vector<bool> stalled() const;  // contact during the last step
  std::vector<std::int64_t> contact_counts() const;  // contacts since start / reset

  // Teleports robot i (throws on contact; leaves the world unchanged then). Velocities and its
  // odometry restart at zero when reset_odometry.
  void set_pose(int i, double x, double y, double th, bool reset_odometry = true);
  // All robots back to their initial poses, at rest, odometry zero, time unchanged.
  void reset();

  // Does a disc of radius_m at (x, y) touch a wall (FCL)? Or any robot other than `ignore`?
  bool disc_hits_wall(double x, double y, double radius_m) const;
  int disc_hits_robot(double x, double y, double radius_m, int ignore) const;  // index or -1

  // One laser scan of robot i; out must hold laser_spec(i).beams floats.
  void scan(int i, float* out);
  // Scans of all robots in index order, concatenated.
  void scan_all(float* out);
  int total_beams() const;
  // Distance [m] along a ray from (x, y) at angle th to the first wall, or +inf beyond max_range_m.
  double cast_ray(double x, double y, double th, double max_range_m) const;
  // Clearance lower bound [m] from a point to the nearest occupied cell (ray-marching field).
  double clearance(double x, double y) const;

 private:
  struct Robot {
    RobotSpec spec;
    LaserSpec laser;
    Eigen::Vector3d pose, initial_pose, odom;
    double v = 0, w = 0;          // actual [m/s, rad/s]
    double cmd_v = 0, cmd_w = 0;  // commanded
    double odom_v = 0, odom_w = 0;
    bool stalled = false;
    std::int64_t contacts = 0;
  };
  bool occupied_padded(int px, int py) const;
  void march_many(double gx, double gy, const double* dx, const double* dy, const double* tmax,
                  int n, double* t_out) const;
  bool robot_pose_free(int i, double x, double y) const;
  void check_index(int i) const;
  void move_robot(int i, double dt);

  int width_, height_, pw_, ph_;   // map size and padded size (one occupied ring) [cells]
  double res_, ox_, oy_;
  // Padded (one occupied ring), row-major, row 0 bottom: 0 = occupied, else a quantised clearance.
  std::vector<std::uint8_t> field_;
  std::vector<Robot> robots_;
  std::uint64_t seed_;
  std::mt19937_64 laser_rng_, odom_rng_;
  double time_s_ = 0.0;
};

}  // namespace tpuaf
