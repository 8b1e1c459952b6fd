// Lock-step of the tpuaf_stage node: which agent answered which odom tick (cmd_vel_stamped), who is
// unresponsive or gone, and the waits for the agents at start and after each tick.
#pragma once

#include <ros/ros.h>

#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace tpuaf_stage {

// [s] steady wall clock: lock-step timeouts, pacing and the status line.
double wall_now();

class Lockstep {
 public:
  // What the waits need from the node.
  struct Hooks {
    std::function<void(double timeout_s)> serve;  // callbacks for up to timeout_s [s of wall time]
    std::function<void()> publish_clock;          // /clock again while waiting at start
    std::function<void(const std::vector<bool>& robots)> resend;  // the tick again to these robots
    std::function<void(const std::string& kind, int robot, const std::string& detail)> event;
  };

  // ns: robot namespaces; timeouts [s of wall time]: ~lockstep_timeout, ~start_timeout.
  Lockstep(std::vector<std::string> ns, double lockstep_timeout_s, double start_timeout_s,
           Hooks hooks);

  // cmd_vel_stamped subscription of the next robot: its publisher is the robot's agent.
  void add_subscriber(ros::Subscriber sub) { cmd_stamped_sub_.push_back(std::move(sub)); }
  // Robot i answered the tick of stamp; an unresponsive robot is waited for again.
  void on_answer(int i, const ros::Time& stamp);
  // The team barrier (~lockstep_team): agent i's team message counts (lockstep_team topic,
  // std_msgs/Int64MultiArray [tick stamp in ns, messages sent, received from robot 0..n-1]).
  void enable_team() { team_ = true; }
  void on_team_counts(int i, const std::vector<std::int64_t>& data);
  // Until every robot's cmd_vel_stamped has a publisher (at most ~start_timeout).
  void start_gate();
  // After the odom tick at stamp tick: until every live agent has answered it.
  void wait_answers(const ros::Time& tick);

  bool unresponsive(int i) const { return unresponsive_[i]; }
  // Robot i's agent publishes its answers (it is not gone).
  bool has_agent(int i) const { return cmd_stamped_sub_[i].getNumPublishers() > 0; }
  int num_unresponsive() const;
  const std::vector<int>& unresponsive_count() const { return unresponsive_count_; }  // events
  const std::vector<std::int64_t>& answers() const { return answers_; }  // answers received
  // Team messages given up on (never delivered within ~lockstep_timeout), per receiving robot.
  const std::vector<std::int64_t>& team_lost() const { return team_lost_; }
  // Ticks without an agent to wait for, per robot.
  const std::vector<std::int64_t>& unwaited_ticks() const { return unwaited_ticks_; }

 private:
  std::vector<std::string> ns_;
  int n_;
  double lockstep_timeout_s_, start_timeout_s_;
  Hooks hooks_;
  std::vector<ros::Subscriber> cmd_stamped_sub_;

  std::vector<ros::Time> answered_;  // stamp of the latest lock-step answer
  std::vector<bool> ever_answered_, unresponsive_, gone_;
  std::vector<int> unresponsive_count_;
  std::vector<std::int64_t> unwaited_ticks_;
  std::vector<std::int64_t> answers_;

  // Team barrier: each agent's latest counts and the messages given up on per (receiver, sender).
  bool team_ = false;
  std::vector<bool> team_seen_;
  std::vector<ros::Time> team_tick_;
  std::vector<std::int64_t> team_sent_, team_lost_;
  std::vector<std::vector<std::int64_t>> team_received_, team_forgiven_;
  // Receivers still missing team messages (or their counts for tick); empty: none.
  std::string team_missing(const ros::Time& tick, const std::vector<bool>& live) const;
  void team_give_up(const ros::Time& tick, const std::vector<bool>& live);
};

}  // namespace tpuaf_stage
