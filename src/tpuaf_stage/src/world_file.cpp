// Resolved world files: strict yaml-cpp reader and binary PGM occupancy image.
#include "tpuaf_stage/world_file.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

namespace tpuaf_stage {
namespace {

std::string where(const std::string& path, const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  if (mark.line >= 0) return path + ":" + std::to_string(mark.line + 1);
  return path;
}

void check_keys(const std::string& path, const YAML::Node& node, const std::set<std::string>& keys,
                const std::string& what) {
  if (!node.IsMap()) throw WorldFileError(where(path, node) + ": " + what + " must be a mapping");
  for (const auto& kv : node) {
    const std::string key = kv.first.as<std::string>();
    if (!keys.count(key)) {
      std::string valid;
      for (const auto& k : keys) valid += (valid.empty() ? "" : ", ") + k;
      throw WorldFileError(where(path, kv.first) + ": unknown key " + key + " in " + what +
                           " (valid: " + valid + ")");
    }
  }
  for (const auto& k : keys) {
    if (!node[k]) throw WorldFileError(where(path, node) + ": missing key '" + k + "' in " + what);
  }
}

double number(const std::string& path, const YAML::Node& node, const std::string& key,
              bool allow_inf = false) {
  const YAML::Node v = node[key];
  double x = 0.0;
  try {
    if (!v.IsScalar()) throw YAML::Exception(v.Mark(), "not a scalar");
    x = v.as<double>();
  } catch (const YAML::Exception&) {
    throw WorldFileError(where(path, v) + ": '" + key + "' must be a number");
  }
  if (std::isnan(x) || (std::isinf(x) && !allow_inf)) {
    throw WorldFileError(where(path, v) + ": '" + key + "' must be a finite number");
  }
  return x;
}

long integer(const std::string& path, const YAML::Node& node, const std::string& key, long lo) {
  const YAML::Node v = node[key];
  long x = 0;
  try {
    x = v.as<long>();
  } catch (const YAML::Exception&) {
    throw WorldFileError(where(path, v) + ": '" + key + "' must be an integer");
  }
  if (x < lo)
    throw WorldFileError(where(path, v) + ": '" + key + "' must be >= " + std::to_string(lo));
  return x;
}

std::string dirname(const std::string& path) {
  const auto slash = path.rfind('/');
  return slash == std::string::npos ? std::string(".") : path.substr(0, slash);
}

// Binary PGM (P5, maxval 255): 0 = occupied, else free; image row 0 = top of the map.
tpuaf::GridMask read_pgm(const std::string& file, int width, int height) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw WorldFileError(file + ": cannot open the occupancy image");
  std::string magic;
  int w = 0, h = 0, maxval = 0;
  in >> magic >> w >> h >> maxval;
  if (!in || magic != "P5" || maxval != 255) {
    throw WorldFileError(file + ": not a binary 8-bit PGM (P5, maxval 255)");
  }
  if (w != width || h != height) {
    throw WorldFileError(file + ": image is " + std::to_string(w) + " x " + std::to_string(h) +
                         ", the world file says " + std::to_string(width) + " x " +
                         std::to_string(height));
  }
  in.get();  // the single whitespace after maxval
  std::vector<unsigned char> pixels(static_cast<size_t>(w) * h);
  in.read(reinterpret_cast<char*>(pixels.data()), static_cast<std::streamsize>(pixels.size()));
  if (in.gcount() != static_cast<std::streamsize>(pixels.size())) {
    throw WorldFileError(file + ": truncated image data");
  }
  tpuaf::GridMask occ(h, w);
  for (int r = 0; r < h; ++r) {
    const unsigned char* row = pixels.data() + static_cast<size_t>(h - 1 - r) * w;
    for (int c = 0; c < w; ++c) occ(r, c) = row[c] == 0;
  }
  return occ;
}

// The robot's section: its limits and odometry noise.
void read_robot(const std::string& path, const YAML::Node& doc, ResolvedWorld& w) {
  const YAML::Node robot = doc["robot"];
  check_keys(path, robot,
             {"radius", "max_linear_speed", "max_angular_speed", "max_linear_accel",
              "max_angular_accel", "odom_linear_noise", "odom_angular_noise", "base_link_z"},
             "robot");
  w.robot.radius_m = number(path, robot, "radius");
  w.robot.max_linear_speed = number(path, robot, "max_linear_speed");
  w.robot.max_angular_speed = number(path, robot, "max_angular_speed");
  w.robot.max_linear_accel = number(path, robot, "max_linear_accel", true);
  w.robot.max_angular_accel = number(path, robot, "max_angular_accel", true);
  w.robot.odom_linear_noise = number(path, robot, "odom_linear_noise");
  w.robot.odom_angular_noise = number(path, robot, "odom_angular_noise");
  w.base_link_z = number(path, robot, "base_link_z");
}

// The laser's section: its beams, ranges, noise, rate and mounting.
void read_laser(const std::string& path, const YAML::Node& doc, ResolvedWorld& w) {
  const YAML::Node laser = doc["laser"];
  check_keys(path, laser,
             {"beams", "angle_min", "angle_increment", "range_min", "range_max", "noise_std",
              "rate", "no_return_range", "x", "y", "z", "yaw"},
             "laser");
  w.laser.beams = static_cast<int>(integer(path, laser, "beams", 1));
  w.laser.angle_min_rad = number(path, laser, "angle_min");
  w.laser.angle_increment_rad = number(path, laser, "angle_increment");
  w.laser.range_min_m = number(path, laser, "range_min");
  w.laser.range_max_m = number(path, laser, "range_max");
  w.laser.noise_std_m = number(path, laser, "noise_std");
  w.laser.no_return_range = number(path, laser, "no_return_range", true);
  w.laser.x_offset_m = number(path, laser, "x");
  w.laser.y_offset_m = number(path, laser, "y");
  w.laser.yaw_offset_rad = number(path, laser, "yaw");
  w.laser_z = number(path, laser, "z");
  w.laser_rate = number(path, laser, "rate");
  if (!(w.laser_rate > 0))
    throw WorldFileError(where(path, laser["rate"]) + ": 'rate' must be > 0 Hz");
}

}  // namespace

