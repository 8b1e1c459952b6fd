// The graph runtime's faults: the team's liveness and fault steps (TeamLiveness, shared with the
// physics runtime) on the loop's events, and a stalled robot's motion and give-ups.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "tpuaf_core/engine.hpp"

namespace tpuaf {

void GraphEngine::set_faults(std::vector<EngineFault> faults,
                             std::vector<NumpyPcg64> heartbeat_rngs) {
  const int n = config_.robots;
  for (std::size_t k = 0; k < faults.size(); ++k) {
    const EngineFault& f = faults[k];
    robot_at(f.robot);
    if (!(f.time_s >= 0) || !std::isfinite(f.time_s)) {
      throw std::invalid_argument("a fault time must be a finite number >= 0 s");
    }
    if (k > 0 && f.time_s < faults[k - 1].time_s) {
      throw std::invalid_argument("faults must be in time order");
    }
  }
  if (!(config_.stall_give_up_s > 0)) throw std::invalid_argument("stall give-up must be > 0 s");
  faults_ = std::move(faults);
  team_.reset();
  if (faults_.empty()) return;
  std::vector<RobotProtocol*> protocols;
  for (RobotProtocol& p : protocols_) protocols.push_back(&p);
  TeamHooks hooks;
  hooks.schedule_check = [this](int robot, double t) { return push(t, kLiveness, robot); };
  hooks.stop_motion = [this](int robot) { freeze(robot); };
  hooks.after_stall = [this](int robot) { after_stall(robot); };
  team_ = std::make_unique<TeamLiveness>(
      std::move(protocols), bus_, recorder_,
      HeartbeatLinks(n, config_.duration_s, config_.teammate_timeout_s, config_.delay_s,
                     config_.loss, config_.heartbeat_period_s, std::move(heartbeat_rngs)),
      std::move(hooks));
}

const std::vector<GraphEngine::Loss>& GraphEngine::losses() const {
  static const std::vector<Loss> kNone;
  return team_ ? team_->losses() : kNone;
}

void GraphEngine::give_up_later(int robot) {
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  r.pending = push(now_ + config_.stall_give_up_s, kGiveUp, robot);
}

void GraphEngine::give_up(int robot) {
  // The navigator gave up: the protocol hears the goal failed, the robot nearest to a vertex.
  stop_holding(robot);  // held short of a narrow vertex too long
  RobotProtocol& p = protocol_of(robot);
  const int goal = p.goal();
  if (goal < 0 || !p.alive()) return;
  double x, y;
  position(robot, now_, x, y);
  p.on_goal_failed(goal, p.nearest_vertex(x, y));
}

void GraphEngine::freeze(int robot) {
  // Stop where it is now; its awaited arrival becomes stale.
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  double x, y;
  position(robot, now_, x, y);
  protocol_of(robot).observe(x, y);
  r.p0x = x;
  r.p0y = y;
  r.vx = r.vy = 0.0;
  r.t0 = r.t1 = now_;
  r.pending = 0;
  // no body in the graph runtime: it no longer stands on, nor waits for, a narrow vertex
  stop_holding(robot);
  for (int v = 0; v < static_cast<int>(standing_.size()); ++v) leave(robot, v);
}

void GraphEngine::after_stall(int robot) {
  // A dwell needs no motion: it ends as planned; else the robot stops and gives up later.
  const RobotProtocol& p = protocol_of(robot);
  if (p.dwelling()) return;
  freeze(robot);
  if (p.goal() >= 0) give_up_later(robot);
}

}  // namespace tpuaf
