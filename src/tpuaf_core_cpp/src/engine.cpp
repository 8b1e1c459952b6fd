// The graph runtime's event loop: event queue, robot motion on graph edges, the team bus with
// delay and loss, faults and liveness; the recorder and the strategies are separate files.
#include "tpuaf_core/engine.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace tpuaf {

namespace {
// Python's max(a, b): a unless b > a (the same number for doubles without NaN).
inline double py_max(double a, double b) { return b > a ? b : a; }
}  // namespace

// ----------------------------------------------------------------------------- GraphEngine

GraphEngine::GraphEngine(const PatrolGraph& graph, Points positions, EngineConfig config,
                         UncertaintyField field, NumpyPcg64 bus_rng)
    : graph_(graph),
      positions_(std::move(positions)),
      config_(std::move(config)),
      recorder_(config_, std::move(field)),
      bus_(config_.robots, config_.delay_s, config_.loss, bus_rng) {
  const int n = config_.robots;
  if (positions_.rows() != graph_.num_vertices()) {
    throw std::invalid_argument("need one position per graph vertex");
  }
  if (static_cast<int>(config_.start_vertices.size()) != n) {
    throw std::invalid_argument("need one start vertex per robot");
  }
  if (!(config_.nominal_speed_mps > 0)) throw std::invalid_argument("nominal speed must be > 0");
  robots_.resize(static_cast<std::size_t>(n));
  protocols_.reserve(static_cast<std::size_t>(n));
  ProtocolConfig pc;
  pc.robots = n;
  pc.stay_s = config_.stay_s;
  pc.retry_s = config_.retry_s;
  pc.teammate_timeout_s = config_.teammate_timeout_s;
  pc.visit_radius_m = config_.visit_radius_m;
  pc.goal_tolerance_m = config_.goal_tolerance_m;
  for (int i = 0; i < n; ++i) {
    Robot& r = robots_[static_cast<std::size_t>(i)];
    const int v = config_.start_vertices[static_cast<std::size_t>(i)];
    graph_.check_vertex(v);
    r.p0x = positions_(v, 0);
    r.p0y = positions_(v, 1);
    pc.robot = i;
    protocols_.emplace_back(static_cast<RobotDriver&>(*this), positions_, pc);
    protocols_.back().place(v);
  }
  scratch_.resize(n, 2);
  const std::int64_t nv = graph_.num_vertices();
  for (const auto& [w, u, v, seconds] : config_.turn_times) {
    graph_.check_vertex(w);
    graph_.check_vertex(u);
    graph_.check_vertex(v);
    if (!std::isfinite(seconds)) throw std::invalid_argument("a turn time must be finite");
    turns_[(w * nv + u) * nv + v] = seconds;
  }
  if (config_.narrow_headway_s > 0 && !config_.narrow_vertices.empty()) {
    if (!std::isfinite(config_.narrow_headway_s)) {
      throw std::invalid_argument("the narrow headway must be finite");
    }
    const auto vertices = static_cast<std::size_t>(graph_.num_vertices());
    narrow_.assign(vertices, 0);
    standing_.assign(vertices, -1);
    slots_.resize(vertices);
    held_.resize(vertices);
    for (int v : config_.narrow_vertices) {
      graph_.check_vertex(v);
      narrow_[static_cast<std::size_t>(v)] = 1;
    }
    for (int i = 0; i < n; ++i) {
      const int v = config_.start_vertices[static_cast<std::size_t>(i)];
      if (narrow(v) && standing_[static_cast<std::size_t>(v)] < 0) {
        standing_[static_cast<std::size_t>(v)] = i;
      }
    }
  }
}

const GraphEngine::Robot& GraphEngine::robot_at(int robot) const {
  if (robot < 0 || robot >= config_.robots) {
    throw std::out_of_range("unknown robot " + std::to_string(robot) + " (team of " +
                            std::to_string(config_.robots) + ")");
  }
  return robots_[static_cast<std::size_t>(robot)];
}

const RobotProtocol& GraphEngine::protocol(int robot) const {
  robot_at(robot);
  return protocols_[static_cast<std::size_t>(robot)];
}

double GraphEngine::average_speed(int robot) const {
  const Robot& r = robot_at(robot);
  if (r.travel_time_s > 1.0 && r.travelled_m > 0) return r.travelled_m / r.travel_time_s;
  return config_.nominal_speed_mps;
}

