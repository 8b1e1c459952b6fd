// tpuaf_stage: headless 2-D simulator node (roscpp) on the tpuaf_core world (docs/SIMULATOR.md).
// The wiring and main: parameters and world in, subscriptions, stepping, watchdog and pacing. One
// thread: the loop steps the world and serves callbacks between steps (pacing, lock-step waits).
#include <geometry_msgs/Twist.h>
#include <geometry_msgs/TwistStamped.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <std_msgs/Int64MultiArray.h>
#include <std_srvs/Empty.h>
#include <topic_tools/shape_shifter.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "tpuaf_core/world.hpp"
#include "tpuaf_stage/json_text.hpp"
#include "tpuaf_stage/lockstep.hpp"
#include "tpuaf_stage/params.hpp"
#include "tpuaf_stage/publishers.hpp"
#include "tpuaf_stage/resolver.hpp"
#include "tpuaf_stage/world_file.hpp"

namespace tpuaf_stage {
namespace {

constexpr const char* kStartTopic = "/fleet/start";  // = tpuaf.topics.START_TOPIC

// [s of ROS time] the epoch of a run start on /fleet/start, read without depending on the
// tpuaf_ros messages (they are built after this package): tpuaf_ros/RunStart begins with its
// std_msgs/Header (uint32 seq, uint32 sec, uint32 nsec); version 1 was a std_msgs/Float64. NaN:
// neither, or too short.
double run_start_epoch(const topic_tools::ShapeShifter& msg) {
  std::vector<uint8_t> raw(msg.size());
  ros::serialization::OStream out(raw.data(), static_cast<uint32_t>(raw.size()));
  msg.write(out);
  if (msg.getDataType() == "tpuaf_ros/RunStart" && raw.size() >= 12) {
    uint32_t sec = 0, nsec = 0;
    std::memcpy(&sec, raw.data() + 4, 4);
    std::memcpy(&nsec, raw.data() + 8, 4);
    return sec + nsec * 1e-9;
  }
  if (msg.getDataType() == "std_msgs/Float64" && raw.size() >= 8) {
    double data = 0;
    std::memcpy(&data, raw.data(), 8);
    return data;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

std::vector<std::string> robot_namespaces(const std::string& prefix, int n) {
  std::vector<std::string> ns;
  for (int i = 0; i < n; ++i) ns.push_back(prefix + std::to_string(i));
  return ns;
}

class StageNode {
 public:
  StageNode(const NodeParams& p, const ResolvedWorld& rw, tpuaf::World& world)
      : p_(p),
        world_(world),
        n_(world.num_robots()),
        nh_(),
        ns_(robot_namespaces(p.robot_prefix, n_)),
        step_ns_(static_cast<std::int64_t>(std::llround(p.step * 1e9))),
        clock_{p.clock_rate, p.step, 0},
        odom_{p.odom_rate, p.step, 0},
        scan_{rw.laser_rate, p.step, 0},
        stalls_(parse_stalls(p.stall, n_)),  // throws ParamError before anything is advertised
        commands_(n_, {0.0, 0.0}),
        last_command_(n_, -std::numeric_limits<double>::infinity()),
        stalled_fault_(n_, false),
        start_latched_(n_, false),
        pubs_(nh_, p, rw, ns_),
        lockstep_(ns_, p.lockstep_timeout, p.start_timeout,
                  {[this](double timeout_s) { serve(timeout_s); }, [this] { publish_clock(); },
                   [this](const std::vector<bool>& robots) { publish_state(&robots); },
                   [this](const std::string& kind, int i, const std::string& detail) {
                     event(kind, i, detail);
                   }}) {
    subscribe();
  }

  const std::vector<std::string>& namespaces() const { return ns_; }

  void spin();
  void write_summary() const;

 private:
  double sim_time() const { return static_cast<double>(steps_) * step_ns_ * 1e-9; }
  ros::Time stamp() const {
    const std::int64_t ns = steps_ * step_ns_;
    ros::Time t;
    t.fromNSec(static_cast<std::uint64_t>(ns));
    if (p_.wall_clock) t = wall_epoch_ + ros::Duration(t.toSec());
    return t;
  }

  void subscribe();
  void on_cmd(int i, const geometry_msgs::Twist::ConstPtr& msg);
  void on_cmd_stamped(int i, const geometry_msgs::TwistStamped::ConstPtr& msg);
  bool on_reset(std_srvs::Empty::Request&, std_srvs::Empty::Response&);
  void on_start(const ros::MessageEvent<topic_tools::ShapeShifter const>& event);
  void hold_for_start();

  void advance();
  void publish_clock() { pubs_.clock(stamp()); }
  void publish_state(const std::vector<bool>* only = nullptr) {
    pubs_.state(world_, stamp(), only);
  }
  void publish_scans() { pubs_.scans(world_, stamp(), p_.lockstep); }
  void event(const std::string& kind, int i, const std::string& detail);
  void serve(double timeout_s) {
    ros::getGlobalCallbackQueue()->callAvailable(ros::WallDuration(std::max(0.0, timeout_s)));
  }
  void status_line(double now);

  NodeParams p_;
  tpuaf::World& world_;
  int n_;
  ros::NodeHandle nh_;
  std::vector<std::string> ns_;
  std::int64_t step_ns_ = 0, steps_ = 0;
  Schedule clock_, odom_, scan_;
  ros::Time wall_epoch_;
  double run_start_ = -1.0;  // [s of ROS time] /fleet/start, for ~stall and ~start_hold
  bool held_ = false;        // ~start_hold done
  std::vector<std::pair<int, double>> stalls_;

  std::vector<std::array<double, 2>> commands_;
  std::vector<double> last_command_;  // [s of sim time]
  std::vector<bool> stalled_fault_;
  std::vector<bool> start_latched_;  // ~start_hold: the robot's agent re-latched the start
  std::vector<std::string> events_json_;
  int stale_ = 0;

  Publishers pubs_;
  Lockstep lockstep_;
  std::vector<ros::Subscriber> cmd_sub_, team_sub_;
  ros::Subscriber start_sub_;
  ros::ServiceServer reset_srv_;
};

// Inputs, per robot in its namespace: cmd_vel (geometry_msgs/Twist) and, in lock-step,
// cmd_vel_stamped (geometry_msgs/TwistStamped, the answer to the odom tick of its stamp) and, with
// ~lockstep_team, lockstep_team (std_msgs/Int64MultiArray, its team message counts). Global:
// /fleet/start (tpuaf_ros/RunStart or std_msgs/Float64, run start for ~stall), service
// reset_positions (std_srvs/Empty).
void StageNode::subscribe() {
  ros::TransportHints hints = ros::TransportHints().tcpNoDelay();
  for (int i = 0; i < n_; ++i) {
    cmd_sub_.push_back(nh_.subscribe<geometry_msgs::Twist>(
        ns_[i] + "/cmd_vel", 10,
        [this, i](const geometry_msgs::Twist::ConstPtr& m) { on_cmd(i, m); }, ros::VoidConstPtr(),
        hints));
    if (p_.lockstep) {
      lockstep_.add_subscriber(nh_.subscribe<geometry_msgs::TwistStamped>(
          ns_[i] + "/cmd_vel_stamped", 10,
          [this, i](const geometry_msgs::TwistStamped::ConstPtr& m) { on_cmd_stamped(i, m); },
          ros::VoidConstPtr(), hints));
      if (p_.lockstep_team) {
        team_sub_.push_back(nh_.subscribe<std_msgs::Int64MultiArray>(
            ns_[i] + "/lockstep_team", 100,
            [this, i](const std_msgs::Int64MultiArray::ConstPtr& m) {
              lockstep_.on_team_counts(i, m->data);
            },
            ros::VoidConstPtr(), hints));
      }
    }
  }
  if (p_.lockstep && p_.lockstep_team) lockstep_.enable_team();
  if (!stalls_.empty() || (p_.lockstep && p_.start_hold > 0))
    start_sub_ = nh_.subscribe(kStartTopic, 10, &StageNode::on_start, this);
  reset_srv_ = nh_.advertiseService("reset_positions", &StageNode::on_reset, this);
}

// The earliest start heard: every agent re-latches the team's epoch (the robots whose agent did
// are marked: ~start_hold waits for them).
void StageNode::on_start(const ros::MessageEvent<topic_tools::ShapeShifter const>& event) {
  const double start = run_start_epoch(*event.getMessage());
  if (!(std::isfinite(start) && start >= 0)) return;
  if (run_start_ < 0 || start < run_start_) run_start_ = start;
  const std::string node = event.getPublisherName() + "/";
  for (int i = 0; i < n_; ++i) {
    if (node.rfind("/" + ns_[i] + "/", 0) == 0) start_latched_[i] = true;
  }
}

// Lock-step, ~start_hold: simulated time stands at the hold (after the tick's answers) until a
// run start was announced and every agent with a lock-step publisher has re-latched it (it will
// begin at the start, whatever the wall clock did meanwhile), at most ~start_timeout. The start
// is then the same in every run: the monitor announces it start_delay after the clock's present.
void StageNode::hold_for_start() {
  const double deadline = wall_now() + p_.start_timeout;
  ROS_INFO("lockstep: time stands at %s s until every agent has the run start",
           pyfloat(sim_time()).c_str());
  while (ros::ok()) {
    bool all = run_start_ >= 0;
    for (int i = 0; i < n_ && all; ++i) all = start_latched_[i] || !lockstep_.has_agent(i);
    if (all) return;
    if (wall_now() > deadline) {
      ROS_WARN("lockstep: going on without the run start of every agent after %s s",
               pyfloat(p_.start_timeout).c_str());
      return;
    }
    publish_clock();
    serve(0.1);
  }
}

void StageNode::on_cmd(int i, const geometry_msgs::Twist::ConstPtr& msg) {
  commands_[i] = {msg->linear.x, msg->angular.z};
  last_command_[i] = sim_time();
}

void StageNode::on_cmd_stamped(int i, const geometry_msgs::TwistStamped::ConstPtr& msg) {
  commands_[i] = {msg->twist.linear.x, msg->twist.angular.z};
  last_command_[i] = sim_time();
  lockstep_.on_answer(i, msg->header.stamp);
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
  const std::string j = event_json(kind, i, ns_[i], sim_time(), detail);
  events_json_.push_back(j);
  pubs_.event(j);
  if (kind == "responsive" || kind == "back") {
    ROS_INFO("%s: %s (%s)", ns_[i].c_str(), detail.c_str(), kind.c_str());
  } else {
    ROS_WARN("%s: %s (%s)", ns_[i].c_str(), detail.c_str(), kind.c_str());
  }
  if (!p_.summary_file.empty()) write_summary();
}

void StageNode::write_summary() const {
  if (p_.summary_file.empty()) return;
  const std::string text =
      summary_json(p_.lockstep, sim_time(), lockstep_.unresponsive_count(), lockstep_.answers(),
                   lockstep_.unwaited_ticks(), events_json_);
  const std::string tmp = p_.summary_file + ".tmp";
  {
    std::ofstream f(tmp);
    f << text;
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
    const bool stop = stale || stalled_fault_[i] || (p_.lockstep && lockstep_.unresponsive(i));
    cmd(i, 0) = stop ? 0.0 : commands_[i][0];
    cmd(i, 1) = stop ? 0.0 : commands_[i][1];
  }
  world_.set_commands(cmd);
  world_.step(p_.step);
  ++steps_;
}

void StageNode::status_line(double now) {
  static double last_wall = now, last_sim = sim_time();
  if (p_.status_period <= 0 || now - last_wall < p_.status_period) return;
  const double rtf = (sim_time() - last_sim) / (now - last_wall);
  int contacts = 0;
  for (bool s : world_.stalled()) contacts += s;
  const int silent = lockstep_.num_unresponsive();
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
  if (p_.lockstep) lockstep_.start_gate();
  publish_scans();
  publish_state();
  if (p_.lockstep) lockstep_.wait_answers(stamp());
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
      if (p_.lockstep) lockstep_.wait_answers(stamp());
      if (p_.lockstep && p_.start_hold > 0 && !held_ && sim_time() >= p_.start_hold - 1e-9) {
        held_ = true;
        hold_for_start();
      }
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
