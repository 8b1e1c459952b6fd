// Text of the tpuaf_stage node's outputs: Python-like floats, JSON strings, the sim event and
// summary-file documents (tpuaf_stage/json_text.hpp).
#include "tpuaf_stage/json_text.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

namespace tpuaf_stage {

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

std::string event_json(const std::string& kind, int robot, const std::string& robot_name,
                       double sim_time_s, const std::string& detail) {
  std::ostringstream j;
  j << "{\"event\": " << json_string(kind) << ", \"robot\": " << robot
    << ", \"robot_name\": " << json_string(robot_name)
    << ", \"sim_time_s\": " << pyfloat(sim_time_s) << ", \"detail\": " << json_string(detail)
    << "}";
  return j.str();
}

std::string summary_json(bool lockstep, double sim_time_s,
                         const std::vector<int>& unresponsive_per_robot,
                         const std::vector<std::int64_t>& answers_per_robot,
                         const std::vector<std::int64_t>& ticks_without_agent_per_robot,
                         const std::vector<std::string>& events) {
  int total = 0;
  std::ostringstream per, unwaited, answers;
  for (std::size_t i = 0; i < unresponsive_per_robot.size(); ++i) {
    total += unresponsive_per_robot[i];
    per << (i ? ", " : "") << unresponsive_per_robot[i];
    unwaited << (i ? ", " : "") << ticks_without_agent_per_robot[i];
    answers << (i ? ", " : "") << answers_per_robot[i];
  }
  std::ostringstream o;
  o << "{\n  \"lockstep\": " << (lockstep ? "true" : "false")
    << ",\n  \"sim_time_s\": " << pyfloat(sim_time_s) << ",\n  \"unresponsive_events\": " << total
    << ",\n  \"unresponsive_per_robot\": [" << per.str() << "],\n  \"answers_per_robot\": ["
    << answers.str() << "],\n  \"ticks_without_agent_per_robot\": [" << unwaited.str()
    << "],\n  \"events\": [";
  for (std::size_t k = 0; k < events.size(); ++k) {
    o << (k ? ",\n    " : "\n    ") << events[k];
  }
  o << (events.empty() ? "]\n}\n" : "\n  ]\n}\n");
  return o.str();
}

}  // namespace tpuaf_stage