void GraphEngine::position(int robot, double t, double& x, double& y) const {
  const Robot& r = robot_at(robot);
  const double elapsed = std::min(py_max(t - r.t0, 0.0), r.t1 - r.t0);
  x = r.p0x + r.vx * elapsed;
  y = r.p0y + r.vy * elapsed;
}

void GraphEngine::positions(double t, Points& out) const {
  for (std::size_t i = 0; i < robots_.size(); ++i) {
    const Robot& r = robots_[i];
    // numpy: minimum(maximum(t - t0, 0), t1 - t0), then p0 + v * elapsed
    double elapsed = t - r.t0;
    if (!(elapsed >= 0.0)) elapsed = 0.0;
    const double span = r.t1 - r.t0;
    if (!(elapsed <= span)) elapsed = span;
    out(static_cast<Eigen::Index>(i), 0) = r.p0x + r.vx * elapsed;
    out(static_cast<Eigen::Index>(i), 1) = r.p0y + r.vy * elapsed;
  }
}

std::uint64_t GraphEngine::push(double time, int kind, int payload) {
  ++seq_;
  events_queue_.push({time, kind, seq_, payload});
  return seq_;
}

void GraphEngine::send(int robot, TeamMessage message) {
  const bool faults = !faults_.empty();
  if (faults) {
    if (!protocol(robot).alive()) return;  // a dead robot sends nothing
    // The destination announced (RobotMachine.send: on_announce), for the recovery metrics.
    int announced = message.announced;
    if (message.kind == TeamMessage::Kind::kIntention) {
      announced = message.vertex;
    } else if (message.kind != TeamMessage::Kind::kOpaque) {
      announced = message.next_vertex;
    }
    if (announced >= 0) recorder_.record_announcement(robot, announced, now_);
  } else {
    robot_at(robot);
  }
  std::int64_t id;
  if (!free_messages_.empty()) {
    id = free_messages_.back();
    free_messages_.pop_back();
    messages_[static_cast<std::size_t>(id)] = std::move(message);
  } else {
    id = static_cast<std::int64_t>(messages_.size());
    messages_.push_back(std::move(message));
  }
  if (!bus_.send(robot, id, now_)) free_message(id);
}

void GraphEngine::free_message(std::int64_t id) {
  messages_[static_cast<std::size_t>(id)] = TeamMessage{};  // drops a Python message now
  free_messages_.push_back(id);
}

void GraphEngine::wake_at(int robot, double time_s) {
  robot_at(robot);
  protocol_of(robot).wake_at(time_s);
}

void GraphEngine::change_goal(int robot, int vertex) {
  robot_at(robot);
  graph_.check_vertex(vertex);
  protocol_of(robot).change_goal(vertex);
}

void GraphEngine::deliver_batch_by_robot() {
  // The ready deliveries, robot by robot; each robot gets them in their order (the strategy's
  // messages_are_local() makes this the same as delivery by delivery).
  batch_.clear();
  while (!bus_.ready().empty()) batch_.push_back(bus_.pop_ready());
  batch_cursor_.assign(batch_.size(), 0);
  const int n = config_.robots;
  const bool faults = !faults_.empty();
  for (int r = 0; r < n; ++r) {
    for (std::size_t k = 0; k < batch_.size(); ++k) {
      const BusDelivery& d = batch_[k];
      if (d.all_but_sender) {
        if (r == d.sender) continue;
      } else {
        std::size_t& c = batch_cursor_[k];
        if (c == d.recipients.size() || d.recipients[c] != r) continue;  // ascending
        ++c;
      }
      const TeamMessage& message = message_of(d);
      if (faults) {  // the team's delivery (no sender is lost: nobody's check moves)
        if (!team_->deliver_to(r, message.robot, now_)) continue;
        bus_.count_delivered(1);
      }
      strategy_->on_message(*this, r, message);
    }
  }
  for (const BusDelivery& d : batch_) {
    if (!faults) {  // else counted per live recipient above
      bus_.count_delivered(d.all_but_sender ? n - 1 : static_cast<long long>(d.recipients.size()));
    }
    free_message(d.message);
  }
  batch_.clear();
}

