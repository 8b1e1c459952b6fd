// TPUAF+'s decision path in C++ (tpuaf/policies/tpuaf_plus.py, step for step): even spacing
// on a shared walk from the mates' timed messages, the start schedule, re-spacing and
// re-planning after a loss, and repair hops. The plans themselves (the choice between the
// tour and the partitions, the merge repair) come from the Python planner through a callback,
// called only when a robot's view of the team changes. Times in seconds, lengths in metres.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <map>
#include <memory>
#include <utility>
#include <vector>

#include "tpuaf_core/strategies.hpp"
#include "tpuaf_core/team_visits.hpp"

namespace tpuaf {

// One closed walk of a plan and the robots that share it (tpuaf_plus.Route).
struct PlusRoute {
  std::vector<int> walk;    // vertex indices; consecutive entries adjacent, last -> first too
  std::vector<double> arc;  // [m] arc position of each walk entry from walk[0]
  double length = 0;        // [m] L
  std::vector<int> robots;  // robot indices on this walk, sorted
  // [m] target gaps between consecutive robots along the walk, one per robot (sum L; which
  // robot has which gap: by their places); empty: even, L / m (one-way walks that pass a vertex
  // twice space robots unevenly so that none meet there: tpuaf_plus.uneven_gaps)
  std::vector<double> gaps;

  // Walk indices (a range of ints).
  struct Indices {
    const int* first;
    const int* last;
    const int* begin() const { return first; }
    const int* end() const { return last; }
  };
  // The walk indices i, ascending, where walk[i] == from (from == to) or where the walk steps
  // from -> to (walk[i] == from, walk[i + 1] == to, last -> first too); empty if none. Built on
  // first use (O(walk)), then O(hits of `from`): placing a mate costs its hits, not the walk's
  // length.
  Indices positions(int from, int to) const;

  // positions()'s index (public members keep PlusRoute an aggregate): per vertex v, entries
  // by_vertex_[v] .. by_vertex_[v + 1] of at_ (walk indices at v, ascending) and of steps_ (the
  // same, ordered by the next vertex, then ascending)
  mutable std::vector<int> by_vertex_, at_, steps_;
};

// A plan (tpuaf_plus.Plan): its walks, each robot's walk and the start schedule.
struct PlusPlan {
  std::vector<PlusRoute> routes;
  std::vector<int> route_of;  // per robot: index into routes (-1: not in the plan's team)
  // Per robot: (entry walk index, departure [s]) of the start schedule; entry -1: none.
  std::vector<std::pair<int, double>> schedule;
};

struct TpuafPlusParams {
  double speed_mps = 1.0;        // plan speed v (the map's nominal speed)
  double gain = 0.35;            // an early robot dwells 2 gain e / u (phase error e [m])
  double pace_weight = 0.25;     // weight of a new pace sample in a mate's running average
  double deadband_s = 0.5;       // no dwell below this
  double dwell_revisit_s = 5.0;  // a dwelling robot re-visits its vertex this often
  double stay_s = 1.0;           // the runtimes' dwell for a goal equal to the vertex
  // follow learned travel times (TpuafPlusStrategy::retime); off: the walks keep the model's
  // times (measured: docs/STRATEGIES.md, benchmarks/results/retime_tpuaf_plus.md)
  bool retime = false;
  // re-time only when a target gap would move by more than this share of the even gap L / m
  // (retime_gap_change)
  double retime_tolerance = 0.10;
};

// Python's float a % b (np.mod): the result takes the sign of b.
double py_mod(double a, double b);

// A robot's measured pace [m/s] along its walk after one more sample: the running average
// pace + weight (sample - pace), the sample clamped to [0.1 v, v] (v = speed_mps).
double update_pace(double pace_mps, double sample_mps, double weight, double speed_mps);

// Phase error [m] of a robot on a closed walk of length_m shared by m = ahead_m.size() + 1
// robots: ahead_m are its mates' distances ahead along the walk [m], sorted, in [0, L]. With
// the robots' targets evenly spread by L / m around the team's mean phase, e = -mean_j (d_j -
// j L / m) (itself j = 0, d_0 = 0): e > 0 the robot is early (ahead of its phase), e < 0 late.
double phase_error(const std::vector<double>& ahead_m, double length_m);

// A mate on a shared walk as a robot places it.
struct MatePlace {
  double ahead_m = 0;   // [m] where it is, ahead along the walk, in [0, L] (dwelling: its vertex)
  double dwell_m = 0;   // [m] its pace x its dwell left: its phase is ahead_m - dwell_m
  double pace_mps = 1;  // its measured pace
  int robot = -1;       // its index (spacing_dwell_gaps)
};

// TPUAF+'s spacing dwell [s] at a walk vertex of a robot of pace pace_mps (u): over its mates
// in their order along the walk, the phase_error e of their phases; early (e > 0) 2 gain e / u
// (at least deadband_s + 0.1 s when e > deadband_s u), at most L / (m u), and never so long that
// the mate behind reaches the robot's vertex (it would queue behind it) less deadband_s; late 0.
double spacing_dwell(std::vector<MatePlace> mates, double length_m, double pace_mps, double gain,
                     double deadband_s);

// spacing_dwell towards uneven target gaps (PlusRoute::gaps, m of them; else spacing_dwell):
// mate j ahead's target is the sum of the gaps from the robot's slot, its slot the rotation of
// the gaps nearest its mates' phases (least squares). Even gaps give spacing_dwell's dwell.
double spacing_dwell_gaps(std::vector<MatePlace> mates, const std::vector<double>& gaps, int robot,
                          double length_m, double pace_mps, double gain, double deadband_s);

// Re-timing a walk (learned travel times): robots on their target phases on `from` carried to
// `to` (the same walk on other edge lengths; the same share of the same walk edge), the largest
// difference of a gap between consecutive robots from `to`'s target gap, as a share of the even
// gap L' / m, over the team's phases from each walk entry on; 0 for a lone robot.
double retime_gap_change(const PlusRoute& from, const PlusRoute& to);

// The walk index where a robot at `vertex` joins `route`: its nearest walk vertex (ties to the
// lowest vertex index), first occurrence (tpuaf_plus._entry_index).
int nearest_entry(const PatrolGraph& graph, const PlusRoute& route, int vertex);

// Steady-state worst idleness [s] of the closed walk's vertices with n_robots evenly spaced
// at speed_mps (tpuaf.maps.tours.walk_idleness(...)["worst"], the same arithmetic): per
// vertex, the largest gap between its passes (times rounded to 1e-9 s) in one period.
double walk_worst_idleness(const PatrolGraph& graph, const std::vector<int>& walk, int n_robots,
                           double speed_mps);

// TPUAF+'s start schedule (tpuaf_plus.start_schedule): per robot of route.robots, in order,
// (entry walk index, departure [s]). m virtual slots evenly spaced along the walk, moving at
// speed_mps, each pick up one robot (matched over slot phases by least squared departures,
// Hungarian); the schedule kept is the one whose walk vertices are all first visited soonest
// (then the least total wait), or with idle_s (per graph vertex, [s] at t = 0) the one whose
// vertices wait least in all. starts: start vertex per robot; late_m: v times how long after
// t = 0 each robot is at its start [m].
std::vector<std::pair<int, double>> start_schedule(const PatrolGraph& graph, const PlusRoute& route,
                                                   const std::vector<int>& starts,
                                                   const std::vector<double>& late_m,
                                                   double speed_mps,
                                                   const std::vector<double>* idle_s);

class TpuafPlusStrategy : public TeamStrategy {
 public:
  // The plan for `team` (sorted robot indices believed alive): tpuaf_plus.make_plan. timing:
  // null, or a re-timed graph (learned travel times): the same walks, their arc positions,
  // lengths and target gaps on its edge lengths.
  using PlanSource = std::function<std::shared_ptr<const PlusPlan>(const std::vector<int>&,
                                                                   const PatrolGraph* timing)>;

