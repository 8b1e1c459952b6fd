// Lock-step of the tpuaf_stage node: the agents' answers to the odom ticks, unresponsive and gone
// agents, and the waits at start and after each tick (tpuaf_stage/lockstep.hpp).
#include "tpuaf_stage/lockstep.hpp"

#include <algorithm>
#include <chrono>

#include "tpuaf_stage/json_text.hpp"

namespace tpuaf_stage {

using WallClock = std::chrono::steady_clock;
double wall_now() {
  return std::chrono::duration<double>(WallClock::now().time_since_epoch()).count();
}

Lockstep::Lockstep(std::vector<std::string> ns, double lockstep_timeout_s, double start_timeout_s,
                   Hooks hooks)
    : ns_(std::move(ns)),
      n_(static_cast<int>(ns_.size())),
      lockstep_timeout_s_(lockstep_timeout_s),
      start_timeout_s_(start_timeout_s),
      hooks_(std::move(hooks)) {
  answered_.assign(n_, ros::Time(0));
  ever_answered_.assign(n_, false);
  unresponsive_.assign(n_, false);
  gone_.assign(n_, false);
  unresponsive_count_.assign(n_, 0);
  unwaited_ticks_.assign(n_, 0);
  answers_.assign(n_, 0);
  team_seen_.assign(n_, false);
  team_tick_.assign(n_, ros::Time(0));
  team_sent_.assign(n_, 0);
  team_lost_.assign(n_, 0);
  team_received_.assign(n_, std::vector<std::int64_t>(n_, 0));
  team_forgiven_.assign(n_, std::vector<std::int64_t>(n_, 0));
}

// data: [stamp of the tick answered last, ns; team messages sent; received from robot 0..n-1].
// The first counts of an agent's process (new, back after it left, or counts that went down: a
// restart) start its account: what its teammates sent before it is not waited for.
void Lockstep::on_team_counts(int i, const std::vector<std::int64_t>& data) {
  if (static_cast<int>(data.size()) != n_ + 2 || data[0] < 0) return;
  ros::Time tick;
  tick.fromNSec(static_cast<std::uint64_t>(data[0]));
  const bool fresh = !team_seen_[i] || data[1] < team_sent_[i];
  if (tick > team_tick_[i] || fresh) team_tick_[i] = tick;
  team_sent_[i] = data[1];
  for (int k = 0; k < n_; ++k) {
    team_received_[i][k] = data[k + 2];
    if (fresh) team_forgiven_[i][k] = std::max<std::int64_t>(0, team_sent_[k] - data[k + 2]);
  }
  team_seen_[i] = true;
}

// A receiver is waited for while it is live and its counts of tick have not come, or while it
// has received fewer messages from a live teammate than that teammate has sent (minus those
// given up on). Returns the first such receiver's namespace and what it misses.
std::string Lockstep::team_missing(const ros::Time& tick, const std::vector<bool>& live) const {
  for (int j = 0; j < n_; ++j) {
    if (!live[j] || !team_seen_[j]) continue;
    if (team_tick_[j] < tick) return ns_[j] + " (no team counts of the tick yet)";
    for (int i = 0; i < n_; ++i) {
      if (i == j || !live[i] || !team_seen_[i]) continue;
      const std::int64_t short_by = team_sent_[i] - team_received_[j][i] - team_forgiven_[j][i];
      if (short_by > 0) return ns_[j] + " (" + std::to_string(short_by) + " of " + ns_[i] + ")";
    }
  }
  return "";
}

// After ~lockstep_timeout: the messages still missing are lost (not waited for again).
void Lockstep::team_give_up(const ros::Time& tick, const std::vector<bool>& live) {
  for (int j = 0; j < n_; ++j) {
    if (!live[j] || !team_seen_[j] || team_tick_[j] < tick) continue;
    for (int i = 0; i < n_; ++i) {
      if (i == j || !live[i] || !team_seen_[i]) continue;
      const std::int64_t short_by = team_sent_[i] - team_received_[j][i] - team_forgiven_[j][i];
      if (short_by <= 0) continue;
      team_forgiven_[j][i] += short_by;
      team_lost_[j] += short_by;
      hooks_.event("team_lost", j,
                   std::to_string(short_by) + " team message(s) of " + ns_[i] +
                       " not received within " + pyfloat(lockstep_timeout_s_) +
                       " s of wall time after the tick at " + pyfloat(tick.toSec()) +
                       " s; not waited for");
    }
  }
}

void Lockstep::on_answer(int i, const ros::Time& stamp) {
  if (stamp > answered_[i]) answered_[i] = stamp;
  ++answers_[i];
  ever_answered_[i] = true;
  if (unresponsive_[i]) {
    unresponsive_[i] = false;
    hooks_.event("responsive", i, "answers again");
  }
}

int Lockstep::num_unresponsive() const {
  int silent = 0;
  for (int i = 0; i < n_; ++i) silent += unresponsive_[i];
  return silent;
}

// Lock-step: wait (wall clock, ~start_timeout) until every robot's cmd_vel_stamped has a
// publisher, republishing /clock meanwhile; time stands at the first step.
void Lockstep::start_gate() {
  const double deadline = wall_now() + start_timeout_s_;
  while (ros::ok()) {
    std::string missing;
    for (int i = 0; i < n_; ++i) {
      if (cmd_stamped_sub_[i].getNumPublishers() == 0)
        missing += (missing.empty() ? "" : ", ") + ns_[i];
    }
    if (missing.empty()) {
      ROS_INFO("lockstep: every robot has a cmd_vel_stamped publisher");
      return;
    }
    if (wall_now() > deadline) {
      ROS_WARN("lockstep: starting without agents for %s after %s s", missing.c_str(),
               pyfloat(start_timeout_s_).c_str());
      return;
    }
    hooks_.publish_clock();
    hooks_.serve(0.2);
  }
}

// Lock-step: after the odom tick at stamp T, wait until every live agent has answered T.
// An agent with no cmd_vel_stamped publisher left is gone (not waited for); one silent for
// ~lockstep_timeout is unresponsive (its robot stops; waited for again once it answers). An agent
// that never answered yet gets ~start_timeout and the tick again every 0.5 s (its subscription may
// have connected after the tick was sent). With the team barrier, then until every team message
// sent before the answers has reached every live teammate (at most ~lockstep_timeout in all):
// the agents handle the messages of a tick at the next one, all of them, whatever the threads do.
void Lockstep::wait_answers(const ros::Time& tick) {
  const double t0 = wall_now();
  double last_resend = t0;
  std::vector<bool> pending(n_), waited(n_);
  bool first = true;  // ticks without an agent are counted once per tick
  while (true) {
    hooks_.serve(0.0);
    bool any = false, any_new = false;
    for (int i = 0; i < n_; ++i) {
      const bool live = cmd_stamped_sub_[i].getNumPublishers() > 0;
      if (!live && ever_answered_[i] && !gone_[i]) {
        gone_[i] = true;
        team_seen_[i] = false;  // a new process starts a new account
        hooks_.event("gone", i, "its agent left (no cmd_vel_stamped publisher); not waited for");
      } else if (live && gone_[i]) {
        gone_[i] = false;
        hooks_.event("back", i, "its agent is back");
      }
      waited[i] = live && !unresponsive_[i];
      pending[i] = waited[i] && answered_[i] < tick;
      unwaited_ticks_[i] += first && !live;
      any |= pending[i];
      any_new |= pending[i] && !ever_answered_[i];
    }
    first = false;
    if (!ros::ok()) return;
    const double now = wall_now();
    if (!any) {
      if (!team_ || team_missing(tick, waited).empty()) return;
      if (now - t0 > lockstep_timeout_s_) {
        team_give_up(tick, waited);
        return;
      }
      hooks_.serve(0.002);
      continue;
    }
    if (any_new && now - last_resend > 0.5 && now - t0 < start_timeout_s_) {
      std::vector<bool> fresh(n_);
      for (int i = 0; i < n_; ++i) fresh[i] = pending[i] && !ever_answered_[i];
      hooks_.resend(fresh);
      last_resend = now;
    }
    bool late = false;
    for (int i = 0; i < n_; ++i) {
      const double limit = ever_answered_[i] ? lockstep_timeout_s_ : start_timeout_s_;
      if (pending[i] && now - t0 > limit) {
        unresponsive_[i] = true;
        ++unresponsive_count_[i];
        hooks_.event("unresponsive", i,
                     "no answer to the tick at " + pyfloat(tick.toSec()) + " s within " +
                         pyfloat(limit) +
                         " s of wall time; robot stopped, not waited for until it answers");
        late = true;
      }
    }
    if (late) continue;
    hooks_.serve(0.002);
  }
}

}  // namespace tpuaf_stage