bool is_resolved_world(const std::string& path) {
  YAML::Node doc;
  try {
    doc = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw WorldFileError(path + ": world file not found");
  } catch (const YAML::Exception& err) {
    return false;  // the Python parser reports the syntax error with its line
  }
  return doc.IsMap() && doc[kResolvedKey];
}

ResolvedWorld load_resolved_world(const std::string& path) {
  YAML::Node doc;
  try {
    doc = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw WorldFileError(path + ": world file not found");
  } catch (const YAML::Exception& err) {
    throw WorldFileError(path + ":" + std::to_string(err.mark.line + 1) + ": " + err.msg);
  }
  check_keys(path, doc,
             {kResolvedKey, "source", "occupancy", "width", "height", "resolution", "origin",
              "seed", "robot", "laser", "robots", "summary"},
             "the resolved world file");
  if (integer(path, doc, kResolvedKey, 0) != 1) {
    throw WorldFileError(where(path, doc[kResolvedKey]) + ": unsupported resolved format version");
  }
  ResolvedWorld w;
  w.path = path;
  w.source = doc["source"].as<std::string>();
  w.summary = doc["summary"].as<std::string>();
  const int width = static_cast<int>(integer(path, doc, "width", 1));
  const int height = static_cast<int>(integer(path, doc, "height", 1));
  w.resolution = number(path, doc, "resolution");
  if (!(w.resolution > 0))
    throw WorldFileError(where(path, doc["resolution"]) + ": 'resolution' must be > 0");
  const YAML::Node origin = doc["origin"];
  if (!origin.IsSequence() || origin.size() != 2) {
    throw WorldFileError(where(path, origin) + ": 'origin' must be [x, y] [m]");
  }
  w.origin_x = origin[0].as<double>();
  w.origin_y = origin[1].as<double>();
  w.seed = static_cast<std::uint64_t>(integer(path, doc, "seed", 0));
  std::string image = doc["occupancy"].as<std::string>();
  if (image.empty() || image[0] != '/') image = dirname(path) + "/" + image;
  w.occupied = read_pgm(image, width, height);

  read_robot(path, doc, w);
  read_laser(path, doc, w);
  const YAML::Node robots = doc["robots"];
  if (!robots.IsSequence() || robots.size() == 0) {
    throw WorldFileError(where(path, robots) + ": 'robots' must be a non-empty list of poses");
  }
  for (std::size_t i = 0; i < robots.size(); ++i) {
    const YAML::Node p = robots[i];
    if (!p.IsSequence() || p.size() != 3) {
      throw WorldFileError(where(path, p) + ": robots[" + std::to_string(i) +
                           "] must be [x, y, theta] [m, m, rad]");
    }
    w.poses.push_back({p[0].as<double>(), p[1].as<double>(), p[2].as<double>()});
  }
  return w;
}

}  // namespace tpuaf_stage