  TpuafPlusStrategy(const TpuafKnowledge& knowledge, TpuafPlusParams params, PlanSource plans);
  // The host's graph changed (a lane edge dropped: a dead robot's body on it, robot/lanes.py):
  // distances from it from now on, plans from `plans` (for it), robot `robot`'s re-installed.
  void replan(StrategyHost& host, int robot, PlanSource plans);
  void start(StrategyHost& host, int robot) override;
  int decide(StrategyHost& host, int robot) override;
  void on_message(StrategyHost& host, int robot, const TeamMessage& message) override;
  void on_goal_failed(StrategyHost& host, int robot, int vertex) override;
  void on_teammate_lost(StrategyHost& host, int robot, int lost) override;
  // Learned travel times: the walks stay (every robot keeps the one it drives and its place on
  // it); their arcs, lengths and target gaps follow host.graph()'s edge lengths (plan speed x
  // learned duration [m]), so the spacing evens the gaps in time; the mates' estimated
  // arcs, a re-spacing target and the paces [m/s] are carried over to the new arcs. Only when
  // that moves a target gap by more than params.retime_tolerance of L / m (retime_gap_change);
  // else the robot keeps the timing it has. Nothing unless params.retime.
  void retime(StrategyHost& host, int robot) override;
  bool is_native() const override { return false; }  // plans are made in Python
  bool messages_are_local() const override { return true; }
  // Robot `robot`'s current walk (its vertices) and the robots it believes alive.
  std::vector<int> walk(int robot) const;
  const PlusRoute& route(int robot) const;  // its walk with timing (arcs, length, gaps)
  std::vector<int> team(int robot) const;

