// Text of the tpuaf_stage node's outputs, as Python and JSON write it: numbers of the log lines,
// JSON strings, the /fleet/sim_events documents and the ~summary_file.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace tpuaf_stage {

// Python-like text of a double (shortest round trip, "1.0" not "1"), for the effective log.
std::string pyfloat(double x);

// JSON string literal of s (quotes and backslashes escaped).
std::string json_string(const std::string& s);

// One /fleet/sim_events document: event kind, robot index and name, sim time [s], detail.
std::string event_json(const std::string& kind, int robot, const std::string& robot_name,
                       double sim_time_s, const std::string& detail);

// The ~summary_file document: lock-step counts per robot and every event document so far.
std::string summary_json(bool lockstep, double sim_time_s,
                         const std::vector<int>& unresponsive_per_robot,
                         const std::vector<std::int64_t>& answers_per_robot,
                         const std::vector<std::int64_t>& ticks_without_agent_per_robot,
                         const std::vector<std::string>& events);

}  // namespace tpuaf_stage
