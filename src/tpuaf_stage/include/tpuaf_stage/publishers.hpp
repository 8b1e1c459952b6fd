// Outputs of the tpuaf_stage node: the advertised topics with their preallocated messages, and
// the publication schedule. Outputs without subscribers are not built.
#pragma once

#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/LaserScan.h>
#include <std_msgs/Bool.h>
#include <tf2_msgs/TFMessage.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "tpuaf_core/world.hpp"
#include "tpuaf_stage/params.hpp"
#include "tpuaf_stage/world_file.hpp"

namespace tpuaf_stage {

// Publication schedule: due at the first step whose time reaches k / rate (exact, by step count).
struct Schedule {
  double rate = 1.0, step = 0.01;
  std::int64_t count = 0;
  bool due(std::int64_t n_steps) {
    const auto k = static_cast<std::int64_t>(std::floor(n_steps * step * rate + 1e-9));
    if (k > count) {
      count = k;
      return true;
    }
    return false;
  }
};

// Per robot, in its namespace: odom, base_pose_ground_truth (nav_msgs/Odometry), <scan_topic>
// (sensor_msgs/LaserScan), stalled (std_msgs/Bool). tf <ns>/odom -> <ns>/base_footprint
// (+ map -> <ns>/odom) on /tf, base_footprint -> base_link -> base_scan on /tf_static. Global:
// /clock (not in wall-clock mode), /fleet/sim_events (std_msgs/String, latched JSON events).
class Publishers {
 public:
  // Advertises every output of the robots in namespaces names; publishes /tf_static once.
  Publishers(ros::NodeHandle& nh, const NodeParams& p, const ResolvedWorld& rw,
             const std::vector<std::string>& names);

  void clock(const ros::Time& stamp);  // /clock (nothing in wall-clock mode)
  // stalled, odom, ground truth and /tf of every robot; with only: odom and ground truth of those
  // robots alone (a lock-step tick re-sent).
  void state(const tpuaf::World& world, const ros::Time& now,
             const std::vector<bool>* only = nullptr);
  // Lasers with subscribers; `every` computes the others too (published to nobody): the
  // laser noise is one stream, so lock-step runs see the same noise whenever agents subscribe.
  void scans(tpuaf::World& world, const ros::Time& now, bool every = false);
  void event(const std::string& json);  // one /fleet/sim_events document

 private:
  int n_;
  bool wall_clock_, publish_map_tf_;

  ros::Publisher clock_pub_, tf_pub_, tf_static_pub_, events_pub_;
  std::vector<ros::Publisher> odom_pub_, gt_pub_, scan_pub_, stall_pub_;

  rosgraph_msgs::Clock clock_msg_;
  std::vector<nav_msgs::Odometry> odom_msg_, gt_msg_;
  std::vector<sensor_msgs::LaserScan> scan_msg_;
  tf2_msgs::TFMessage tf_msg_;
  std_msgs::Bool bool_msg_;
};

}  // namespace tpuaf_stage