 private:
  friend class TpuafPlusProbe;  // test/test_tpuaf_plus.cpp: the spacing rule's parts, by hand
  // A timed announcement: (from vertex, to vertex, departure [s], sent [s]).
  struct Heard {
    int from = -1, to = -1;
    double departure = 0, sent = 0;
  };
  // The last 4 announcements of one robot, oldest first (in place: one per message heard).
  class Recent {
   public:
    Recent() = default;
    Recent(std::initializer_list<Heard> entries) {
      for (const Heard& entry : entries) push(entry);
    }
    void push(const Heard& entry) {
      if (size_ == items_.size()) {
        std::copy(items_.begin() + 1, items_.end(), items_.begin());
        --size_;
      }
      items_[size_++] = entry;
    }
    const Heard* begin() const { return items_.data(); }
    const Heard* end() const { return items_.data() + size_; }

   private:
    std::array<Heard, 4> items_{};
    std::size_t size_ = 0;
  };
  struct Robot {
    explicit Robot(const TpuafKnowledge& k) : knowledge(k) {}
    // For repair hops' utilities only: the visits are in visits_, lent to it for each one.
    TpuafKnowledge knowledge;
    std::vector<char> alive;
    std::vector<double> lost_at;  // [s] reported lost by the runtime (+inf: not)
    std::vector<Heard> heard;     // latest timed message per mate
    std::vector<char> has_heard;
    std::vector<double> mate_arc;  // last estimated arc [m] per mate
    std::vector<char> has_mate_arc;
    // one-way walks (a step may be on the walk twice): each mate's walk index, followed forward
    // from message to message (-1: not yet), on the route mate_index_route (track_mate)
    std::vector<int> mate_index;
    const PlusRoute* mate_index_route = nullptr;
    std::vector<double> pace;  // [m/s] measured pace along the walk per robot (me too)
    double changed_at = 0;     // [s] when the team last changed
    bool holding = false;
    double hold_until = 0;  // planned departure while dwelling [s]
    bool respacing = false;
    double respace_target = 0, respace_at = 0;  // [m], [s]
    bool waking = false;
    double last_announce = 0;
    std::shared_ptr<const PlusPlan> plan;
    int route = -1;
    bool has_departure = false;
    double departure = 0;  // [s] start-schedule departure
    int entry = 0;
    int idx = -1;  // my walk index (-1: driving to my walk)
    bool started = false;
  };
  Robot& state(int robot);
  const PlusRoute& route_of(const Robot& r) const { return r.plan->routes[r.route]; }
  std::shared_ptr<const PlusPlan> plan_for(const std::vector<int>& team);
  void install_plan(StrategyHost& host, int robot, bool initial);
  int urgent_entry(int robot, const PlusRoute& route, int vertex, double now) const;
  std::map<int, int> transition_entries(const Robot& r, int robot) const;
  bool respace_target(Robot& r, int robot, double now, double& target);
  double idle_room(Robot& r, int robot, double now);
  double respace_wait(Robot& r, int robot, double now);
  void heard_from(Robot& r, int k, double sent) const;
  void remember(Robot& r, int robot, const Heard& entry);
  // What robot r holds of robot k's last announcements (histories_).
  Recent& history(const Robot& r, int k);
  const Recent& history(const Robot& r, int k) const;
  void learn_pace(Robot& r, int k, int vertex, double arrived_s) const;
  void update_team(StrategyHost& host, int robot);
  bool mate_arc(Robot& r, int k, double now, double& arc, double* dwell_m = nullptr);
  // One-way walks only: mate k announced the step from -> to at `sent` [s]; its walk index
  // moves on to the first walk position of that step at or after the one it had; before its
  // start-schedule departure it stays at its entry (tpuaf_plus_one_way.cpp).
  void track_mate(Robot& r, int k, int from, int to, double sent) const;
  // The tracked walk index of mate k when it is among `hits` (its latest step's positions).
  int tracked_hit(const Robot& r, int k, const PlusRoute::Indices& hits) const;
  double spacing_wait(Robot& r, int robot, double now);
  void announce(StrategyHost& host, int robot, int here, int next, double departure, bool visit);
  int hold(StrategyHost& host, int robot, int here, bool waking);
  int step(StrategyHost& host, int robot, bool waking);
  int repair_hop(StrategyHost& host, int robot, int here, int target);

  // d(u, v) [m] on graph_, through a direct-mapped memo (every robot asks the same steps).
  double distance(int u, int v) const;

  struct KnownLength {
    int u = -1, v = -1;
    double length_m = 0;
  };
  mutable std::vector<KnownLength> lengths_ = std::vector<KnownLength>(1u << 14);
  TpuafKnowledge prototype_;
  TeamVisits visits_;  // every robot's visits and estimate anchors (its knowledge's)
  // The last 4 announcements of robot k as robot r holds them, at [k * robots + r]: a message
  // heard by the whole team touches one stretch of memory.
  std::vector<Recent> histories_;
  TpuafPlusParams params_;
  PlanSource plans_;
  std::map<std::vector<int>, std::shared_ptr<const PlusPlan>> plan_cache_;
  const PatrolGraph* graph_ = nullptr;
  const PatrolGraph* timing_ = nullptr;  // the re-timed graph (retime), null: the plan's own
  std::vector<Robot> robots_;
};

}  // namespace tpuaf
