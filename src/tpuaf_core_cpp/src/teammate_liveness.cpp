// Silent-teammate detection of one robot (teammate_liveness.hpp).
#include "tpuaf_core/teammate_liveness.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace tpuaf {

TeammateLiveness::TeammateLiveness(int robots, int me, double timeout_s)
    : me_(me),
      timeout_s_(timeout_s),
      last_heard_(static_cast<std::size_t>(robots), -std::numeric_limits<double>::infinity()),
      lost_(static_cast<std::size_t>(robots), 0) {
  if (!(timeout_s > 0)) {
    throw std::invalid_argument("teammate timeout must be > 0 s, got " + std::to_string(timeout_s));
  }
}

std::size_t TeammateLiveness::index(int robot) const {
  if (robot < 0 || robot >= robots()) {
    throw std::out_of_range("unknown robot " + std::to_string(robot) + " (team of " +
                            std::to_string(robots()) + ")");
  }
  return static_cast<std::size_t>(robot);
}

bool TeammateLiveness::heard(int robot, double t) {
  if (robot < 0 || robot >= robots() || robot == me_) return false;
  double& last = last_heard_[static_cast<std::size_t>(robot)];
  if (t <= last) return false;
  last = t;
  char& lost = lost_[static_cast<std::size_t>(robot)];
  if (lost) {
    lost = 0;
    return true;
  }
  return false;
}

void TeammateLiveness::check(double now, std::vector<int>& out) {
  for (int r = 0; r < robots(); ++r) {
    const double t = last_heard_[static_cast<std::size_t>(r)];
    char& lost = lost_[static_cast<std::size_t>(r)];
    // now >= t + timeout, computed as the runtimes compute the due time of a check
    if (r != me_ && !lost && std::isfinite(t) && now >= t + timeout_s_) {
      lost = 1;
      out.push_back(r);
    }
  }
}

}  // namespace tpuaf
