#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <cmath>
#include <sstream>

#include "bindings.hpp"
#include "tpuaf_core/world.hpp"

namespace py = pybind11;

namespace {

std::string robot_repr(const tpuaf::RobotSpec& r) {
  std::ostringstream os;
  os << "RobotSpec(radius_m=" << r.radius_m << ", max_linear_speed=" << r.max_linear_speed
     << ", max_angular_speed=" << r.max_angular_speed << ", max_linear_accel=" << r.max_linear_accel
     << ", max_angular_accel=" << r.max_angular_accel
     << ", odom_linear_noise=" << r.odom_linear_noise
     << ", odom_angular_noise=" << r.odom_angular_noise << ")";
  return os.str();
}

std::string laser_repr(const tpuaf::LaserSpec& l) {
  std::ostringstream os;
  os << "LaserSpec(beams=" << l.beams << ", angle_min_rad=" << l.angle_min_rad
     << ", angle_increment_rad=" << l.angle_increment_rad << ", range_min_m=" << l.range_min_m
     << ", range_max_m=" << l.range_max_m << ", noise_std_m=" << l.noise_std_m
     << ", no_return_range=" << l.no_return_range << ", x_offset_m=" << l.x_offset_m
     << ", y_offset_m=" << l.y_offset_m << ", yaw_offset_rad=" << l.yaw_offset_rad << ")";
  return os.str();
}

}  // namespace

