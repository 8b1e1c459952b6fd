// tpuaf_stage: headless 2-D simulator node (roscpp) on the tpuaf_core world. See docs/SIMULATOR.md.
//
// Per robot i, in namespace <robot_prefix><i>: cmd_vel (geometry_msgs/Twist) and, in lock-step,
// cmd_vel_stamped (geometry_msgs/TwistStamped, the answer to the odom tick of its stamp) in;
// odom, base_pose_ground_truth (nav_msgs/Odometry), <scan_topic> (sensor_msgs/LaserScan),
// stalled (std_msgs/Bool) out. tf <ns>/odom -> <ns>/base_footprint (+ map -> <ns>/odom) on /tf,
// base_footprint -> base_link -> base_scan on /tf_static. Global: /clock (not in wall-clock
// mode), /fleet/sim_events (std_msgs/String, JSON: lock-step and fault events), service
// reset_positions (std_srvs/Empty). Private parameters: strict (unknown ones are refused).
//
// One thread: the loop steps the world and serves callbacks from the global queue between steps
// (while pacing or waiting for lock-step answers), so no state is shared across threads.
#include <geometry_msgs/TransformStamped.h>
#include <geometry_msgs/Twist.h>
#include <geometry_msgs/TwistStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/LaserScan.h>
#include <std_msgs/Bool.h>
#include <std_msgs/Float64.h>
#include <std_msgs/String.h>
#include <std_srvs/Empty.h>
#include <sys/wait.h>
#include <tf2_msgs/TFMessage.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "tpuaf_core/world.hpp"
#include "tpuaf_stage/world_file.hpp"

