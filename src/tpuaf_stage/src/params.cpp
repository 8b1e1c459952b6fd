// Private parameters of the tpuaf_stage node: the table, strict reading and validation, the
// effective-values text, ~stall parsing and --help (tpuaf_stage/params.hpp).
#include "tpuaf_stage/params.hpp"

#include <ros/ros.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "tpuaf_stage/json_text.hpp"

namespace tpuaf_stage {
namespace {

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
    {"lockstep_team", "bool", "false",
     "lock-step: also wait until the team messages sent before the tick reached every agent"},
    {"start_hold", "double", "0",
     "[s of sim time] lock-step: time stands here until every agent has the run start; 0 = no"},
    {"start_timeout", "double", "60", "[s of wall time] lock-step: wait for every agent at start"},
    {"wall_clock", "bool", "false", "rehearsal: real-time pace, wall-clock stamps, no /clock"},
    {"stall", "string", "''", "faults: \"R@T,R@T\": robot R stops moving at run time T [s]"},
    {"summary_file", "string", "''", "JSON of the lock-step and fault events, written at exit"},
};

std::string value_text(const XmlRpc::XmlRpcValue& v) {
  XmlRpc::XmlRpcValue copy = v;
  return copy.toXml();
}

}  // namespace

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

// Every name a declared parameter (kParams), or a ParamError listing the valid ones.
void check_names(const std::map<std::string, XmlRpc::XmlRpcValue>& values) {
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
}

// The values' ranges and the rules between them, or a ParamError naming the first broken one.
void check_ranges(const NodeParams& p) {
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
  if (!(p.start_hold >= 0)) fail("~start_hold must be >= 0 s");
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
}

NodeParams parse_params(const std::map<std::string, XmlRpc::XmlRpcValue>& values) {
  check_names(values);
  NodeParams p;
  std::map<std::string, double*> doubles = {{"step", &p.step},
                                            {"clock_rate", &p.clock_rate},
                                            {"real_time_factor", &p.real_time_factor},
                                            {"odom_rate", &p.odom_rate},
                                            {"cmd_vel_timeout", &p.cmd_vel_timeout},
                                            {"status_period", &p.status_period},
                                            {"lockstep_timeout", &p.lockstep_timeout},
                                            {"start_timeout", &p.start_timeout},
                                            {"start_hold", &p.start_hold}};
  std::map<std::string, bool*> bools = {{"publish_map_tf", &p.publish_map_tf},
                                        {"lockstep", &p.lockstep},
                                        {"lockstep_team", &p.lockstep_team},
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
  check_ranges(p);
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
    << ", 'lockstep_team': " << b(p.lockstep_team) << ", 'start_hold': " << pyfloat(p.start_hold)
    << ", 'start_timeout': " << pyfloat(p.start_timeout) << ", 'wall_clock': " << b(p.wall_clock)
    << ", 'stall': " << s(p.stall) << ", 'summary_file': " << s(p.summary_file) << "}";
  return o.str();
}

std::vector<std::pair<int, double>> parse_stalls(const std::string& text, int n_robots) {
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
  for (const auto& s : out) {
    if (s.first >= n_robots) {
      throw ParamError(std::string(kNode) + ": ~stall robot " + std::to_string(s.first) +
                       " not in 0.." + std::to_string(n_robots - 1));
    }
  }
  return out;
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

}  // namespace tpuaf_stage
