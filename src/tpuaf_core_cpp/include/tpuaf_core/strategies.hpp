// The C++ decision paths of TPUAF (Eq. 6-14), GBS and DTAG: each strategy's one implementation.
#pragma once

#include <deque>
#include <unordered_map>
#include <utility>
#include <vector>

#include "tpuaf_core/knowledge.hpp"
#include "tpuaf_core/numpy_random.hpp"
#include "tpuaf_core/strategy.hpp"

namespace tpuaf {

// TPUAF (tpuaf.policies.tpuaf.Tpuaf, and TpuafAnyVertex with any_vertex): every robot holds
// a copy of `knowledge` (built as the Python policy builds it) and its own random stream
// (numpy default_rng([seed, 2, robot])) for the tie-break. On a bus without loss and delay the
// copies would stay equal but for each robot's own intention: the team then holds one
// knowledge (TpuafKnowledge::hear_team_*), so a message costs O(1), not O(robots).
class TpuafStrategy : public TeamStrategy {
 public:
  // colocation: the Python policy's `colocation` parameter (robots that arrive together
  // before late messages tell resolve by index, tpuaf/policies/tpuaf.py).
  TpuafStrategy(const TpuafKnowledge& knowledge, UtilityForm form, bool any_vertex,
                std::vector<NumpyPcg64> rngs, bool colocation = true);
  void start(StrategyHost& host, int robot) override;
  int decide(StrategyHost& host, int robot) override;
  void on_message(StrategyHost& host, int robot, const TeamMessage& message) override;
  // As Tpuaf.on_teammate_lost: forget its intention, it is no longer my shadow.
  void on_teammate_lost(StrategyHost& host, int robot, int lost) override;
  bool messages_are_local() const override { return true; }
  bool on_team_message(StrategyHost& host, int sender, const TeamMessage& message) override;
  // What robot `robot` knows (a copy; the team's knowledge without its own intention when
  // the team shares one).
  TpuafKnowledge knowledge(int robot) const;
  bool shares_knowledge() const { return shared_; }

 private:
  TpuafKnowledge& knowledge_of(int robot) {
    return knowledge_[shared_ ? 0 : static_cast<std::size_t>(robot)];
  }
  struct Colocation {
    double latency_s = 0;  // largest message latency seen (receive - send) [s]
    std::unordered_map<int, std::deque<std::pair<double, int>>> my_visits;  // v -> (t, next)
    std::vector<char> shadows;                                              // per teammate
  };
  void presume_choice(StrategyHost& host, int robot, int mate);
  void track_shadow(int robot, const TeamMessage& visit);
  TpuafKnowledge prototype_;
  UtilityForm form_;
  bool any_vertex_;
  std::vector<NumpyPcg64> rngs_;
  bool colocation_;
  bool shared_ = false;                    // one knowledge for the team (knowledge_[0])
  std::vector<TpuafKnowledge> knowledge_;  // per robot, or the team's
  std::vector<Colocation> colocated_;
  std::vector<int> candidates_;
};

// Candidate of largest score, ties (within tol * max(1, |max|)) at random with rng.integers:
// tpuaf.policies.common.pick_max. Returns an index into scores.
int pick_max_index(const std::vector<double>& scores, NumpyPcg64& rng, double tol = 1e-9);

// GBS (tpuaf.policies.bayesian.GreedyBayesian): argmax over the neighbours of
// P = G1 exp(ln(1/G1) gain / G2), gain = shared idleness / max(edge, edge_min). G2 and edge_min
// come resolved from the Python policy. exp is the C library's, where numpy uses its own SIMD
// exp (both within 1 ulp); the decision compares P with a 1e-9 tolerance, so the runs agree
// unless a P falls within 1 ulp of that threshold (tests/test_engine_golden.py checks).
class GbsStrategy : public TeamStrategy {
 public:
  GbsStrategy(double g1, double g2, double edge_min_m, std::vector<NumpyPcg64> rngs);
  void start(StrategyHost& host, int robot) override;
  int decide(StrategyHost& host, int robot) override;
  void on_message(StrategyHost& host, int robot, const TeamMessage& message) override;
  bool messages_are_local() const override { return true; }

 private:
  double g1_, g2_, edge_min_m_, log_inv_g1_;
  std::vector<NumpyPcg64> rngs_;
  std::vector<std::vector<double>> last_visit_;  // per robot, per vertex [s]
  std::vector<int> candidates_;
  std::vector<double> scores_;
};

// DTAG (tpuaf.policies.dtag): argmax over all vertices of w_idleness E[v] - w_path path(cv, v)
// - w_origin |pos(v) - origin|; estimates shared (min-merge), the next vertex reserved, the
// higher-id robot of a clash re-plans once per decision (change_goal). origin_distance_m:
// per robot, |pos(v) - start position| computed by numpy (np.hypot) on the Python side.
class DtagStrategy : public TeamStrategy {
 public:
  DtagStrategy(double initial_estimate_s, double w_idleness, double w_path, double w_origin,
               std::vector<std::vector<double>> origin_distance_m, std::vector<NumpyPcg64> rngs);
  void start(StrategyHost& host, int robot) override;
  int decide(StrategyHost& host, int robot) override;
  void on_message(StrategyHost& host, int robot, const TeamMessage& message) override;
  long long replans(int robot) const;

 private:
  struct State {
    std::vector<double> values;  // E[v] [s]
    double updated = 0;
    int next = -1;
    bool replanned = false;
    long long replans = 0;
  };
  void advance(State& s, double now);
  int choose(StrategyHost& host, int robot, int here, int exclude_a, int exclude_b);
  void announce(StrategyHost& host, int robot, int next);
  double initial_, w_idleness_, w_path_, w_origin_;
  std::vector<std::vector<double>> origin_distance_m_;
  std::vector<NumpyPcg64> rngs_;
  std::vector<State> states_;
  std::vector<int> candidates_;
  std::vector<double> scores_;
};

}  // namespace tpuaf
