// The team bus: loss draws, the messages in flight and the ready ones.
#include "tpuaf_core/team_bus.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

namespace tpuaf {

namespace {
std::string number(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}
}  // namespace

TeamBus::TeamBus(int robots, double delay_s, double loss, NumpyPcg64 rng)
    : robots_(robots), delay_s_(delay_s), loss_(loss), rng_(rng) {
  if (robots < 1) throw std::invalid_argument("need at least one robot");
  if (!(delay_s >= 0) || !std::isfinite(delay_s)) {
    throw std::invalid_argument("message delay must be a finite number >= 0 s, got " +
                                number(delay_s));
  }
  if (!(loss >= 0 && loss <= 1)) {
    throw std::invalid_argument("message loss probability must be in [0, 1], got " + number(loss));
  }
  alive_.assign(static_cast<std::size_t>(robots), 1);
}

bool TeamBus::alive(int robot) const {
  if (robot < 0 || robot >= robots_) {
    throw std::out_of_range("unknown robot " + std::to_string(robot) + " (team of " +
                            std::to_string(robots_) + ")");
  }
  return alive_[static_cast<std::size_t>(robot)] != 0;
}

void TeamBus::set_alive(int robot, bool alive) {
  if (this->alive(robot) == alive) return;
  alive_[static_cast<std::size_t>(robot)] = alive ? 1 : 0;
  dead_ += alive ? -1 : 1;
}

bool TeamBus::send(int sender, std::int64_t message, double now_s) {
  alive(sender);  // checks the index
  ++stats_.sent;
  BusDelivery d;
  d.message = message;
  d.sender = sender;
  if (loss_ > 0 || dead_ > 0) {
    for (int i = 0; i < robots_; ++i) {
      // numpy: lost = rng.random(N) < loss, a draw for every robot
      const bool lost = loss_ > 0 && rng_.random() < loss_;
      if (i == sender || !alive_[static_cast<std::size_t>(i)]) continue;
      if (lost) {
        ++stats_.lost;
      } else {
        d.recipients.push_back(i);
      }
    }
    if (d.recipients.empty()) return false;
  } else {
    if (robots_ == 1) return false;
    d.all_but_sender = true;
  }
  if (delay_s_ == 0) {
    ready_.push_back(std::move(d));
    return true;
  }
  const double due_s = now_s + delay_s_;
  // After every message due by then (send order among equal due times); at the end unless
  // the clock went back.
  auto at = in_flight_.end();
  if (!in_flight_.empty() && in_flight_.back().due_s > due_s) {
    at = std::upper_bound(in_flight_.begin(), in_flight_.end(), due_s,
                          [](double t, const InFlight& f) { return t < f.due_s; });
  }
  in_flight_.insert(at, InFlight{due_s, std::move(d)});
  return true;
}

void TeamBus::release_next() {
  if (in_flight_.empty()) throw std::logic_error("release_next: no message in flight");
  ready_.push_back(std::move(in_flight_.front().delivery));
  in_flight_.pop_front();
}

void TeamBus::release_due(double now_s, double slack_s) {
  while (!in_flight_.empty() && in_flight_.front().due_s <= now_s + slack_s) release_next();
}

BusDelivery TeamBus::pop_ready() {
  if (ready_.empty()) throw std::logic_error("pop_ready: no message ready");
  BusDelivery d = std::move(ready_.front());
  ready_.pop_front();
  return d;
}

}  // namespace tpuaf
