// The team bus of every runtime (the graph loop, the physics runtime, the fleet's relay model):
// broadcast with a fixed delay and a seeded loss per recipient.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <limits>
#include <vector>

#include "tpuaf_core/numpy_random.hpp"

namespace tpuaf {

struct TeamBusStats {
  long long sent = 0;       // broadcasts
  long long delivered = 0;  // (message, recipient) pairs handed over (counted by the runtime)
  long long lost = 0;       // (message, live recipient) pairs lost
};

// One broadcast on its way: the caller's message id, and who receives it.
struct BusDelivery {
  std::int64_t message = -1;  // the caller's id of the message (the bus never reads it)
  int sender = -1;
  bool all_but_sender = false;  // recipients: every robot but the sender (no loss, none dead)
  std::vector<int> recipients;  // else: the recipients, ascending

  // f(recipient) for each recipient, ascending; `robots`: the team size N.
  template <class F>
  void for_each_recipient(int robots, F&& f) const {
    if (all_but_sender) {
      for (int r = 0; r < robots; ++r) {
        if (r != sender) f(r);
      }
    } else {
      for (int r : recipients) f(r);
    }
  }
};

// Every recipient (the live robots but the sender) independently loses a message with
// probability `loss`; the others receive it `delay_s` [s] after it was sent. The losses are
// drawn as numpy's `rng.random(N) < loss` (one draw per robot, the sender's and the dead's
// included, none without loss) from the PCG64 stream `rng` (tpuaf.team.bus.bus_stream). Without
// delay a message is ready at once; else it is in flight until due, and messages are released
// in due order, then send order. The runtime hands the ready ones to its robots and counts
// what it delivered.
class TeamBus {
 public:
  TeamBus(int robots, double delay_s, double loss, NumpyPcg64 rng);

  int robots() const { return robots_; }
  double delay_s() const { return delay_s_; }
  double loss() const { return loss_; }
  bool alive(int robot) const;
  void set_alive(int robot, bool alive);  // a dead robot receives nothing sent after
  const TeamBusStats& stats() const { return stats_; }
  void count_delivered(long long pairs) { stats_.delivered += pairs; }

  // Broadcast message `message` from `sender` at run time now_s [s]. False when nobody is to
  // receive it (all lost, or no live teammate): the bus then keeps nothing.
  bool send(int sender, std::int64_t message, double now_s);

  // [s] when the next message in flight is due (+inf: none).
  double next_due_s() const {
    return in_flight_.empty() ? std::numeric_limits<double>::infinity() : in_flight_.front().due_s;
  }
  std::size_t in_flight() const { return in_flight_.size(); }
  void release_next();  // the next message in flight becomes ready
  // Every message in flight due by now_s [s] (within slack_s) becomes ready.
  void release_due(double now_s, double slack_s = 1e-9);

  // The messages to deliver now, in order.
  const std::deque<BusDelivery>& ready() const { return ready_; }
  BusDelivery pop_ready();

 private:
  struct InFlight {
    double due_s;
    BusDelivery delivery;
  };
  int robots_;
  double delay_s_, loss_;
  NumpyPcg64 rng_;
  std::vector<char> alive_;
  int dead_ = 0;
  TeamBusStats stats_;
  std::deque<InFlight> in_flight_;  // due order, then send order
  std::deque<BusDelivery> ready_;
};

}  // namespace tpuaf