namespace tpuaf_stage {
namespace {

constexpr const char* kNode = "tpuaf_stage";
constexpr const char* kSimEventsTopic = "/fleet/sim_events";  // = tpuaf.topics.SIM_EVENTS_TOPIC
constexpr const char* kStartTopic = "/fleet/start";           // = tpuaf.topics.START_TOPIC

class ParamError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Python-like text of a double (shortest round trip, "1.0" not "1"), for the effective log.
std::string pyfloat(double x) {
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  if (std::isnan(x)) return "nan";
  char buf[40];
  for (int prec = 1; prec <= 17; ++prec) {
    std::snprintf(buf, sizeof buf, "%.*g", prec, x);
    if (std::strtod(buf, nullptr) == x) break;
  }
  std::string s(buf);
  if (s.find_first_of(".e") == std::string::npos) s += ".0";
  return s;
}

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

// ---------------------------------------------------------------------------------------------
// Parameters

struct NodeParams {
  std::string world;                    // path of the world YAML file (plain or resolved; required)
  double step = 0.01;                   // [s] fixed physics step of simulated time
  double clock_rate = 100.0;            // [Hz of sim time] /clock messages; at most 1 / step
  double real_time_factor = 0.0;        // [-] simulated s per wall s; 0 = as fast as possible
  double odom_rate = 10.0;              // [Hz of sim time] odom, ground truth, stalled, /tf
  std::string robot_prefix = "robot_";  // robot i lives in namespace <robot_prefix><i>
  double cmd_vel_timeout = 0.2;         // [s of sim time] a robot with an older command gets zero
  std::string map_frame = "map";        // global frame of the ground truth and map -> <ns>/odom
  bool publish_map_tf = true;           // also publish map -> <ns>/odom (perfect localisation)
  std::string scan_topic = "base_scan";  // per-robot laser topic (TurtleBot3: scan)
  double status_period = 10.0;           // [s of wall time] between status log lines; 0 = none
  bool lockstep = false;          // step on only once every live agent answered the odom tick
  double lockstep_timeout = 1.0;  // [s of wall time] per tick; a silent agent is unresponsive
  double start_timeout = 60.0;    // [s of wall time] lock-step: wait for every agent at start
  bool wall_clock = false;        // rehearsal: real-time pace, wall-clock stamps, no /clock
  std::string stall = "";         // faults: "R@T,R@T": robot R stops moving at run time T [s]
  std::string summary_file = "";  // JSON of the lock-step and fault events, written at exit
};

struct ParamDoc {
  const char* name;
  const char* kind;  // "double", "bool", "string"
  const char* default_text;
  const char* meaning;  // unit and meaning (as beside NodeParams)
};
const ParamDoc kParams[] = {
    {"world", "string", "(required)", "path of the world YAML file (plain or resolved)"},
    {"step", "double", "0.01", "[s] fixed physics step of simulated time"},
    {"clock_rate", "double", "100", "[Hz of sim time] /clock messages; at most 1 / step"},
    {"real_time_factor", "double", "0", "[-] simulated s per wall s; 0 = as fast as possible"},
    {"odom_rate", "double", "10", "[Hz of sim time] odom, ground truth, stalled, /tf"},
    {"robot_prefix", "string", "robot_", "robot i lives in namespace <robot_prefix><i>"},
    {"cmd_vel_timeout", "double", "0.2", "[s of sim time] a robot with an older command gets zero"},
    {"map_frame", "string", "map", "global frame of the ground truth and map -> <ns>/odom"},
    {"publish_map_tf", "bool", "true", "also publish map -> <ns>/odom (perfect localisation)"},
    {"scan_topic", "string", "base_scan", "per-robot laser topic (TurtleBot3: scan)"},
    {"status_period", "double", "10", "[s of wall time] between status log lines; 0 = none"},
    {"lockstep", "bool", "false", "step on only once every live agent answered the odom tick"},
    {"lockstep_timeout", "double", "1",
     "[s of wall time] per tick; a silent agent is unresponsive"},
    {"start_timeout", "double", "60", "[s of wall time] lock-step: wait for every agent at start"},
    {"wall_clock", "bool", "false", "rehearsal: real-time pace, wall-clock stamps, no /clock"},
    {"stall", "string", "''", "faults: \"R@T,R@T\": robot R stops moving at run time T [s]"},
    {"summary_file", "string", "''", "JSON of the lock-step and fault events, written at exit"},
};

std::string value_text(const XmlRpc::XmlRpcValue& v) {
  XmlRpc::XmlRpcValue copy = v;
  return copy.toXml();
}

NodeParams parse_params(const std::map<std::string, XmlRpc::XmlRpcValue>& values) {
  std::map<std::string, std::string> kinds;
  std::string valid;
  for (const auto& d : kParams) {
    kinds[d.name] = d.kind;
  }
  for (const auto& kv : kinds) valid += (valid.empty() ? "~" : ", ~") + kv.first;
  std::string unknown;
  for (const auto& kv : values) {
    if (!kinds.count(kv.first)) unknown += (unknown.empty() ? "~" : ", ~") + kv.first;
  }
  if (!unknown.empty()) {
    throw ParamError(std::string(kNode) + ": unknown parameter(s) " + unknown +
                     " (valid: " + valid + ")");
  }
  NodeParams p;
  std::map<std::string, double*> doubles = {{"step", &p.step},
                                            {"clock_rate", &p.clock_rate},
                                            {"real_time_factor", &p.real_time_factor},
                                            {"odom_rate", &p.odom_rate},
                                            {"cmd_vel_timeout", &p.cmd_vel_timeout},
                                            {"status_period", &p.status_period},
                                            {"lockstep_timeout", &p.lockstep_timeout},
                                            {"start_timeout", &p.start_timeout}};
  std::map<std::string, bool*> bools = {{"publish_map_tf", &p.publish_map_tf},
                                        {"lockstep", &p.lockstep},
                                        {"wall_clock", &p.wall_clock}};
  std::map<std::string, std::string*> strings = {
      {"world", &p.world},         {"robot_prefix", &p.robot_prefix},
      {"map_frame", &p.map_frame}, {"scan_topic", &p.scan_topic},
      {"stall", &p.stall},         {"summary_file", &p.summary_file}};
  for (const auto& kv : values) {
    XmlRpc::XmlRpcValue v = kv.second;
    const std::string& name = kv.first;
    if (doubles.count(name)) {
      double x;
      if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) {
        x = static_cast<int>(v);
      } else if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
        x = static_cast<double>(v);
      } else {
        throw ParamError(std::string(kNode) + ": ~" + name + " must be a finite number, got " +
                         value_text(v));
      }
      if (!std::isfinite(x)) {
        throw ParamError(std::string(kNode) + ": ~" + name + " must be a finite number, got " +
                         pyfloat(x));
      }
      *doubles[name] = x;
    } else if (bools.count(name)) {
      if (v.getType() != XmlRpc::XmlRpcValue::TypeBoolean) {
        throw ParamError(std::string(kNode) + ": ~" + name + " must be true or false, got " +
                         value_text(v));
      }
      *bools[name] = static_cast<bool>(v);
    } else {
      if (v.getType() != XmlRpc::XmlRpcValue::TypeString) {
        throw ParamError(std::string(kNode) + ": ~" + name + " must be a string, got " +
                         value_text(v));
      }
      *strings[name] = static_cast<std::string>(v);
    }
  }
  auto fail = [](const std::string& msg) { throw ParamError(std::string(kNode) + ": " + msg); };
  if (p.world.empty()) fail("~world (path of the world YAML file) is required");
  if (!(p.step > 0) || p.step < 1e-9) fail("~step must be > 0 s, got " + pyfloat(p.step));
  if (p.real_time_factor < 0) {
    fail("~real_time_factor must be >= 0 (0 = as fast as possible), got " +
         pyfloat(p.real_time_factor));
  }
  if (!(p.clock_rate > 0 && p.clock_rate <= 1.0 / p.step + 1e-9)) {
    fail("~clock_rate must be > 0 and <= 1/step = " + pyfloat(1.0 / p.step) + " Hz, got " +
         pyfloat(p.clock_rate));
  }
  if (!(p.odom_rate > 0)) fail("~odom_rate must be > 0 Hz, got " + pyfloat(p.odom_rate));
  if (!(p.cmd_vel_timeout > 0)) {
    fail("~cmd_vel_timeout must be > 0 s, got " + pyfloat(p.cmd_vel_timeout));
  }
  if (!(p.lockstep_timeout > 0) || !(p.start_timeout >= 0)) {
    fail("~lockstep_timeout must be > 0 s and ~start_timeout >= 0 s");
  }
  if (p.status_period < 0) fail("~status_period must be >= 0 s, got " + pyfloat(p.status_period));
  for (const auto& [name, value] :
       std::vector<std::pair<std::string, std::string>>{{"robot_prefix", p.robot_prefix},
                                                        {"map_frame", p.map_frame},
                                                        {"scan_topic", p.scan_topic}}) {
    if (value.empty() || value[0] == '/' || value.find(' ') != std::string::npos) {
      fail("~" + name + " must be a non-empty relative name, got '" + value + "'");
    }
  }
  if (p.wall_clock && p.real_time_factor != 0 && p.real_time_factor != 1) {
    fail("~wall_clock runs at real time: ~real_time_factor must be 0 or 1, got " +
         pyfloat(p.real_time_factor));
  }
  return p;
}

