// Outputs of the tpuaf_stage node: advertising, the preallocated messages, and publishing clock,
// odometry, ground truth, stalled, tf, scans and sim events (tpuaf_stage/publishers.hpp).
#include "tpuaf_stage/publishers.hpp"

#include <geometry_msgs/TransformStamped.h>
#include <std_msgs/String.h>

namespace tpuaf_stage {
namespace {

constexpr const char* kSimEventsTopic = "/fleet/sim_events";  // = tpuaf.topics.SIM_EVENTS_TOPIC

void yaw_quat(geometry_msgs::Quaternion& q, double yaw) {
  q.x = q.y = 0.0;
  q.z = std::sin(0.5 * yaw);
  q.w = std::cos(0.5 * yaw);
}

// Odometry of robot i (pose row and robot-frame twist row), published only when subscribed.
void publish_odometry(ros::Publisher& pub, nav_msgs::Odometry& m, const ros::Time& stamp,
                      const tpuaf::Poses& poses, const tpuaf::Twists& twists, int i) {
  if (pub.getNumSubscribers() == 0) return;
  m.header.stamp = stamp;
  m.pose.pose.position.x = poses(i, 0);
  m.pose.pose.position.y = poses(i, 1);
  yaw_quat(m.pose.pose.orientation, poses(i, 2));
  m.twist.twist.linear.x = twists(i, 0);
  m.twist.twist.angular.z = twists(i, 1);
  pub.publish(m);
}

}  // namespace

Publishers::Publishers(ros::NodeHandle& nh, const NodeParams& p, const ResolvedWorld& rw,
                       const std::vector<std::string>& names)
    : n_(static_cast<int>(names.size())),
      wall_clock_(p.wall_clock),
      publish_map_tf_(p.publish_map_tf) {
  auto frame = [&names](int i, const char* name) { return names[i] + "/" + name; };
  // Large queues: roscpp never blocks the loop on a slow subscriber (it drops the oldest).
  const uint32_t q = 1000;
  if (!p.wall_clock) clock_pub_ = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
  tf_pub_ = nh.advertise<tf2_msgs::TFMessage>("/tf", q);
  tf_static_pub_ = nh.advertise<tf2_msgs::TFMessage>("/tf_static", 1, true);
  events_pub_ = nh.advertise<std_msgs::String>(kSimEventsTopic, 100, true);
  const auto& laser = rw.laser;
  for (int i = 0; i < n_; ++i) {
    const std::string& ns = names[i];
    odom_pub_.push_back(nh.advertise<nav_msgs::Odometry>(ns + "/odom", q));
    gt_pub_.push_back(nh.advertise<nav_msgs::Odometry>(ns + "/base_pose_ground_truth", q));
    scan_pub_.push_back(nh.advertise<sensor_msgs::LaserScan>(ns + "/" + p.scan_topic, q));
    stall_pub_.push_back(nh.advertise<std_msgs::Bool>(ns + "/stalled", q));
    nav_msgs::Odometry o;
    o.header.frame_id = frame(i, "odom");
    o.child_frame_id = frame(i, "base_footprint");
    odom_msg_.push_back(o);
    nav_msgs::Odometry g;
    g.header.frame_id = p.map_frame;
    g.child_frame_id = frame(i, "base_footprint");
    gt_msg_.push_back(g);
    sensor_msgs::LaserScan s;
    s.header.frame_id = frame(i, "base_scan");
    s.angle_min = static_cast<float>(laser.angle_min_rad);
    s.angle_increment = static_cast<float>(laser.angle_increment_rad);
    s.angle_max =
        static_cast<float>(laser.angle_min_rad + (laser.beams - 1) * laser.angle_increment_rad);
    s.time_increment = 0.0f;
    s.scan_time = static_cast<float>(1.0 / rw.laser_rate);
    s.range_min = static_cast<float>(laser.range_min_m);
    s.range_max = static_cast<float>(laser.range_max_m);
    s.ranges.resize(laser.beams);
    scan_msg_.push_back(s);
  }
  // /tf: odom -> base_footprint of every robot, then map -> odom of every robot.
  for (int i = 0; i < n_; ++i) {
    geometry_msgs::TransformStamped t;
    t.header.frame_id = frame(i, "odom");
    t.child_frame_id = frame(i, "base_footprint");
    tf_msg_.transforms.push_back(t);
  }
  if (p.publish_map_tf) {
    for (int i = 0; i < n_; ++i) {
      geometry_msgs::TransformStamped t;
      t.header.frame_id = p.map_frame;
      t.child_frame_id = frame(i, "odom");
      tf_msg_.transforms.push_back(t);
    }
  }
  // Static chain base_footprint -> base_link -> base_scan, latched once.
  tf2_msgs::TFMessage st;
  for (int i = 0; i < n_; ++i) {
    geometry_msgs::TransformStamped a;
    a.header.frame_id = frame(i, "base_footprint");
    a.child_frame_id = frame(i, "base_link");
    a.transform.translation.z = rw.base_link_z;
    a.transform.rotation.w = 1.0;
    geometry_msgs::TransformStamped b;
    b.header.frame_id = frame(i, "base_link");
    b.child_frame_id = frame(i, "base_scan");
    b.transform.translation.x = laser.x_offset_m;
    b.transform.translation.y = laser.y_offset_m;
    b.transform.translation.z = rw.laser_z;
    yaw_quat(b.transform.rotation, laser.yaw_offset_rad);
    st.transforms.push_back(a);
    st.transforms.push_back(b);
  }
  tf_static_pub_.publish(st);
}

void Publishers::clock(const ros::Time& stamp) {
  if (wall_clock_) return;
  clock_msg_.clock = stamp;
  clock_pub_.publish(clock_msg_);
}

void Publishers::state(const tpuaf::World& world, const ros::Time& now,
                       const std::vector<bool>* only) {
  auto wanted = [&](int i) { return only == nullptr || (*only)[i]; };
  bool any_stall = false;
  for (int i = 0; i < n_; ++i) any_stall |= stall_pub_[i].getNumSubscribers() > 0;
  if (any_stall && only == nullptr) {
    const std::vector<bool> stalled = world.stalled();
    for (int i = 0; i < n_; ++i) {
      if (stall_pub_[i].getNumSubscribers() > 0) {
        bool_msg_.data = stalled[i];
        stall_pub_[i].publish(bool_msg_);
      }
    }
  }
  const tpuaf::Poses odom = world.odom_poses();
  const tpuaf::Twists odom_vel = world.odom_velocities();
  const tpuaf::Poses truth = world.poses();
  const tpuaf::Twists vel = world.velocities();
  for (int i = 0; i < n_; ++i) {
    if (!wanted(i)) continue;
    publish_odometry(odom_pub_[i], odom_msg_[i], now, odom, odom_vel, i);
    publish_odometry(gt_pub_[i], gt_msg_[i], now, truth, vel, i);
  }
  if (only != nullptr || tf_pub_.getNumSubscribers() == 0) return;
  for (int i = 0; i < n_; ++i) {
    auto& t = tf_msg_.transforms[i];
    t.header.stamp = now;
    t.transform.translation.x = odom(i, 0);
    t.transform.translation.y = odom(i, 1);
    yaw_quat(t.transform.rotation, odom(i, 2));
  }
  if (publish_map_tf_) {
    for (int i = 0; i < n_; ++i) {
      // map -> odom = truth * odom^-1 (perfect localisation).
      auto& t = tf_msg_.transforms[n_ + i];
      const double yaw = truth(i, 2) - odom(i, 2);
      const double c = std::cos(yaw), s = std::sin(yaw);
      t.header.stamp = now;
      t.transform.translation.x = truth(i, 0) - (c * odom(i, 0) - s * odom(i, 1));
      t.transform.translation.y = truth(i, 1) - (s * odom(i, 0) + c * odom(i, 1));
      yaw_quat(t.transform.rotation, yaw);
    }
  }
  tf_pub_.publish(tf_msg_);
}

void Publishers::scans(tpuaf::World& world, const ros::Time& now, bool every) {
  for (int i = 0; i < n_; ++i) {
    const bool heard = scan_pub_[i].getNumSubscribers() > 0;
    if (!heard && !every) continue;
    sensor_msgs::LaserScan& m = scan_msg_[i];
    m.header.stamp = now;
    world.scan(i, m.ranges.data());
    if (heard) scan_pub_[i].publish(m);
  }
}

void Publishers::event(const std::string& json) {
  std_msgs::String m;
  m.data = json;
  events_pub_.publish(m);
}

}  // namespace tpuaf_stage
