// Lock-step of the tpuaf_stage node: the agents' answers to the odom ticks, unresponsive and gone
// agents, and the waits at start and after each tick (tpuaf_stage/lockstep.hpp).
#include "tpuaf_stage/lockstep.hpp"

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
// have connected after the tick was sent).
void Lockstep::wait_answers(const ros::Time& tick) {
  const double t0 = wall_now();
  double last_resend = t0;
  std::vector<bool> pending(n_);
  while (true) {
    hooks_.serve(0.0);
    bool any = false, any_new = false;
    for (int i = 0; i < n_; ++i) {
      const bool live = cmd_stamped_sub_[i].getNumPublishers() > 0;
      if (!live && ever_answered_[i] && !gone_[i]) {
        gone_[i] = true;
        hooks_.event("gone", i, "its agent left (no cmd_vel_stamped publisher); not waited for");
      } else if (live && gone_[i]) {
        gone_[i] = false;
        hooks_.event("back", i, "its agent is back");
      }
      pending[i] = live && !unresponsive_[i] && answered_[i] < tick;
      unwaited_ticks_[i] += !live;
      any |= pending[i];
      any_new |= pending[i] && !ever_answered_[i];
    }
    if (!any || !ros::ok()) return;
    const double now = wall_now();
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