std::string params_summary(const NodeParams& p) {
  auto s = [](const std::string& x) { return "'" + x + "'"; };
  auto b = [](bool x) { return std::string(x ? "True" : "False"); };
  std::ostringstream o;
  o << "{'world': " << s(p.world) << ", 'step': " << pyfloat(p.step)
    << ", 'clock_rate': " << pyfloat(p.clock_rate)
    << ", 'real_time_factor': " << pyfloat(p.real_time_factor)
    << ", 'odom_rate': " << pyfloat(p.odom_rate) << ", 'robot_prefix': " << s(p.robot_prefix)
    << ", 'cmd_vel_timeout': " << pyfloat(p.cmd_vel_timeout) << ", 'map_frame': " << s(p.map_frame)
    << ", 'publish_map_tf': " << b(p.publish_map_tf) << ", 'scan_topic': " << s(p.scan_topic)
    << ", 'status_period': " << pyfloat(p.status_period) << ", 'lockstep': " << b(p.lockstep)
    << ", 'lockstep_timeout': " << pyfloat(p.lockstep_timeout)
    << ", 'start_timeout': " << pyfloat(p.start_timeout) << ", 'wall_clock': " << b(p.wall_clock)
    << ", 'stall': " << s(p.stall) << ", 'summary_file': " << s(p.summary_file) << "}";
  return o.str();
}

// "R@T,R@T" -> {(R, T)}: robot index >= 0, run time [s] >= 0.
std::vector<std::pair<int, double>> parse_stalls(const std::string& text) {
  std::vector<std::pair<int, double>> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    if (item.empty()) continue;
    const auto at = item.find('@');
    char* end = nullptr;
    long r = at == std::string::npos ? -1 : std::strtol(item.c_str(), &end, 10);
    if (at == std::string::npos || end != item.c_str() + at || r < 0) {
      throw ParamError(std::string(kNode) + ": ~stall items are ROBOT@TIME, got '" + item + "'");
    }
    const std::string ts = item.substr(at + 1);
    double t = std::strtod(ts.c_str(), &end);
    if (ts.empty() || *end != '\0' || !std::isfinite(t) || t < 0) {
      throw ParamError(std::string(kNode) + ": ~stall time must be a number >= 0 s, got '" + item +
                       "'");
    }
    out.emplace_back(static_cast<int>(r), t);
  }
  return out;
}