void GraphEngine::deliver_heard() {
  // The team's rule (TeamLiveness::deliver_ready): message by message, each live recipient first
  // hears its sender (a teammate back from lost moves its check), then gets the message.
  team_->deliver_ready(
      now_, [this](const BusDelivery& d) { return message_of(d).robot; },
      [this](int r, const BusDelivery& d) { strategy_->on_message(*this, r, message_of(d)); },
      [this](const BusDelivery& d) { free_message(d.message); });
}

void GraphEngine::deliver_ready() {
  const std::deque<BusDelivery>& ready = bus_.ready();
  if (!faults_.empty()) {
    // While no robot holds a sender of these messages for lost, hearing it cannot plan a
    // liveness check (no event is pushed during the deliveries): robot by robot is then the
    // same as message by message.
    bool batch = ready.size() > 1 && strategy_->messages_are_local();
    for (std::size_t k = 0; batch && k < ready.size(); ++k) {
      const int sender = message_of(ready[k]).robot;
      batch = sender < 0 || sender >= config_.robots || team_->lost_by(sender) == 0;
    }
    if (batch) {
      deliver_batch_by_robot();
    } else {
      deliver_heard();
    }
    return;
  }
  if (team_hears_alike()) {  // the strategy may hear a message once for the team
    const long long mates = config_.robots - 1;
    while (!ready.empty() && ready.front().all_but_sender &&
           strategy_->on_team_message(*this, ready.front().sender, message_of(ready.front()))) {
      free_message(bus_.pop_ready().message);
      bus_.count_delivered(mates);
    }
    if (ready.empty()) return;
  }
  if (ready.size() > 1 && strategy_->messages_are_local()) {
    deliver_batch_by_robot();
    return;
  }
  while (!ready.empty()) {
    const BusDelivery d = bus_.pop_ready();
    const TeamMessage& message = message_of(d);
    long long delivered = 0;
    d.for_each_recipient(config_.robots, [&](int r) {
      strategy_->on_message(*this, r, message);
      ++delivered;
    });
    bus_.count_delivered(delivered);
    free_message(d.message);
  }
}

void GraphEngine::plan_route(Robot& r, int from, int goal) {
  r.route_k = 0;
  if (goal == from) {
    r.route.assign(1, goal);
  } else {
    r.route = graph_.path(from, goal);
    r.route.erase(r.route.begin());
  }
}

int GraphEngine::policy_decide(int robot) {
  const int goal = strategy_->decide(*this, robot);
  if (goal >= 0) graph_.check_vertex(goal);
  return goal;
}

void GraphEngine::emit(int robot, int kind, int vertex, int /*from_vertex*/, double t) {
  // The recorder's share of the protocol's events (GOAL and FAILED are not recorded here).
  if (kind == robot_event::kReached || kind == robot_event::kStart) {
    recorder_.record_visit(robot, vertex, t);
  } else if (kind == robot_event::kDwell) {
    recorder_.count_dwell(protocols_[static_cast<std::size_t>(robot)].last_dwell_s());
  }
}

void GraphEngine::drive(int robot, int from_vertex, int goal) {
  plan_route(robots_[static_cast<std::size_t>(robot)], from_vertex, goal);
  move(robot);
}

void GraphEngine::dwell(int robot, int vertex, double /*duration_s*/) {
  // A one-vertex route: start_segment stands config_.stay_s (the protocol's stay) on it.
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  r.route.assign(1, vertex);
  r.route_k = 0;
  start_segment(robot);
}

bool GraphEngine::at_vertex(int robot, int vertex) const {
  // A robot that can move stands exactly on its vertex between drives; a stalled one may have
  // stopped anywhere.
  const RobotProtocol& p = protocols_[static_cast<std::size_t>(robot)];
  return !p.stalled() || p.within_goal_tolerance(vertex);
}

void GraphEngine::move(int robot) {
  // A stalled robot cannot move; its navigator gives up later.
  if (protocols_[static_cast<std::size_t>(robot)].stalled()) {
    give_up_later(robot);
  } else {
    start_segment(robot);
  }
}