// Over 80 lines on purpose: one .def per bound member, in the order of the C++ header; split,
// one class's binding would be scattered.
// long: one pybind11 declaration per bound name, read top to bottom; no logic
void tpuaf::bindings::bind_world(py::module_& m) {
  using tpuaf::LaserSpec;
  using tpuaf::RobotSpec;
  using tpuaf::World;

  py::class_<RobotSpec>(m, "RobotSpec",
                        "Disc robot with differential drive. Defaults: TurtleBot3 Burger-like.")
      .def(py::init([](double radius_m, double max_linear_speed, double max_angular_speed,
                       double max_linear_accel, double max_angular_accel, double odom_linear_noise,
                       double odom_angular_noise) {
             return RobotSpec{radius_m,          max_linear_speed,  max_angular_speed,
                              max_linear_accel,  max_angular_accel, odom_linear_noise,
                              odom_angular_noise};
           }),
           py::arg("radius_m") = 0.105, py::arg("max_linear_speed") = 0.22,
           py::arg("max_angular_speed") = 2.84, py::arg("max_linear_accel") = 2.5,
           py::arg("max_angular_accel") = 3.2, py::arg("odom_linear_noise") = 0.0,
           py::arg("odom_angular_noise") = 0.0,
           "radius_m [m]; speeds [m/s], [rad/s]; accelerations [m/s^2], [rad/s^2] (inf: none); "
           "odometry noise: std of the relative error of distance and rotation [-].")
      .def_readwrite("radius_m", &RobotSpec::radius_m)
      .def_readwrite("max_linear_speed", &RobotSpec::max_linear_speed)
      .def_readwrite("max_angular_speed", &RobotSpec::max_angular_speed)
      .def_readwrite("max_linear_accel", &RobotSpec::max_linear_accel)
      .def_readwrite("max_angular_accel", &RobotSpec::max_angular_accel)
      .def_readwrite("odom_linear_noise", &RobotSpec::odom_linear_noise)
      .def_readwrite("odom_angular_noise", &RobotSpec::odom_angular_noise)
      .def("__repr__", &robot_repr);

  py::class_<LaserSpec>(m, "LaserSpec",
                        "Planar laser. Beam k at angle_min_rad + k angle_increment_rad in the "
                        "laser frame, offset (x, y, yaw) from the robot centre. Defaults: LDS-01-"
                        "like geometry (360 beams, 1 degree, 0.12-3.5 m), no noise, inf for no "
                        "return.")
      .def(py::init([](int beams, double angle_min_rad, double angle_increment_rad,
                       double range_min_m, double range_max_m, double noise_std_m,
                       double no_return_range, double x_offset_m, double y_offset_m,
                       double yaw_offset_rad) {
             return LaserSpec{beams,       angle_min_rad,   angle_increment_rad, range_min_m,
                              range_max_m, noise_std_m,     no_return_range,     x_offset_m,
                              y_offset_m,  yaw_offset_rad};
           }),
           py::arg("beams") = 360, py::arg("angle_min_rad") = 0.0,
           py::arg("angle_increment_rad") = M_PI / 180.0, py::arg("range_min_m") = 0.12,
           py::arg("range_max_m") = 3.5, py::arg("noise_std_m") = 0.0,
           py::arg("no_return_range") = INFINITY, py::arg("x_offset_m") = 0.0,
           py::arg("y_offset_m") = 0.0, py::arg("yaw_offset_rad") = 0.0)
      .def_readwrite("beams", &LaserSpec::beams)
      .def_readwrite("angle_min_rad", &LaserSpec::angle_min_rad)
      .def_readwrite("angle_increment_rad", &LaserSpec::angle_increment_rad)
      .def_readwrite("range_min_m", &LaserSpec::range_min_m)
      .def_readwrite("range_max_m", &LaserSpec::range_max_m)
      .def_readwrite("noise_std_m", &LaserSpec::noise_std_m)
      .def_readwrite("no_return_range", &LaserSpec::no_return_range)
      .def_readwrite("x_offset_m", &LaserSpec::x_offset_m)
      .def_readwrite("y_offset_m", &LaserSpec::y_offset_m)
      .def_readwrite("yaw_offset_rad", &LaserSpec::yaw_offset_rad)
      .def("__repr__", &laser_repr);

  m.def(
      "integrate_arc",
      [](double x, double y, double th, double v, double w, double t) {
        const Eigen::Vector3d p = tpuaf::integrate_arc(Eigen::Vector3d(x, y, th), v, w, t);
        return py::make_tuple(p[0], p[1], p[2]);
      },
      py::arg("x"), py::arg("y"), py::arg("theta"), py::arg("v"), py::arg("w"), py::arg("t"),
      "Pose (x [m], y [m], theta [rad]) after driving the constant twist v [m/s], w [rad/s] for "
      "t [s]: the exact arc.");

  py::class_<World>(m, "World",
                    "2-D world: occupancy grid (row 0 = bottom row, outside = occupied), disc "
                    "robots with differential drive, lasers, FCL contacts. Map frame, m, s, rad. "
                    "Deterministic for a seed.")
      .def(py::init([](py::array_t<bool, py::array::c_style | py::array::forcecast> occupied,
                       double resolution_m, std::pair<double, double> origin, std::uint64_t seed) {
             if (occupied.ndim() != 2) throw py::value_error("occupied must be a 2-D bool array");
             const auto h = occupied.shape(0), w = occupied.shape(1);
             tpuaf::GridMask grid(h, w);
             std::copy(occupied.data(), occupied.data() + h * w, grid.data());
             py::gil_scoped_release release;
             return World(grid, resolution_m, origin.first, origin.second, seed);
           }),
           py::arg("occupied"), py::arg("resolution_m"), py::arg("origin") = std::make_pair(0.0, 0.0),
           py::arg("seed") = 0,
           "occupied: (height, width) bool, row 0 the bottom row of the map; resolution_m [m per "
           "cell]; origin: (x, y) [m] of the lower-left corner of cell (0, 0); seed for the noise.")
      .def(
          "add_robot",
          [](World& w, std::tuple<double, double, double> pose, const RobotSpec& robot,
             const LaserSpec& laser) {
            return w.add_robot(robot, laser, std::get<0>(pose), std::get<1>(pose), std::get<2>(pose));
          },
          py::arg("pose"), py::arg("robot") = RobotSpec(), py::arg("laser") = LaserSpec(),
          "Adds a robot at pose (x [m], y [m], theta [rad]); ValueError if it touches a wall or a "
          "robot. Returns its index.")
      .def_property_readonly("num_robots", &World::num_robots)
      .def_property_readonly("width", &World::width, "[cells]")
      .def_property_readonly("height", &World::height, "[cells]")
      .def_property_readonly("resolution", &World::resolution, "[m per cell]")
      .def_property_readonly("origin", [](const World& w) { return py::make_tuple(w.origin_x(), w.origin_y()); },
                             "(x, y) [m] of the lower-left corner of cell (0, 0)")
      .def_property_readonly("time", &World::time, "simulated time [s]")
      .def_property_readonly("seed", &World::seed)
      .def("robot_spec", &World::robot_spec, py::arg("i"))
      .def("laser_spec", &World::laser_spec, py::arg("i"))
      .def("set_command", &World::set_command, py::arg("i"), py::arg("v"), py::arg("w"),
           "Commanded twist of robot i: v [m/s], w [rad/s] (clamped to its limits when stepping).")
      .def("set_commands", &World::set_commands, py::arg("commands"),
           "Commanded twists, one row (v [m/s], w [rad/s]) per robot.")
      .def("commands", &World::commands)
      .def("step", &World::step, py::arg("dt"), py::call_guard<py::gil_scoped_release>(),
           "Advances by dt [s]: acceleration limits, exact arcs, sub-stepped FCL contact checks; "
           "a contact stops the robot before it and flags it stalled.")
      .def("poses", &World::poses, "Ground truth (x [m], y [m], theta [rad]) per robot, map frame.")
      .def("velocities", &World::velocities, "Ground-truth twist (v [m/s], w [rad/s]) per robot.")
      .def("odom_poses", &World::odom_poses,
           "Odometry (x [m], y [m], theta [rad]) per robot in its odom frame (0 at the start).")
      .def("odom_velocities", &World::odom_velocities,
           "Measured twist (v [m/s], w [rad/s]) per robot, with odometry noise.")
      .def("stalled", [](const World& w) {
             const auto s = w.stalled();
             py::array_t<bool> out(static_cast<py::ssize_t>(s.size()));
             for (size_t i = 0; i < s.size(); ++i) out.mutable_at(i) = s[i];
             return out;
           },
           "Per robot: did a contact stop it during the last step?")
      .def("contact_counts", &World::contact_counts, "Per robot: contacts since start or reset.")
      .def("set_pose", &World::set_pose, py::arg("i"), py::arg("x"), py::arg("y"),
           py::arg("theta"), py::arg("reset_odometry") = true,
           "Teleports robot i; ValueError if the pose touches a wall or a robot.")
      .def("reset", &World::reset,
           "All robots to their initial poses, at rest, odometry zero (time unchanged).")
      .def("disc_hits_wall", &World::disc_hits_wall, py::arg("x"), py::arg("y"),
           py::arg("radius_m"), "Does a disc at (x, y) [m] touch a wall or the map edge (FCL)?")
      .def("disc_hits_robot", &World::disc_hits_robot, py::arg("x"), py::arg("y"),
           py::arg("radius_m"), py::arg("ignore") = -1,
           "Index of a robot the disc touches (FCL), or -1.")
      .def("cast_ray", &World::cast_ray, py::arg("x"), py::arg("y"), py::arg("theta"),
           py::arg("max_range_m"), "Distance [m] to the first wall along a ray, inf beyond max.")
      .def("clearance", &World::clearance, py::arg("x"), py::arg("y"),
           "Lower bound [m] of the distance from (x, y) to the nearest occupied cell.")
      .def(
          "scan",
          [](World& w, int i) {
            const int beams = w.laser_spec(i).beams;
            py::array_t<float> out(beams);
            float* data = out.mutable_data();
            {
              py::gil_scoped_release release;
              w.scan(i, data);
            }
            return out;
          },
          py::arg("i"), "Laser ranges [m] of robot i (float32, one per beam).")
      .def(
          "scan_all",
          [](World& w) {
            const int n = w.num_robots();
            const int beams = n > 0 ? w.laser_spec(0).beams : 0;
            for (int i = 1; i < n; ++i) {
              if (w.laser_spec(i).beams != beams) {
                throw py::value_error("scan_all needs the same beam count on every robot; use scan(i)");
              }
            }
            py::array_t<float> out({n, beams});
            float* data = out.mutable_data();
            {
              py::gil_scoped_release release;
              w.scan_all(data);
            }
            return out;
          },
          "Laser ranges [m] of all robots in one call: (num_robots, beams) float32.");
}
