// Silent-teammate detection of one robot, the liveness of every runtime (each robot's
// RobotProtocol holds one; tpuaf.team.liveness.TeammateLiveness builds one for Python). Times in
// seconds of run time.
#pragma once

#include <cstddef>
#include <vector>

namespace tpuaf {

// Silent-teammate detection of one robot (tpuaf.team.liveness): a teammate heard once and then
// silent for timeout_s is lost (reported once); it is back when heard again.
class TeammateLiveness {
 public:
  TeammateLiveness(int robots, int me, double timeout_s);
  // `robot` heard at run time t [s]; true when it had been lost (it is back). Nothing newer
  // than the last time heard changes nothing.
  bool heard(int robot, double t);
  // Teammates silent for the timeout by run time now [s], not reported before (appended to
  // `out`, in index order).
  void check(double now, std::vector<int>& out);
  double last_heard(int robot) const { return last_heard_[index(robot)]; }  // -inf: never
  bool lost(int robot) const { return lost_[index(robot)] != 0; }
  double timeout_s() const { return timeout_s_; }
  int robots() const { return static_cast<int>(last_heard_.size()); }
  int me() const { return me_; }

 private:
  std::size_t index(int robot) const;
  int me_;
  double timeout_s_;
  std::vector<double> last_heard_;  // [s] run time
  std::vector<char> lost_;
};

}  // namespace tpuaf
