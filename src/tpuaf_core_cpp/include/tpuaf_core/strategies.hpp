// TPUAF's decision path (Eq. 6-14): the strategy's one implementation, run by every runtime.
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
  // The navigator gave up on `vertex` (physics, robots): after a second failure there with no
  // visit between, within kFailedGoalHoldS of each other, it is no candidate for
  // kFailedGoalHoldS, so that a vertex no robot can reach (a dead robot's body on it) is not
  // chosen again and again (one failure, e.g. in a jam, holds nothing back); when every
  // candidate is held back, all are candidates.
  void on_goal_failed(StrategyHost& host, int robot, int vertex) override;
  static constexpr double kFailedGoalHoldS = 60.0;  // [s]
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
  void resolve_colocation(StrategyHost& host, int robot, const TpuafKnowledge& k, int here,
                          double now);
  int choose(int robot, const Eigen::VectorXd& utility);
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
  // per robot: vertex -> (failures in a row, the last one's time [s])
  std::vector<std::unordered_map<int, std::pair<int, double>>> failed_;
};

}  // namespace tpuaf
