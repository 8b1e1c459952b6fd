// Private parameters of the tpuaf_stage node: the table (also --help), strict reading from the
// parameter server, validation, the effective-values log text and ~stall (ROBOT@TIME) parsing.
#pragma once

#include <xmlrpcpp/XmlRpcValue.h>

#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace tpuaf_stage {

constexpr const char* kNode = "tpuaf_stage";

// A bad private parameter; the message starts with the node name.
class ParamError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

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
  bool lockstep_team = false;     // lock-step: also wait until every team message is delivered
  double start_hold = 0.0;        // [s of sim time] lock-step: time stands here until the run start
  double start_timeout = 60.0;    // [s of wall time] lock-step: wait for every agent at start
  bool wall_clock = false;        // rehearsal: real-time pace, wall-clock stamps, no /clock
  std::string stall = "";         // faults: "R@T,R@T": robot R stops moving at run time T [s]
  std::string summary_file = "";  // JSON of the lock-step and fault events, written at exit
};

// The node's private parameters on the parameter server (name without "~" -> value).
std::map<std::string, XmlRpc::XmlRpcValue> private_params();

// Strict: unknown names, wrong types and bad values throw ParamError.
NodeParams parse_params(const std::map<std::string, XmlRpc::XmlRpcValue>& values);

// The effective values as a Python dict text (start-up log line).
std::string params_summary(const NodeParams& p);

// "R@T,R@T" -> {(R, T)}: robot index in 0..n_robots-1, run time [s] >= 0; throws ParamError.
std::vector<std::pair<int, double>> parse_stalls(const std::string& text, int n_robots);

// --help: the table of private parameters on stdout (no master needed).
void print_help();

}  // namespace tpuaf_stage