std::map<std::string, XmlRpc::XmlRpcValue> private_params() {
  std::map<std::string, XmlRpc::XmlRpcValue> out;
  std::vector<std::string> names;
  ros::param::getParamNames(names);
  const std::string prefix = ros::this_node::getName() + "/";
  for (const auto& name : names) {
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    std::string key = name.substr(prefix.size());
    key = key.substr(0, key.find('/'));
    if (out.count(key)) continue;
    XmlRpc::XmlRpcValue v;
    if (ros::param::get(prefix + key, v)) out[key] = v;
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// World files: plain ones are resolved once by the Python parser (tpuaf_stage.resolve).

std::string run_resolver(const std::string& world, std::string& folder) {
  char tmpl[] = "/tmp/tpuaf_stage_world.XXXXXX";
  if (!mkdtemp(tmpl)) throw WorldFileError("cannot create a temporary folder for the world");
  folder = tmpl;
  const char* python = std::getenv("TPUAF_PYTHON");
  const std::string exe = python && *python ? python : "/usr/bin/python3";
  const std::string err_file = folder + "/resolve.err";
  const std::string out_file = folder + "/resolve.out";
  pid_t pid = fork();
  if (pid < 0) throw WorldFileError("cannot start the world file parser");
  if (pid == 0) {
    FILE* e = std::freopen(err_file.c_str(), "w", stderr);
    FILE* o = std::freopen(out_file.c_str(), "w", stdout);
    (void)e;
    (void)o;
    execl(exe.c_str(), exe.c_str(), "-m", "tpuaf_stage.resolve", world.c_str(), folder.c_str(),
          static_cast<char*>(nullptr));
    std::fprintf(stderr, "cannot run %s: %s\n", exe.c_str(), std::strerror(errno));
    _exit(127);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  std::ifstream err_in(err_file);
  std::string line, last;
  while (std::getline(err_in, line)) {
    if (!line.empty()) last = line;
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw WorldFileError(last.empty() ? world + ": the world file parser failed" : last);
  }
  return folder + "/world.resolved.yaml";
}

void remove_folder(const std::string& folder) {
  if (folder.empty()) return;
  for (const char* f :
       {"world.resolved.yaml", "world.occupancy.pgm", "resolve.err", "resolve.out"}) {
    std::remove((folder + "/" + f).c_str());
  }
  rmdir(folder.c_str());
}

// ---------------------------------------------------------------------------------------------
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

using WallClock = std::chrono::steady_clock;
double wall_now() {
  return std::chrono::duration<double>(WallClock::now().time_since_epoch()).count();
}

// ---------------------------------------------------------------------------------------------

class StageNode {
 public:
  StageNode(const NodeParams& p, const ResolvedWorld& rw, tpuaf::World& world)
      : p_(p), rw_(rw), world_(world), n_(world.num_robots()), nh_() {
    step_ns_ = static_cast<std::int64_t>(std::llround(p.step * 1e9));
    clock_ = {p.clock_rate, p.step, 0};
    odom_ = {p.odom_rate, p.step, 0};
    scan_ = {rw.laser_rate, p.step, 0};
    stalls_ = parse_stalls(p.stall);
    for (const auto& s : stalls_) {
      if (s.first >= n_) {
        throw ParamError(std::string(kNode) + ": ~stall robot " + std::to_string(s.first) +
                         " not in 0.." + std::to_string(n_ - 1));
      }
    }
    commands_.assign(n_, {0.0, 0.0});
    last_command_.assign(n_, -std::numeric_limits<double>::infinity());
    answered_.assign(n_, ros::Time(0));
    ever_answered_.assign(n_, false);
    unresponsive_.assign(n_, false);
    gone_.assign(n_, false);
    stalled_fault_.assign(n_, false);
    unresponsive_count_.assign(n_, 0);
    unwaited_ticks_.assign(n_, 0);
    answers_.assign(n_, 0);
    for (int i = 0; i < n_; ++i) ns_.push_back(p.robot_prefix + std::to_string(i));
    advertise();
  }

  const std::vector<std::string>& namespaces() const { return ns_; }

  void spin();
  void write_summary() const;

 private:
  std::string frame(int i, const char* name) const { return ns_[i] + "/" + name; }
  double sim_time() const { return static_cast<double>(steps_) * step_ns_ * 1e-9; }
  ros::Time stamp() const {
    const std::int64_t ns = steps_ * step_ns_;
    ros::Time t;
    t.fromNSec(static_cast<std::uint64_t>(ns));
    if (p_.wall_clock) t = wall_epoch_ + ros::Duration(t.toSec());
    return t;
  }

  void advertise();
  void on_cmd(int i, const geometry_msgs::Twist::ConstPtr& msg);
  void on_cmd_stamped(int i, const geometry_msgs::TwistStamped::ConstPtr& msg);
  bool on_reset(std_srvs::Empty::Request&, std_srvs::Empty::Response&);
  void on_start(const std_msgs::Float64::ConstPtr& msg) { run_start_ = msg->data; }

  void advance();
  void publish_clock();
  void publish_state(const std::vector<bool>* only = nullptr);
  void publish_scans();
  void event(const std::string& kind, int i, const std::string& detail);
  void start_gate();
  void wait_answers();
  void serve(double timeout_s) {
    ros::getGlobalCallbackQueue()->callAvailable(ros::WallDuration(std::max(0.0, timeout_s)));
  }
  void status_line(double now);

  NodeParams p_;
  const ResolvedWorld& rw_;
  tpuaf::World& world_;
  int n_;
  ros::NodeHandle nh_;
  std::vector<std::string> ns_;
  std::int64_t step_ns_ = 0, steps_ = 0;
  Schedule clock_, odom_, scan_;
  ros::Time wall_epoch_;
  double run_start_ = -1.0;  // [s of ROS time] /fleet/start, for ~stall
  std::vector<std::pair<int, double>> stalls_;

  std::vector<std::array<double, 2>> commands_;
  std::vector<double> last_command_;  // [s of sim time]
  std::vector<ros::Time> answered_;   // stamp of the latest lock-step answer
  std::vector<bool> ever_answered_, unresponsive_, gone_, stalled_fault_;
  std::vector<int> unresponsive_count_;
  std::vector<std::int64_t> unwaited_ticks_;
  std::vector<std::int64_t>
      answers_;  // lock-step answers received  // lock-step ticks without an agent to wait for
  std::vector<std::string> events_json_;
  int stale_ = 0;

  ros::Publisher clock_pub_, tf_pub_, tf_static_pub_, events_pub_;
  std::vector<ros::Publisher> odom_pub_, gt_pub_, scan_pub_, stall_pub_;
  std::vector<ros::Subscriber> cmd_sub_, cmd_stamped_sub_;
  ros::Subscriber start_sub_;
  ros::ServiceServer reset_srv_;

  rosgraph_msgs::Clock clock_msg_;
  std::vector<nav_msgs::Odometry> odom_msg_, gt_msg_;
  std::vector<sensor_msgs::LaserScan> scan_msg_;
  tf2_msgs::TFMessage tf_msg_;
  std_msgs::Bool bool_msg_;
};

void StageNode::advertise() {
  // Large queues: roscpp never blocks the loop on a slow subscriber (it drops the oldest).
  const uint32_t q = 1000;
  if (!p_.wall_clock) clock_pub_ = nh_.advertise<rosgraph_msgs::Clock>("/clock", 10);
  tf_pub_ = nh_.advertise<tf2_msgs::TFMessage>("/tf", q);
  tf_static_pub_ = nh_.advertise<tf2_msgs::TFMessage>("/tf_static", 1, true);
  events_pub_ = nh_.advertise<std_msgs::String>(kSimEventsTopic, 100, true);
  const auto& laser = rw_.laser;
  for (int i = 0; i < n_; ++i) {
    const std::string& ns = ns_[i];
    odom_pub_.push_back(nh_.advertise<nav_msgs::Odometry>(ns + "/odom", q));
    gt_pub_.push_back(nh_.advertise<nav_msgs::Odometry>(ns + "/base_pose_ground_truth", q));
    scan_pub_.push_back(nh_.advertise<sensor_msgs::LaserScan>(ns + "/" + p_.scan_topic, q));
    stall_pub_.push_back(nh_.advertise<std_msgs::Bool>(ns + "/stalled", q));
    nav_msgs::Odometry o;
    o.header.frame_id = frame(i, "odom");
    o.child_frame_id = frame(i, "base_footprint");
    odom_msg_.push_back(o);
    nav_msgs::Odometry g;
    g.header.frame_id = p_.map_frame;
    g.child_frame_id = frame(i, "base_footprint");
    gt_msg_.push_back(g);
    sensor_msgs::LaserScan s;
    s.header.frame_id = frame(i, "base_scan");
    s.angle_min = static_cast<float>(laser.angle_min_rad);
    s.angle_increment = static_cast<float>(laser.angle_increment_rad);
    s.angle_max =
        static_cast<float>(laser.angle_min_rad + (laser.beams - 1) * laser.angle_increment_rad);
    s.time_increment = 0.0f;
    s.scan_time = static_cast<float>(1.0 / rw_.laser_rate);
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
  if (p_.publish_map_tf) {
    for (int i = 0; i < n_; ++i) {
      geometry_msgs::TransformStamped t;
      t.header.frame_id = p_.map_frame;
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
    a.transform.translation.z = rw_.base_link_z;
    a.transform.rotation.w = 1.0;
    geometry_msgs::TransformStamped b;
    b.header.frame_id = frame(i, "base_link");
    b.child_frame_id = frame(i, "base_scan");
    b.transform.translation.x = laser.x_offset_m;
    b.transform.translation.y = laser.y_offset_m;
    b.transform.translation.z = rw_.laser_z;
    yaw_quat(b.transform.rotation, laser.yaw_offset_rad);
    st.transforms.push_back(a);
    st.transforms.push_back(b);
  }
  tf_static_pub_.publish(st);

  ros::TransportHints hints = ros::TransportHints().tcpNoDelay();
  for (int i = 0; i < n_; ++i) {
    cmd_sub_.push_back(nh_.subscribe<geometry_msgs::Twist>(
        ns_[i] + "/cmd_vel", 10,
        [this, i](const geometry_msgs::Twist::ConstPtr& m) { on_cmd(i, m); }, ros::VoidConstPtr(),
        hints));
    if (p_.lockstep) {
      cmd_stamped_sub_.push_back(nh_.subscribe<geometry_msgs::TwistStamped>(
          ns_[i] + "/cmd_vel_stamped", 10,
          [this, i](const geometry_msgs::TwistStamped::ConstPtr& m) { on_cmd_stamped(i, m); },
          ros::VoidConstPtr(), hints));
    }
  }
  if (!stalls_.empty()) start_sub_ = nh_.subscribe(kStartTopic, 1, &StageNode::on_start, this);
  reset_srv_ = nh_.advertiseService("reset_positions", &StageNode::on_reset, this);
}

void StageNode::on_cmd(int i, const geometry_msgs::Twist::ConstPtr& msg) {
  commands_[i] = {msg->linear.x, msg->angular.z};
  last_command_[i] = sim_time();
}

void StageNode::on_cmd_stamped(int i, const geometry_msgs::TwistStamped::ConstPtr& msg) {
  commands_[i] = {msg->twist.linear.x, msg->twist.angular.z};
  last_command_[i] = sim_time();
  if (msg->header.stamp > answered_[i]) answered_[i] = msg->header.stamp;
  ++answers_[i];
  ever_answered_[i] = true;
  if (unresponsive_[i]) {
    unresponsive_[i] = false;
    event("responsive", i, "answers again");
  }
}

bool StageNode::on_reset(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  world_.reset();
  for (int i = 0; i < n_; ++i) {
    commands_[i] = {0.0, 0.0};
    last_command_[i] = -std::numeric_limits<double>::infinity();
  }
  ROS_INFO("reset_positions: robots back to their initial poses");
  return true;
}

void StageNode::event(const std::string& kind, int i, const std::string& detail) {
  std::ostringstream j;
  j << "{\"event\": " << json_string(kind) << ", \"robot\": " << i
    << ", \"robot_name\": " << json_string(ns_[i]) << ", \"sim_time_s\": " << pyfloat(sim_time())
    << ", \"detail\": " << json_string(detail) << "}";
  events_json_.push_back(j.str());
  std_msgs::String m;
  m.data = j.str();
  events_pub_.publish(m);
  if (kind == "responsive" || kind == "back") {
    ROS_INFO("%s: %s (%s)", ns_[i].c_str(), detail.c_str(), kind.c_str());
  } else {
    ROS_WARN("%s: %s (%s)", ns_[i].c_str(), detail.c_str(), kind.c_str());
  }
  if (!p_.summary_file.empty()) write_summary();
}

void StageNode::write_summary() const {
  if (p_.summary_file.empty()) return;
  int total = 0;
  std::ostringstream per, unwaited, answers;
  for (int i = 0; i < n_; ++i) {
    total += unresponsive_count_[i];
    per << (i ? ", " : "") << unresponsive_count_[i];
    unwaited << (i ? ", " : "") << unwaited_ticks_[i];
    answers << (i ? ", " : "") << answers_[i];
  }
  std::ostringstream o;
  o << "{\n  \"lockstep\": " << (p_.lockstep ? "true" : "false")
    << ",\n  \"sim_time_s\": " << pyfloat(sim_time()) << ",\n  \"unresponsive_events\": " << total
    << ",\n  \"unresponsive_per_robot\": [" << per.str() << "],\n  \"answers_per_robot\": ["
    << answers.str() << "],\n  \"ticks_without_agent_per_robot\": [" << unwaited.str()
    << "],\n  \"events\": [";
  for (std::size_t k = 0; k < events_json_.size(); ++k) {
    o << (k ? ",\n    " : "\n    ") << events_json_[k];
  }
  o << (events_json_.empty() ? "]\n}\n" : "\n  ]\n}\n");
  const std::string tmp = p_.summary_file + ".tmp";
  {
    std::ofstream f(tmp);
    f << o.str();
  }
  std::rename(tmp.c_str(), p_.summary_file.c_str());
}

void StageNode::advance() {
  const double t = sim_time();
  stale_ = 0;
  tpuaf::Twists cmd(n_, 2);
  const bool faults = run_start_ >= 0 && !stalls_.empty();
  if (faults) {
    for (const auto& s : stalls_) {
      if (!stalled_fault_[s.first] && stamp().toSec() >= run_start_ + s.second) {
        stalled_fault_[s.first] = true;
        event("stall", s.first, "stopped moving (fault injection); its agent goes on");
      }
    }
  }
  for (int i = 0; i < n_; ++i) {
    const bool stale = (t - last_command_[i]) > p_.cmd_vel_timeout + 1e-9;
    stale_ += stale;
    const bool stop = stale || stalled_fault_[i] || (p_.lockstep && unresponsive_[i]);
    cmd(i, 0) = stop ? 0.0 : commands_[i][0];
    cmd(i, 1) = stop ? 0.0 : commands_[i][1];
  }
  world_.set_commands(cmd);
  world_.step(p_.step);
  ++steps_;
}

void StageNode::publish_clock() {
  if (p_.wall_clock) return;
  clock_msg_.clock = stamp();
  clock_pub_.publish(clock_msg_);
}

void StageNode::publish_state(const std::vector<bool>* only) {
  const ros::Time now = stamp();
  auto wanted = [&](int i) { return only == nullptr || (*only)[i]; };
  bool any_stall = false;
  for (int i = 0; i < n_; ++i) any_stall |= stall_pub_[i].getNumSubscribers() > 0;
  if (any_stall && only == nullptr) {
    const std::vector<bool> stalled = world_.stalled();
    for (int i = 0; i < n_; ++i) {
      if (stall_pub_[i].getNumSubscribers() > 0) {
        bool_msg_.data = stalled[i];
        stall_pub_[i].publish(bool_msg_);
      }
    }
  }
  const tpuaf::Poses odom = world_.odom_poses();
  const tpuaf::Twists odom_vel = world_.odom_velocities();
  const tpuaf::Poses truth = world_.poses();
  const tpuaf::Twists vel = world_.velocities();
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
  if (p_.publish_map_tf) {
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

void StageNode::publish_scans() {
  const ros::Time now = stamp();
  for (int i = 0; i < n_; ++i) {
    if (scan_pub_[i].getNumSubscribers() == 0) continue;
    sensor_msgs::LaserScan& m = scan_msg_[i];
    m.header.stamp = now;
    world_.scan(i, m.ranges.data());
    scan_pub_[i].publish(m);
  }
}

// Lock-step: wait (wall clock, ~start_timeout) until every robot's cmd_vel_stamped has a
// publisher, republishing /clock meanwhile; time stands at the first step.
void StageNode::start_gate() {
  const double deadline = wall_now() + p_.start_timeout;
  while (ros::ok()) {
    std::string missing;
    for (int i = 0; i < n_; ++i) {
      if (cmd_stamped_sub_[i].getNumPublishers() == 0)
        missing += (missing.empty() ? "" : ", ") + ns_[i];
    }
    if (missing.empty()) {
      ROS_INFO("lockstep: every robot has a cmd_vel_stamped publisher");
      return;
    }
    if (wall_now() > deadline) {
      ROS_WARN("lockstep: starting without agents for %s after %s s", missing.c_str(),
               pyfloat(p_.start_timeout).c_str());
      return;
    }
    publish_clock();
    serve(0.2);
  }
}

// Lock-step: after the odom tick at stamp T, wait until every live agent has answered T.
// An agent with no cmd_vel_stamped publisher left is gone (not waited for); one silent for
// ~lockstep_timeout is unresponsive (its robot stops; waited for again once it answers). An agent
// that never answered yet gets ~start_timeout and the tick again every 0.5 s (its subscription may
// have connected after the tick was sent).
void StageNode::wait_answers() {
  const ros::Time tick = stamp();
  const double t0 = wall_now();
  double last_resend = t0;
  std::vector<bool> pending(n_);
  while (true) {
    serve(0.0);
    bool any = false, any_new = false;
    for (int i = 0; i < n_; ++i) {
      const bool live = cmd_stamped_sub_[i].getNumPublishers() > 0;
      if (!live && ever_answered_[i] && !gone_[i]) {
        gone_[i] = true;
        event("gone", i, "its agent left (no cmd_vel_stamped publisher); not waited for");
      } else if (live && gone_[i]) {
        gone_[i] = false;
        event("back", i, "its agent is back");
      }
      pending[i] = live && !unresponsive_[i] && answered_[i] < tick;
      unwaited_ticks_[i] += !live;
      any |= pending[i];
      any_new |= pending[i] && !ever_answered_[i];
    }
    if (!any || !ros::ok()) return;
    const double now = wall_now();
    if (any_new && now - last_resend > 0.5 && now - t0 < p_.start_timeout) {
      std::vector<bool> fresh(n_);
      for (int i = 0; i < n_; ++i) fresh[i] = pending[i] && !ever_answered_[i];
      publish_state(&fresh);
      last_resend = now;
    }
    bool late = false;
    for (int i = 0; i < n_; ++i) {
      const double limit = ever_answered_[i] ? p_.lockstep_timeout : p_.start_timeout;
      if (pending[i] && now - t0 > limit) {
        unresponsive_[i] = true;
        ++unresponsive_count_[i];
        event("unresponsive", i,
              "no answer to the tick at " + pyfloat(tick.toSec()) + " s within " + pyfloat(limit) +
                  " s of wall time; robot stopped, not waited for until it answers");
        late = true;
      }
    }
    if (late) continue;
    serve(0.002);
  }
}

void StageNode::status_line(double now) {
  static double last_wall = now, last_sim = sim_time();
  if (p_.status_period <= 0 || now - last_wall < p_.status_period) return;
  const double rtf = (sim_time() - last_sim) / (now - last_wall);
  int contacts = 0;
  for (bool s : world_.stalled()) contacts += s;
  int silent = 0;
  for (int i = 0; i < n_; ++i) silent += unresponsive_[i];
  ROS_INFO(
      "sim time %.1f s, real-time factor %.1f, %d robot(s) in contact, %d without fresh "
      "cmd_vel, %d unresponsive",
      sim_time(), rtf, contacts, stale_, silent);
  last_wall = now;
  last_sim = sim_time();
}

void StageNode::spin() {
  if (p_.wall_clock) wall_epoch_ = ros::Time(ros::WallTime::now().toSec() - p_.step);
  // One step at rest first: /clock is non-zero from start-up (rosbag waits for that).
  advance();
  publish_clock();
  if (p_.lockstep) start_gate();
  publish_scans();
  publish_state();
  if (p_.lockstep) wait_answers();
  const double rtf = p_.wall_clock ? 1.0 : p_.real_time_factor;
  double wall0 = wall_now();
  double sim0 = sim_time();
  std::int64_t k = 0;
  while (ros::ok()) {
    advance();
    if (clock_.due(steps_)) publish_clock();
    const bool scan = scan_.due(steps_);
    if (scan) publish_scans();
    if (odom_.due(steps_)) {
      publish_state();
      if (p_.lockstep) wait_answers();
    }
    if (rtf > 0) {
      const double delay = (sim_time() - sim0) / rtf - (wall_now() - wall0);
      if (delay > 0.0005) {
        serve(delay);  // callbacks while pacing; callAvailable returns early on a callback
        double left = (sim_time() - sim0) / rtf - (wall_now() - wall0);
        while (left > 0.0005 && ros::ok()) {
          serve(left);
          left = (sim_time() - sim0) / rtf - (wall_now() - wall0);
        }
      } else if (delay < -1.0) {  // far behind (e.g. a lock-step wait): do not race to catch up
        wall0 = wall_now();
        sim0 = sim_time();
      }
    } else if (!p_.lockstep) {
      serve(0.0);
    }
    if (++k % 50 == 0) status_line(wall_now());
  }
}

void print_help() {
  std::printf(
      "%s: headless 2-D simulator node (replaces Stage; docs/SIMULATOR.md)\n\n"
      "Private parameters (~name, type, default, meaning):\n",
      kNode);
  for (const auto& d : kParams) {
    std::printf("  ~%-20s %-7s %-12s %s\n", d.name, d.kind, d.default_text, d.meaning);
  }
}

int run(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // log lines reach a redirected stdout at once
  for (int k = 1; k < argc; ++k) {
    if (std::strcmp(argv[k], "--help") == 0 || std::strcmp(argv[k], "-h") == 0) {
      print_help();  // no master needed
      return 0;
    }
  }
  ros::init(argc, argv, kNode);
  ros::NodeHandle nh;
  NodeParams p;
  ResolvedWorld rw;
  std::string tmp_folder;
  try {
    p = parse_params(private_params());
    std::string path = p.world;
    if (!is_resolved_world(path)) path = run_resolver(p.world, tmp_folder);
    rw = load_resolved_world(path);
    remove_folder(tmp_folder);
  } catch (const std::exception& err) {
    remove_folder(tmp_folder);
    ROS_FATAL("%s: %s", kNode, err.what());
    return 2;
  }
  if (p.wall_clock) {
    bool sim = false;
    ros::param::get("/use_sim_time", sim);
    if (sim) ROS_WARN("%s: ~wall_clock with /use_sim_time true: nothing publishes /clock", kNode);
  }
  tpuaf::World world(rw.occupied, rw.resolution, rw.origin_x, rw.origin_y, rw.seed);
  try {
    for (std::size_t i = 0; i < rw.poses.size(); ++i) {
      try {
        world.add_robot(rw.robot, rw.laser, rw.poses[i][0], rw.poses[i][1], rw.poses[i][2]);
      } catch (const std::exception& err) {
        throw WorldFileError((rw.source.empty() ? rw.path : rw.source) + ": robots[" +
                             std::to_string(i) + "]: " + err.what());
      }
    }
  } catch (const std::exception& err) {
    ROS_FATAL("%s: %s", kNode, err.what());
    return 2;
  }
  ROS_INFO("%s parameters (effective): %s", kNode, params_summary(p).c_str());
  ROS_INFO("%s world (effective): %s", kNode, rw.summary.c_str());
  std::unique_ptr<StageNode> node;
  try {
    node = std::make_unique<StageNode>(p, rw, world);
  } catch (const std::exception& err) {
    ROS_FATAL("%s: %s", kNode, err.what());
    return 2;
  }
  ROS_INFO("%s: %d robot(s) in namespaces %s..%s, step %s s, %s%s", kNode, world.num_robots(),
           node->namespaces().front().c_str(), node->namespaces().back().c_str(),
           pyfloat(p.step).c_str(),
           p.wall_clock ? "wall clock (real time, no /clock)"
                        : (p.real_time_factor > 0
                               ? ("real-time factor " + pyfloat(p.real_time_factor)).c_str()
                               : "as fast as possible"),
           p.lockstep ? ", lock-step" : "");
  node->spin();
  node->write_summary();
  return 0;
}

}  // namespace
}  // namespace tpuaf_stage

int main(int argc, char** argv) { return tpuaf_stage::run(argc, argv); }
