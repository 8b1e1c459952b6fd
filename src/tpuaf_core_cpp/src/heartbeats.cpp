// Heartbeats of runs with faults: when each robot hears each teammate.
#include "tpuaf_core/heartbeats.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace tpuaf {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

// -------------------------------------------------------------------------- HeartbeatLinks

HeartbeatLinks::HeartbeatLinks(int robots, double duration_s, double timeout_s, double delay_s,
                               double loss, double period_s, std::vector<NumpyPcg64> rngs)
    : n_(robots),
      period_s_(period_s),
      delay_s_(delay_s),
      timeout_s_(timeout_s),
      loss_(loss),
      rngs_(std::move(rngs)) {
  if (!(period_s > 0) || !std::isfinite(period_s)) {
    throw std::invalid_argument("heartbeat period must be a finite number > 0 s");
  }
  if (!(timeout_s > 0)) throw std::invalid_argument("teammate timeout must be > 0 s");
  if (!(loss >= 0 && loss <= 1)) {
    throw std::invalid_argument("heartbeat loss probability must be in [0, 1]");
  }
  if (loss > 0 && static_cast<int>(rngs_.size()) != robots) {
    throw std::invalid_argument("heartbeats with loss need one random stream per robot");
  }
  count_ = static_cast<std::int64_t>(std::floor(duration_s / period_s + 1e-9)) + 1;
  if (count_ > std::numeric_limits<std::int32_t>::max()) {
    throw std::invalid_argument("too many heartbeats in the run");
  }
  last_sent_.assign(static_cast<std::size_t>(n_), count_ - 1);
  links_.resize(static_cast<std::size_t>(n_));
}

void HeartbeatLinks::silences_of(Link& l) const {
  l.silences.clear();
  for (std::size_t p = 0; p + 1 < l.received.size(); ++p) {
    if (arrival(l.received[p + 1]) > arrival(l.received[p]) + timeout_s_) {
      l.silences.push_back(static_cast<std::int32_t>(p));
    }
  }
}

const HeartbeatLinks::Link& HeartbeatLinks::link(int recipient, int sender) {
  if (loss_ == 0) {  // every heartbeat heard: one link for all
    if (every_.received.empty()) {
      every_.received.resize(static_cast<std::size_t>(count_));
      for (std::int64_t k = 0; k < count_; ++k) {
        every_.received[static_cast<std::size_t>(k)] = static_cast<std::int32_t>(k);
      }
      silences_of(every_);
    }
    return every_;
  }
  auto& of_sender = links_[static_cast<std::size_t>(sender)];
  if (of_sender.empty()) {
    // numpy: rng.random((n, count)) >= loss, row = recipient.
    of_sender.resize(static_cast<std::size_t>(n_));
    NumpyPcg64& rng = rngs_[static_cast<std::size_t>(sender)];
    for (auto& l : of_sender) {
      for (std::int64_t k = 0; k < count_; ++k) {
        if (rng.random() >= loss_) l.received.push_back(static_cast<std::int32_t>(k));
      }
      silences_of(l);
    }
  }
  return of_sender[static_cast<std::size_t>(recipient)];
}

void HeartbeatLinks::died(int robot, double t) {
  auto k = static_cast<std::int64_t>(std::floor(t / period_s_ + 1e-9));
  if (static_cast<double>(k) * period_s_ > t) --k;
  auto& last = last_sent_[static_cast<std::size_t>(robot)];
  last = std::min(last, k);
}

std::int64_t HeartbeatLinks::heard_by(const Link& l, int sender, double t) const {
  const std::int64_t k =
      std::min(last_sent_[static_cast<std::size_t>(sender)],
               static_cast<std::int64_t>(std::floor((t - delay_s_) / period_s_ + 1e-9)));
  auto it = std::upper_bound(l.received.begin(), l.received.end(), k,
                             [](std::int64_t v, std::int32_t r) { return v < r; });
  std::int64_t pos = (it - l.received.begin()) - 1;
  if (pos >= 0 && arrival(l.received[static_cast<std::size_t>(pos)]) > t) --pos;  // rounding
  return pos;
}

double HeartbeatLinks::last_arrival_s(int recipient, int sender, double t) {
  if (recipient == sender) return -kInf;
  const Link& l = link(recipient, sender);
  const std::int64_t pos = heard_by(l, sender, t);
  return pos >= 0 ? arrival(l.received[static_cast<std::size_t>(pos)]) : -kInf;
}

double HeartbeatLinks::next_check_s(int recipient, int sender, double last_heard, bool lost,
                                    double now) {
  if (recipient == sender) return kInf;
  const Link& l = link(recipient, sender);
  const std::int64_t pos = heard_by(l, sender, now);
  const std::int64_t sent = last_sent_[static_cast<std::size_t>(sender)];
  auto it = std::upper_bound(l.received.begin(), l.received.end(), sent,
                             [](std::int64_t v, std::int32_t r) { return v < r; });
  const std::int64_t last = (it - l.received.begin()) - 1;
  const std::int64_t nxt = pos + 1 <= last ? pos + 1 : -1;  // the next heartbeat heard, if any
  auto at = [&](std::int64_t p) { return arrival(l.received[static_cast<std::size_t>(p)]); };
  if (lost) return nxt >= 0 ? at(nxt) : kInf;  // back at the next heartbeat heard
  if (std::isfinite(last_heard)) {
    const double due = last_heard + timeout_s_;
    if (nxt < 0 || at(nxt) > due) return due;  // silent from last_heard on
  } else if (nxt < 0) {
    return kInf;  // never heard, and never will be
  }
  // The first silence after the next heartbeat, or the sender's last heartbeat.
  auto s = std::lower_bound(l.silences.begin(), l.silences.end(), nxt,
                            [](std::int32_t v, std::int64_t x) { return v < x; });
  const std::int64_t end = s != l.silences.end() && *s < last ? *s : last;
  return at(end) + timeout_s_;
}

void HeartbeatLinks::feed(TeammateLiveness& liveness, double now, std::vector<int>* back) {
  const int me = liveness.me();
  for (int j = 0; j < n_; ++j) {
    const double t = last_arrival_s(me, j, now);
    if (t > -kInf && liveness.heard(j, t) && back != nullptr) back->push_back(j);
  }
}

double HeartbeatLinks::next_check_s(const TeammateLiveness& liveness, double now) {
  const int me = liveness.me();
  double due = kInf;
  for (int j = 0; j < n_; ++j) {
    if (j == me) continue;
    const double t = next_check_s(me, j, liveness.last_heard(j), liveness.lost(j), now);
    if (t < due) due = t;
  }
  return due;
}

}  // namespace tpuaf
