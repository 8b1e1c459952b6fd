// Resolved world files of tpuaf_stage (format: src/tpuaf_stage/src/tpuaf_stage/resolve.py).
// ROS-free. Every key is required, unknown keys are refused; errors name the file and line.
#pragma once

#include <array>
#include <stdexcept>
#include <string>
#include <vector>

#include "tpuaf_core/world.hpp"

namespace tpuaf_stage {

// A malformed resolved world file (or its occupancy image); the message names file and line.
class WorldFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ResolvedWorld {
  std::string path;          // the resolved file
  std::string source;        // the world file it was resolved from
  tpuaf::GridMask occupied;  // height x width, row 0 at the bottom
  double resolution = 0.0;   // [m]
  double origin_x = 0.0;     // [m] lower-left corner of cell (0, 0)
  double origin_y = 0.0;     // [m]
  std::uint64_t seed = 0;
  tpuaf::RobotSpec robot;
  double base_link_z = 0.01;  // [m] base_footprint -> base_link (tf only)
  tpuaf::LaserSpec laser;
  double laser_rate = 5.0;                   // [Hz of sim time]
  double laser_z = 0.172;                    // [m] (tf only)
  std::vector<std::array<double, 3>> poses;  // [m, m, rad], map frame
  std::string summary;  // effective values (Python dict text) for the start-up log
};

// The top-level key that marks a resolved file (value: format version 1).
constexpr const char* kResolvedKey = "tpuaf_stage_resolved_world";

// Does the YAML file carry kResolvedKey? (false for plain world files; throws if unreadable)
bool is_resolved_world(const std::string& path);

// Reads a resolved world file and its PGM; throws WorldFileError.
ResolvedWorld load_resolved_world(const std::string& path);

}  // namespace tpuaf_stage
