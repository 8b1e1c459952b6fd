// The graph runtime's faults and liveness: fault injection, stalled robots' give-ups, heartbeats
// heard and teammates lost (TeamRun, RobotMachine.hear / check_liveness).
#include <cmath>
#include <limits>
#include <stdexcept>

#include "tpuaf_core/engine.hpp"

namespace tpuaf {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
// Python's max(a, b): a unless b > a (the same number for doubles without NaN).
inline double py_max(double a, double b) { return b > a ? b : a; }
}  // namespace

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
  links_.reset();
  if (faults_.empty()) return;
  links_ = std::make_unique<HeartbeatLinks>(n, config_.duration_s, config_.teammate_timeout_s,
                                            config_.delay_s, config_.loss,
                                            config_.heartbeat_period_s, std::move(heartbeat_rngs));
  lost_by_.assign(static_cast<std::size_t>(n), 0);
}

void GraphEngine::give_up_later(int robot) {
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  r.pending = push(now_ + config_.stall_give_up_s, kGiveUp, robot);
}

void GraphEngine::give_up(int robot) {
  // The navigator gave up: the protocol hears the goal failed, the robot nearest to a vertex.
  RobotProtocol& p = protocol_of(robot);
  const int goal = p.goal();
  if (goal < 0 || !p.alive()) return;
  double x, y;
  position(robot, now_, x, y);
  p.on_goal_failed(goal, nearest_vertex(x, y));
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
}

void GraphEngine::inject(const EngineFault& fault) {
  // TeamRun.inject.
  const int i = fault.robot;
  RobotProtocol& p = protocol_of(i);
  if (!p.alive()) return;
  if (fault.death) {
    freeze(i);
    p.die();
    bus_.set_alive(i, false);  // it receives nothing sent after
    recorder_.record_robot_death(i, now_);
    links_->died(i, now_);  // its heartbeats stop: every survivor's checks move
    for (int j = 0; j < config_.robots; ++j) plan_liveness(j);
    return;
  }
  p.stall();
  recorder_.record_robot_stall(i, now_);
  if (!p.dwelling()) {  // a dwell needs no motion: it ends as planned
    freeze(i);
    if (p.goal() >= 0) give_up_later(i);
  }
}

bool GraphEngine::hear(int robot, int sender, double t) {
  // The protocol's liveness hears the sender; true when it was lost (it is back).
  if (!protocol_of(robot).hear(sender, t)) return false;
  --lost_by_[static_cast<std::size_t>(sender)];
  return true;
}

void GraphEngine::feed_heartbeats(int robot) {
  back_.clear();
  links_->feed(protocol_of(robot).liveness(), now_, &back_);
  for (int j : back_) --lost_by_[static_cast<std::size_t>(j)];
}

void GraphEngine::plan_liveness(int robot) {
  // TeamRun._plan_liveness: one pending check per robot, when the first of its teammates'
  // silences can end or one can be heard again.
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  if (!protocol_of(robot).alive()) return;
  feed_heartbeats(robot);
  const double due = links_->next_check_s(protocol_of(robot).liveness(), now_);
  r.liveness = std::isfinite(due) ? push(py_max(due, now_), kLiveness, robot) : 0;
}

void GraphEngine::liveness_due(int robot) {
  // TeamRun.liveness_due: the protocol's check (each silent teammate reported once to the
  // strategy).
  RobotProtocol& p = protocol_of(robot);
  if (!p.alive()) return;
  feed_heartbeats(robot);
  for (int j : p.check_liveness(now_)) {
    ++lost_by_[static_cast<std::size_t>(j)];
    losses_.push_back({now_, robot, j});
  }
  plan_liveness(robot);
}

}  // namespace tpuaf