void GraphEngine::start_segment(int robot) {
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  RobotProtocol& p = protocols_[static_cast<std::size_t>(robot)];
  const int here = p.current_vertex(), next = r.route[r.route_k];
  const double x0 = positions_(here, 0), y0 = positions_(here, 1);
  const double x1 = positions_(next, 0), y1 = positions_(next, 1);
  double duration;
  if (next == here) {
    duration = config_.stay_s;
  } else {
    leave(robot, here);
    const double length = graph_.edge_length(here, next);
    const double driven = length / config_.nominal_speed_mps;
    // the turn at `here` from the way it arrived (a turn back: slower than the edge's mean)
    duration = driven + turn_s(r.came_from, here, next);
    if (!(duration > 0)) duration = driven;
    r.came_from = here;
    // one robot at a time through a narrow vertex: it drives slower to take its passing slot
    if (narrow(next)) duration = take_slot(next, now_ + duration) - now_;
    r.travelled_m += length;
    r.travel_time_s += duration;
  }
  p.observe(x0, y0);  // straight: ends are the extremes
  r.t0 = now_;
  r.t1 = now_ + duration;
  r.p0x = x0;
  r.p0y = y0;
  r.vx = (x1 - x0) / duration;  // [m/s] along the straight segment
  r.vy = (y1 - y0) / duration;
  r.pending = push(r.t1, kArrive, robot);
}

double GraphEngine::turn_s(int from, int at, int to) const {
  if (from < 0 || turns_.empty()) return 0.0;
  const std::int64_t nv = graph_.num_vertices();
  const auto it = turns_.find((from * nv + at) * nv + to);
  return it == turns_.end() ? 0.0 : it->second;
}

void GraphEngine::arrive(int robot) {
  // A vertex of the route reached: the protocol says whether to go on (a pass-through vertex).
  // A narrow vertex another robot stands on holds it short of it until that robot leaves.
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  const int vertex = r.route[r.route_k];
  if (blocks(robot, vertex)) {
    hold_short(robot, vertex);
    return;
  }
  ++r.route_k;
  if (narrow(vertex)) standing_[static_cast<std::size_t>(vertex)] = robot;  // until it leaves
  if (protocol_of(robot).on_vertex(vertex, r.route_k >= r.route.size())) start_segment(robot);
}

double GraphEngine::take_slot(int vertex, double earliest_s) {
  // The first time >= earliest_s at least the headway from every passing time taken [s].
  const double h = config_.narrow_headway_s;
  std::vector<double>& taken = slots_[static_cast<std::size_t>(vertex)];
  taken.erase(taken.begin(), std::lower_bound(taken.begin(), taken.end(), now_ - h));
  double t = earliest_s;
  for (double s : taken) {
    if (s >= t + h) break;
    if (s > t - h) t = s + h;
  }
  taken.insert(std::lower_bound(taken.begin(), taken.end(), t), t);
  return t;
}

bool GraphEngine::blocks(int robot, int vertex) const {
  if (!narrow(vertex)) return false;
  const int other = standing_[static_cast<std::size_t>(vertex)];
  if (other < 0 || other == robot) return false;
  const RobotProtocol& p = protocols_[static_cast<std::size_t>(other)];
  return p.alive() && !p.stalled();  // the graph runtime models no body (docs/LANES.md)
}

void GraphEngine::hold_short(int robot, int vertex) {
  // It waits a headway's drive short of `vertex` (at most half the edge) until the robot on it
  // leaves; after the navigator's give-up time its goal fails, as a blocked robot's in physics.
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  const int from = protocol_of(robot).current_vertex();
  const double x = positions_(vertex, 0), y = positions_(vertex, 1);
  const double dx = positions_(from, 0) - x, dy = positions_(from, 1) - y;
  const double d = std::hypot(dx, dy);
  const double back =
      d > 0 ? std::min(0.5 * d, config_.narrow_headway_s * config_.nominal_speed_mps) / d : 0.0;
  r.p0x = x + dx * back;
  r.p0y = y + dy * back;
  r.vx = r.vy = 0.0;
  r.t0 = r.t1 = now_;
  protocol_of(robot).observe(r.p0x, r.p0y);
  r.held_short_of = vertex;
  held_[static_cast<std::size_t>(vertex)].push_back(robot);
  r.pending = push(now_ + config_.stall_give_up_s, kGiveUp, robot);
}

void GraphEngine::stop_holding(int robot) {
  Robot& r = robots_[static_cast<std::size_t>(robot)];
  if (r.held_short_of < 0) return;
  std::deque<int>& queue = held_[static_cast<std::size_t>(r.held_short_of)];
  queue.erase(std::remove(queue.begin(), queue.end(), robot), queue.end());
  r.held_short_of = -1;
}

