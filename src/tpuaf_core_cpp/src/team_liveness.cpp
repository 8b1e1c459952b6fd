// The team around the robots' protocols in runs with faults (team_liveness.hpp): checks planned
// from the heartbeats, checks due, and a fault's steps.
#include "tpuaf_core/team_liveness.hpp"

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace tpuaf {

TeamLiveness::TeamLiveness(std::vector<RobotProtocol*> protocols, TeamBus& bus,
                           GroundTruthRecorder& recorder, HeartbeatLinks links, TeamHooks hooks)
    : protocols_(std::move(protocols)),
      bus_(bus),
      recorder_(recorder),
      links_(std::move(links)),
      hooks_(std::move(hooks)) {
  for (const RobotProtocol* p : protocols_) {
    if (p == nullptr) throw std::invalid_argument("a team needs every robot's protocol");
  }
  if (bus_.robots() != robots()) throw std::invalid_argument("the bus has another team size");
  if (!hooks_.schedule_check || !hooks_.stop_motion || !hooks_.after_stall) {
    throw std::invalid_argument("a team needs its runtime's hooks");
  }
  checks_.assign(protocols_.size(), 0);
  lost_by_.assign(protocols_.size(), 0);
}

std::size_t TeamLiveness::index(int robot) const {
  if (robot < 0 || robot >= robots()) {
    throw std::out_of_range("unknown robot " + std::to_string(robot) + " (team of " +
                            std::to_string(robots()) + ")");
  }
  return static_cast<std::size_t>(robot);
}

void TeamLiveness::start(double now) {
  for (int r = 0; r < robots(); ++r) plan(r, now);
}

void TeamLiveness::feed(int robot, double now) {
  // The robot hears the last heartbeat of every teammate that reached it by now.
  back_.clear();
  links_.feed(protocols_[static_cast<std::size_t>(robot)]->liveness(), now, &back_);
  for (int j : back_) --lost_by_[static_cast<std::size_t>(j)];
}

void TeamLiveness::plan(int robot, double now) {
  // One pending check per live robot: when the first of its teammates' silences can end or one
  // can be heard again (a new plan makes the previous token stale).
  const RobotProtocol& p = *protocols_[static_cast<std::size_t>(robot)];
  if (!p.alive()) return;
  feed(robot, now);
  const double due = links_.next_check_s(p.liveness(), now);
  checks_[static_cast<std::size_t>(robot)] =
      std::isfinite(due) ? hooks_.schedule_check(robot, due > now ? due : now) : 0;
}

void TeamLiveness::check_due(int robot, std::uint64_t token, double now) {
  // The protocol's check: each silent teammate is reported once to the policy.
  RobotProtocol& p = *protocols_[index(robot)];
  if (token != checks_[static_cast<std::size_t>(robot)] || !p.alive()) return;
  feed(robot, now);
  for (int j : p.check_liveness(now)) {
    ++lost_by_[static_cast<std::size_t>(j)];
    losses_.push_back({now, robot, j});
  }
  plan(robot, now);
}

void TeamLiveness::inject(int robot, bool death, double now) {
  RobotProtocol& p = *protocols_[index(robot)];
  if (!p.alive()) return;
  if (death) {
    hooks_.stop_motion(robot);
    p.die();
    bus_.set_alive(robot, false);  // it receives nothing sent after
    recorder_.record_robot_death(robot, now);
    links_.died(robot, now);  // its heartbeats stop: every survivor's checks move
    for (int r = 0; r < robots(); ++r) plan(r, now);
    return;
  }
  p.stall();
  recorder_.record_robot_stall(robot, now);
  hooks_.after_stall(robot);
}

}  // namespace tpuaf
