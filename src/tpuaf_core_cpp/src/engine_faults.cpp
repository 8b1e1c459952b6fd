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
  for (Robot& r : robots_) {
    r.last_heard.assign(static_cast<std::size_t>(n), -kInf);
    r.lost.assign(static_cast<std::size_t>(n), 0);
  }
  lost_by_.assign(static_cast<std::size_t>(n), 0);
}

void GraphEngine::give_up_later(int robot) {
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  r.pending = push(now_ + config_.stall_give_up_s, kGiveUp, robot);
}

void GraphEngine::give_up(int robot) {
  // The navigator gave up: the strategy hears the goal failed (as RobotMachine.on_goal_failed).
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  const int goal = r.goal;
  if (goal < 0 || !r.alive) return;
  double x, y;
  position(robot, now_, x, y);
  r.goal = -1;
  r.dwelling = false;
  r.current = nearest_vertex(x, y);
  strategy_->on_goal_failed(*this, robot, goal);
  decide(robot);
}

void GraphEngine::freeze(int robot) {
  // Stop where it is now; its awaited arrival becomes stale.
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  double x, y;
  position(robot, now_, x, y);
  rules_[static_cast<std::size_t>(robot)].observe(x, y);
  r.p0x = x;
  r.p0y = y;
  r.vx = r.vy = 0.0;
  r.t0 = r.t1 = now_;
  r.pending = 0;
}

void GraphEngine::inject(const EngineFault& fault) {
  // TeamRun.inject.
  const int i = fault.robot;
  Robot& r = robots_[static_cast<std::size_t>(i)];
  if (!r.alive) return;
  if (fault.death) {
    freeze(i);
    r.alive = false;
    bus_.set_alive(i, false);  // it receives nothing sent after
    r.goal = r.redirect = -1;
    r.dwelling = false;
    recorder_.record_robot_death(i, now_);
    links_->died(i, now_);  // its heartbeats stop: every survivor's checks move
    for (int j = 0; j < config_.robots; ++j) plan_liveness(j);
    return;
  }
  r.stalled = true;
  recorder_.record_robot_stall(i, now_);
  if (!r.dwelling) {  // a dwell needs no motion: it ends as planned
    freeze(i);
    if (r.goal >= 0) give_up_later(i);
  }
}

bool GraphEngine::hear(int robot, int sender, double t) {
  // RobotMachine.hear / TeammateLiveness.heard: true when the sender was lost (it is back).
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  if (!r.alive || sender < 0 || sender >= config_.robots || sender == robot) return false;
  double& last = r.last_heard[static_cast<std::size_t>(sender)];
  if (t <= last) return false;
  last = t;
  char& lost = r.lost[static_cast<std::size_t>(sender)];
  if (lost) {
    lost = 0;
    --lost_by_[static_cast<std::size_t>(sender)];
    return true;
  }
  return false;
}

void GraphEngine::feed_heartbeats(int robot) {
  for (int j = 0; j < config_.robots; ++j) {
    const double t = links_->last_arrival_s(robot, j, now_);
    if (t > -kInf) hear(robot, j, t);
  }
}

void GraphEngine::plan_liveness(int robot) {
  // TeamRun._plan_liveness: the earliest time any teammate's silence can reach the timeout, or
  // one can be heard again; one pending check per robot.
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  if (!r.alive) return;
  feed_heartbeats(robot);
  double due = kInf;
  for (int j = 0; j < config_.robots; ++j) {
    if (j == robot) continue;
    const double t = links_->next_check_s(robot, j, r.last_heard[static_cast<std::size_t>(j)],
                                          r.lost[static_cast<std::size_t>(j)] != 0, now_);
    if (t < due) due = t;
  }
  r.liveness = std::isfinite(due) ? push(py_max(due, now_), kLiveness, robot) : 0;
}

void GraphEngine::liveness_due(int robot) {
  // TeamRun.liveness_due: RobotMachine.check_liveness (each silent teammate reported once).
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  if (!r.alive) return;
  feed_heartbeats(robot);
  lost_now_.clear();
  for (int j = 0; j < config_.robots; ++j) {
    const double t = r.last_heard[static_cast<std::size_t>(j)];
    char& lost = r.lost[static_cast<std::size_t>(j)];
    // now >= t + timeout, as the due time of the check is computed
    if (j != robot && !lost && std::isfinite(t) && now_ >= t + config_.teammate_timeout_s) {
      lost = 1;
      ++lost_by_[static_cast<std::size_t>(j)];
      lost_now_.push_back(j);
    }
  }
  const std::vector<int> lost = lost_now_;  // a hook may re-enter the engine
  for (int j : lost) strategy_->on_teammate_lost(*this, robot, j);
  for (int j : lost) losses_.push_back({now_, robot, j});
  plan_liveness(robot);
}

}  // namespace tpuaf
