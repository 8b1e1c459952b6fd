// The team bus (team_bus.hpp): numpy's loss draws, counters, dead robots, due order.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "tpuaf_core/team_bus.hpp"

namespace tpuaf {
namespace {

// numpy.random.default_rng([3, 1]).bit_generator.state; its random(9):
// 0.253 0.407 0.341 | 0.427 0.539 0.907 | 0.329 0.522 0.748
NumpyPcg64 numpy_3_1() {
  return NumpyPcg64(0x5965f3094fb76bc0ULL, 0xdb1c9d97f130a0d4ULL, 0xe7a1a505a2178266ULL,
                    0xb8a537f40efcf881ULL);
}

std::vector<int> recipients(const BusDelivery& d, int robots) {
  std::vector<int> out;
  d.for_each_recipient(robots, [&](int r) { out.push_back(r); });
  return out;
}

TEST(TeamBus, LosesAsNumpysDrawsOnePerRobotSenderIncluded) {
  TeamBus bus(3, 0.0, 0.4, numpy_3_1());
  EXPECT_TRUE(bus.send(0, 10, 0.0));  // 1 keeps (0.407), 2 loses (0.341)
  EXPECT_TRUE(bus.send(2, 11, 0.0));  // 0 and 1 keep; 2's draw (0.907) is the sender's
  EXPECT_TRUE(bus.send(1, 12, 0.0));  // 0 loses (0.329), 2 keeps (0.748)
  ASSERT_EQ(bus.ready().size(), 3u);
  const BusDelivery a = bus.pop_ready(), b = bus.pop_ready(), c = bus.pop_ready();
  EXPECT_EQ(a.message, 10);
  EXPECT_EQ(recipients(a, 3), std::vector<int>({1}));
  EXPECT_EQ(b.message, 11);
  EXPECT_EQ(recipients(b, 3), std::vector<int>({0, 1}));
  EXPECT_EQ(c.message, 12);
  EXPECT_EQ(recipients(c, 3), std::vector<int>({2}));
  EXPECT_EQ(bus.stats().sent, 3);
  EXPECT_EQ(bus.stats().lost, 2);
  EXPECT_EQ(bus.stats().delivered, 0);  // the runtime counts what it hands over
  bus.count_delivered(4);
  EXPECT_EQ(bus.stats().delivered, 4);
}

TEST(TeamBus, WithoutLossEveryLiveTeammateAndNoDraw) {
  TeamBus bus(4, 0.0, 0.0, numpy_3_1());
  ASSERT_TRUE(bus.send(1, 0, 0.0));
  const BusDelivery all = bus.pop_ready();
  EXPECT_TRUE(all.all_but_sender);
  EXPECT_EQ(recipients(all, 4), std::vector<int>({0, 2, 3}));
  bus.set_alive(3, false);
  ASSERT_TRUE(bus.send(1, 1, 0.0));
  EXPECT_EQ(recipients(bus.pop_ready(), 4), std::vector<int>({0, 2}));
  bus.set_alive(0, false);
  bus.set_alive(2, false);
  EXPECT_FALSE(bus.send(1, 2, 0.0));  // nobody alive to hear it: nothing kept
  EXPECT_TRUE(bus.ready().empty());
  EXPECT_EQ(bus.stats().sent, 3);
  EXPECT_EQ(bus.stats().lost, 0);
  TeamBus alone(1, 0.0, 0.0, numpy_3_1());
  EXPECT_FALSE(alone.send(0, 0, 0.0));
}

TEST(TeamBus, ADeadRobotDrawsButIsNotCountedLost) {
  TeamBus bus(3, 0.0, 0.4, numpy_3_1());
  bus.set_alive(2, false);
  EXPECT_TRUE(bus.send(0, 0, 0.0));  // 2's draw (0.341, lost) is made but not counted
  EXPECT_EQ(recipients(bus.pop_ready(), 3), std::vector<int>({1}));
  EXPECT_EQ(bus.stats().lost, 0);
  EXPECT_TRUE(bus.send(2, 1, 0.0));  // the next three draws: 0 and 1 keep
  EXPECT_EQ(recipients(bus.pop_ready(), 3), std::vector<int>({0, 1}));
}

TEST(TeamBus, ReleasesInDueOrderThenSendOrder) {
  TeamBus bus(2, 2.0, 0.0, numpy_3_1());
  EXPECT_EQ(bus.next_due_s(), INFINITY);
  bus.send(0, 0, 1.0);
  bus.send(1, 1, 1.0);
  bus.send(0, 2, 0.5);  // the clock went back: due before the others
  EXPECT_EQ(bus.in_flight(), 3u);
  EXPECT_TRUE(bus.ready().empty());
  EXPECT_EQ(bus.next_due_s(), 2.5);
  bus.release_due(2.9);
  EXPECT_EQ(bus.ready().size(), 1u);
  bus.release_due(3.0 - 1e-10);  // within the slack
  ASSERT_EQ(bus.ready().size(), 3u);
  EXPECT_EQ(bus.pop_ready().message, 2);
  EXPECT_EQ(bus.pop_ready().message, 0);
  EXPECT_EQ(bus.pop_ready().message, 1);
  EXPECT_EQ(bus.in_flight(), 0u);
  EXPECT_THROW(bus.release_next(), std::logic_error);
  EXPECT_THROW(bus.pop_ready(), std::logic_error);
}

TEST(TeamBus, RejectsBadSettings) {
  EXPECT_THROW(TeamBus(0, 0.0, 0.0, numpy_3_1()), std::invalid_argument);
  EXPECT_THROW(TeamBus(2, -1.0, 0.0, numpy_3_1()), std::invalid_argument);
  EXPECT_THROW(TeamBus(2, NAN, 0.0, numpy_3_1()), std::invalid_argument);
  EXPECT_THROW(TeamBus(2, INFINITY, 0.0, numpy_3_1()), std::invalid_argument);
  EXPECT_THROW(TeamBus(2, 0.0, 1.5, numpy_3_1()), std::invalid_argument);
  TeamBus bus(2, 0.0, 0.0, numpy_3_1());
  EXPECT_THROW(bus.send(2, 0, 0.0), std::out_of_range);
  EXPECT_THROW(bus.set_alive(-1, false), std::out_of_range);
}

}  // namespace
}  // namespace tpuaf
