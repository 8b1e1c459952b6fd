// The heartbeats of runs with faults: who hears whom, and when (teammate liveness).
#pragma once

#include <cstdint>
#include <vector>

#include "tpuaf_core/numpy_random.hpp"
#include "tpuaf_core/teammate_liveness.hpp"

namespace tpuaf {

// Heartbeats of a run with faults (the graph and physics runtimes; tpuaf.team.liveness.
// heartbeat_links builds one for the physics runtime): robot j
// sends heartbeat k at k * period [s] while alive (k * period <= its death time) and within the
// run; robot i hears it delay [s] later unless lost, one draw per (sender, recipient, heartbeat)
// from the sender's stream numpy default_rng([seed, 4, sender]).random((n, count)).
class HeartbeatLinks {
 public:
  // rngs: one stream per sender (unused, and may be empty, without loss).
  HeartbeatLinks(int robots, double duration_s, double timeout_s, double delay_s, double loss,
                 double period_s, std::vector<NumpyPcg64> rngs);
  void died(int robot, double t);  // its heartbeats stop after run time t [s]
  // [s] when `recipient` last heard `sender` by run time t (-inf: never).
  double last_arrival_s(int recipient, int sender, double t);
  // [s] the next time recipient's view of sender can change from heartbeats alone (+inf: never).
  double next_check_s(int recipient, int sender, double last_heard, bool lost, double now);
  // A live robot's `liveness` hears the last heartbeat of every teammate that reached it by
  // run time now [s]; the teammates heard again after being lost are appended to `back`.
  void feed(TeammateLiveness& liveness, double now, std::vector<int>* back = nullptr);
  // [s] the earliest time a check of `liveness` can find a change (a silence reaching the
  // timeout, a lost teammate heard again), from heartbeats alone (+inf: never); after feed.
  double next_check_s(const TeammateLiveness& liveness, double now);
  double period_s() const { return period_s_; }
  std::int64_t count() const { return count_; }  // heartbeats per sender over the run
  // Heartbeat indices `recipient` hears of `sender` (ascending), and the positions p among them
  // whose next one arrives more than the timeout later (a silence).
  const std::vector<std::int32_t>& received(int recipient, int sender) {
    return link(recipient, sender).received;
  }
  const std::vector<std::int32_t>& silences(int recipient, int sender) {
    return link(recipient, sender).silences;
  }

 private:
  struct Link {
    std::vector<std::int32_t> received;  // heartbeat indices heard, ascending
    std::vector<std::int32_t> silences;  // positions p: received[p + 1] comes after a timeout
  };
  double arrival(std::int64_t k) const { return static_cast<double>(k) * period_s_ + delay_s_; }
  const Link& link(int recipient, int sender);
  std::int64_t heard_by(const Link& l, int sender, double t) const;
  void silences_of(Link& l) const;
  int n_;
  double period_s_, delay_s_, timeout_s_, loss_;
  std::int64_t count_;
  std::vector<std::int64_t> last_sent_;
  std::vector<NumpyPcg64> rngs_;
  std::vector<std::vector<Link>> links_;  // [sender][recipient], drawn when first asked
  Link every_;                            // without loss: every heartbeat on every link
};

}  // namespace tpuaf