void GraphEngine::leave(int robot, int vertex) {
  // It drives off `vertex` (or stops for good): the first robot held short of it comes on,
  // a headway later.
  if (standing_.empty() || standing_[static_cast<std::size_t>(vertex)] != robot) return;
  standing_[static_cast<std::size_t>(vertex)] = -1;
  std::deque<int>& queue = held_[static_cast<std::size_t>(vertex)];
  if (queue.empty()) return;
  const int next = queue.front();
  queue.pop_front();
  Robot& r = robots_[static_cast<std::size_t>(next)];
  double x, y;
  position(next, now_, x, y);
  r.held_short_of = -1;
  r.p0x = x;  // from where it waited, onto the vertex by its passing slot
  r.p0y = y;
  r.t0 = now_;
  r.t1 = take_slot(vertex, now_ + config_.narrow_headway_s);
  r.vx = (positions_(vertex, 0) - x) / (r.t1 - r.t0);
  r.vy = (positions_(vertex, 1) - y) / (r.t1 - r.t0);
  r.pending = push(r.t1, kArrive, next);
}

void GraphEngine::record_positions(double t) {
  if (t > last_positions_time_) {
    positions(t, scratch_);
    recorder_.record_positions(t, scratch_);
    last_positions_time_ = t;
  }
}

void GraphEngine::run(const std::function<void(double)>& progress) {
  if (strategy_ == nullptr) throw std::logic_error("no strategy set");
  const double end = config_.duration_s;
  const int n = config_.robots;
  record_positions(0.0);
  for (std::size_t k = 0; k < faults_.size(); ++k) {
    push(faults_[k].time_s, kFault, static_cast<int>(k));
  }
  for (int i = 0; i < n; ++i) protocol_of(i).start();  // START (a visit), the policy's start
  deliver_ready();
  for (int i = 0; i < n; ++i) {
    protocol_of(i).decide();
    deliver_ready();
  }
  if (team_) team_->start(now_);
  double next_progress = 0.0;
  auto next_wall = std::chrono::steady_clock::now() + std::chrono::milliseconds(100);
  for (;;) {
    // The next event: the queue's, or the bus's next message in flight at its due time (as a
    // kDeliver event: after arrivals and wake-ups of that time, before the other kinds).
    const double due_s = bus_.next_due_s();
    const bool message_next =
        events_queue_.empty() || due_s < events_queue_.top().time ||
        (due_s == events_queue_.top().time && kDeliver < events_queue_.top().kind);
    Event ev{due_s, kDeliver, 0, -1};
    if (!message_next) ev = events_queue_.top();
    if (!(ev.time <= end)) break;
    if (!message_next) events_queue_.pop();
    ++events_;
    if (ev.time > now_) {
      record_positions(ev.time);
      now_ = ev.time;
    }
    if (ev.kind == kDeliver) {
      bus_.release_next();
    } else if (ev.kind == kArrive) {
      if (robots_[static_cast<std::size_t>(ev.payload)].pending == ev.seq) arrive(ev.payload);
    } else if (ev.kind == kWake) {
      protocol_of(ev.payload).on_wake();
    } else if (ev.kind == kFault) {
      const EngineFault& f = faults_[static_cast<std::size_t>(ev.payload)];
      team_->inject(f.robot, f.death, now_);
    } else if (ev.kind == kGiveUp) {
      if (robots_[static_cast<std::size_t>(ev.payload)].pending == ev.seq) give_up(ev.payload);
    } else if (ev.kind == kLiveness) {
      team_->check_due(ev.payload, ev.seq, now_);
    }
    deliver_ready();
    // Every 1/200 of the run, and every 0.1 s of wall time (looked at every 256 events): a
    // signal reaches Python within ~0.1 s however long the run and slow its events (issue 22).
    bool call = progress && now_ >= next_progress;
    if (progress && !call && (events_ & 0xFF) == 0) {
      call = std::chrono::steady_clock::now() >= next_wall;
    }
    if (call) {
      progress(now_);
      next_progress = std::max(next_progress, now_ + end / 200.0);
      next_wall = std::chrono::steady_clock::now() + std::chrono::milliseconds(100);
    }
  }
  record_positions(end);
  now_ = end;
  if (progress) progress(end);
}

}  // namespace tpuaf
