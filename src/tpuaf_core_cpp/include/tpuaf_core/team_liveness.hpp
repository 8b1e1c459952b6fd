// The team around the robots' protocols in runs with faults, written once for the graph loop
// (GraphEngine) and the physics runtime (tpuaf.runtimes.base.TeamRun, through pybind11): the
// heartbeats, each robot's one pending liveness check, the losses, a fault's steps, and the
// delivery of ready team messages that feeds every recipient's liveness. Times in seconds of run
// time.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "tpuaf_core/heartbeats.hpp"
#include "tpuaf_core/recorder.hpp"
#include "tpuaf_core/robot_protocol.hpp"
#include "tpuaf_core/team_bus.hpp"

namespace tpuaf {

// What differs between runtimes: how a check is scheduled, and how a robot stops.
struct TeamHooks {
  // Schedule a liveness check of `robot` at run time t [s]; returns its token (> 0), which
  // check_due is given back.
  std::function<std::uint64_t(int robot, double t)> schedule_check;
  std::function<void(int robot)> stop_motion;  // a death: the robot stops where it is
  std::function<void(int robot)> after_stall;  // a stall: the robot no longer moves
};

// Liveness: every live robot hears its teammates' heartbeats (HeartbeatLinks) and the team
// messages delivered to it, and has one pending check, at the earliest time a teammate's silence
// can reach the timeout or a lost one can be heard again (messages only postpone it, so it is
// never late). A teammate heard again after being lost moves the robot's check.
class TeamLiveness {
 public:
  // protocols: one per robot, index order (they must outlive this); bus and recorder: the run's.
  TeamLiveness(std::vector<RobotProtocol*> protocols, TeamBus& bus, GroundTruthRecorder& recorder,
               HeartbeatLinks links, TeamHooks hooks);

  int robots() const { return static_cast<int>(protocols_.size()); }
  HeartbeatLinks& links() { return links_; }
  // (run time [s], observer, lost teammate) of every liveness loss, in order.
  struct Loss {
    double time_s;
    int observer, lost;
  };
  const std::vector<Loss>& losses() const { return losses_; }
  // How many robots hold `robot` for lost now.
  int lost_by(int robot) const { return lost_by_[static_cast<std::size_t>(robot)]; }
  // The token of robot's pending check (0: none).
  std::uint64_t pending_check(int robot) const { return checks_[index(robot)]; }

  // Plan every robot's first check (after the start, at run time now).
  void start(double now);
  // A fault of `robot` at run time now: a death (stop its motion, its protocol dies, the bus
  // drops it, the recorder notes it, its heartbeats stop, every survivor's check moves) or a
  // stall (its protocol stalls, the recorder notes it, then after_stall). Nothing if dead.
  void inject(int robot, bool death, double now);
  // A check of `robot` scheduled with `token` is due at now; stale when not its latest.
  void check_due(int robot, std::uint64_t token, double now);

  // `robot`'s protocol hears `sender` at t; true when it was lost (it is back). The caller
  // plans the robot's check again (deliver_to does) unless no robot holds the sender lost.
  bool hear(int robot, int sender, double t) {
    if (!protocols_[static_cast<std::size_t>(robot)]->hear(sender, t)) return false;
    --lost_by_[static_cast<std::size_t>(sender)];
    return true;
  }
  // A team message from `sender` reaches `robot` at now: false when the robot is dead (it gets
  // nothing); else it hears the sender (one back from lost moves its check) and gets it.
  bool deliver_to(int robot, int sender, double now) {
    if (!protocols_[static_cast<std::size_t>(robot)]->alive()) return false;
    if (hear(robot, sender, now)) plan(robot, now);
    return true;
  }
  // Every ready message of the bus, message by message, to each live recipient in ascending
  // order (deliver_to, then deliver(recipient, delivery)); sender_of(delivery): the sender its
  // recipients hear; done(delivery) once it is handed over. Messages sent on the way join in.
  template <class SenderOf, class Deliver, class Done>
  void deliver_ready(double now, SenderOf&& sender_of, Deliver&& deliver, Done&& done) {
    while (!bus_.ready().empty()) {
      const BusDelivery d = bus_.pop_ready();
      const int sender = sender_of(d);
      d.for_each_recipient(robots(), [&](int r) {
        if (!deliver_to(r, sender, now)) return;
        deliver(r, d);
        bus_.count_delivered(1);
      });
      done(d);
    }
  }

 private:
  std::size_t index(int robot) const;
  void feed(int robot, double now);
  void plan(int robot, double now);

  std::vector<RobotProtocol*> protocols_;
  TeamBus& bus_;
  GroundTruthRecorder& recorder_;
  HeartbeatLinks links_;
  TeamHooks hooks_;
  std::vector<std::uint64_t> checks_;  // per robot: the token of its pending check (0: none)
  std::vector<int> lost_by_;           // per robot: how many robots hold it for lost
  std::vector<int> back_;              // scratch: teammates heard again by a heartbeat feed
  std::vector<Loss> losses_;
};

}  // namespace tpuaf
