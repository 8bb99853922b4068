// The simulated network's delays, order, losses and determinism (net_sim.h), without a server.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "mirage/stream/net_sim.h"

namespace mirage {
namespace {

using stream::NetSim;
using stream::NetSimConfig;

// Arrivals of `count` messages sent every `stepUs` on one direction.
std::vector<uint64_t> uplinkArrivals(NetSim& net, int count, uint64_t stepUs) {
  std::vector<uint64_t> arrivals;
  for (int i = 0; i < count; ++i) arrivals.push_back(net.uplinkArrival(uint64_t(i) * stepUs));
  return arrivals;
}

TEST(NetSim, WithoutDelayMessagesArriveWhenSent) {
  NetSim net(NetSimConfig{});
  for (uint64_t t : {0ull, 16666ull, 33333ull}) {
    EXPECT_EQ(net.uplinkArrival(t), t);
    EXPECT_EQ(net.downlinkArrival(t), t);
  }
}

TEST(NetSim, EachDirectionTakesHalfTheRoundTripPlusJitterAndKeepsOrder) {
  NetSimConfig config;
  config.roundTripMs = 50;
  config.jitterMs = 30;
  config.seed = 3;
  NetSim net(config);
  // Messages sent 1 ms apart with up to 30 ms jitter: many would overtake each other without the
  // order rule, which then holds them back to the arrival of the one before.
  uint64_t previous = 0, longest = 0;
  int heldBack = 0;
  for (int i = 0; i < 2000; ++i) {
    uint64_t sent = uint64_t(i) * 1000;
    uint64_t arrival = net.downlinkArrival(sent);
    EXPECT_GE(arrival, sent + 25000) << "message " << i;
    EXPECT_LE(arrival, sent + 25000 + 30000) << "message " << i;
    EXPECT_GE(arrival, previous) << "message " << i << " overtook the one before it";
    heldBack += arrival == previous;
    longest = std::max(longest, arrival - sent);
    previous = arrival;
  }
  EXPECT_GT(heldBack, 100);
  EXPECT_GT(longest, 25000u + 25000u) << "jitter never drew near its bound";
}

TEST(NetSim, JitterSpreadsUniformlyOverItsRange) {
  NetSimConfig config;
  config.jitterMs = 20;
  config.seed = 11;
  NetSim net(config);
  // Messages 1 s apart never hold each other back: each delay is the jitter alone.
  double sum = 0, lowest = 1e9, highest = 0;
  const int count = 4000;
  for (int i = 0; i < count; ++i) {
    uint64_t sent = uint64_t(i) * 1000000;
    double delayMs = double(net.uplinkArrival(sent) - sent) / 1000.0;
    sum += delayMs;
    lowest = std::min(lowest, delayMs);
    highest = std::max(highest, delayMs);
  }
  EXPECT_NEAR(sum / count, 10.0, 0.5);
  EXPECT_GE(lowest, 0.0);
  EXPECT_LT(lowest, 0.5);
  EXPECT_LE(highest, 20.0);
  EXPECT_GT(highest, 19.5);
  EXPECT_DOUBLE_EQ(stream::meanRoundTripMs(config), 20.0);
}

TEST(NetSim, LossRateMatchesItsProbabilityAndSparesTheFirstPose) {
  for (double p : {0.0, 0.25, 1.0}) {
    NetSimConfig config;
    config.poseLoss = p;
    config.seed = 5;
    NetSim net(config);
    EXPECT_FALSE(net.losePose()) << "the first pose starts the session";
    int lost = 0;
    const int count = 8000;
    for (int i = 0; i < count; ++i) lost += net.losePose();
    EXPECT_NEAR(double(lost) / count, p, 0.02) << "loss " << p;
  }
}

TEST(NetSim, SameSeedSameRunAnotherSeedAnother) {
  NetSimConfig config;
  config.roundTripMs = 40;
  config.jitterMs = 25;
  config.poseLoss = 0.5;
  config.seed = 42;
  auto run = [](const NetSimConfig& c) {
    NetSim net(c);
    std::vector<uint64_t> trace = uplinkArrivals(net, 64, 1000);
    for (int i = 0; i < 64; ++i) trace.push_back(net.losePose());
    return trace;
  };
  EXPECT_EQ(run(config), run(config));
  NetSimConfig other = config;
  other.seed = 43;
  EXPECT_NE(run(config), run(other));
}

TEST(NetSim, JitterDoesNotChangeWhichPosesAreLost) {
  NetSimConfig calm;
  calm.poseLoss = 0.4;
  calm.seed = 9;
  NetSimConfig jittery = calm;
  jittery.jitterMs = 30;
  NetSim a(calm), b(jittery);
  for (int i = 0; i < 200; ++i) {
    a.uplinkArrival(uint64_t(i) * 1000);
    b.uplinkArrival(uint64_t(i) * 1000);
    EXPECT_EQ(a.losePose(), b.losePose()) << "pose " << i;
  }
}

TEST(NetSim, ConfigurationOutOfRangeIsOneLineNamingTheField) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  struct Case {
    NetSimConfig config;
    const char* field;
  };
  std::vector<Case> cases = {
      {{.roundTripMs = -1}, "round trip"}, {{.roundTripMs = nan}, "round trip"}, {{.jitterMs = -0.5}, "jitter"},
      {{.jitterMs = 1e12}, "jitter"},      {{.poseLoss = 1.5}, "pose loss"},     {{.poseLoss = nan}, "pose loss"},
  };
  for (const Case& c : cases) {
    Status s = stream::checkNetSimConfig(c.config);
    ASSERT_FALSE(s) << c.field;
    EXPECT_NE(s.error().message.find(c.field), std::string::npos) << s.error().message;
    EXPECT_EQ(s.error().message.find('\n'), std::string::npos) << s.error().message;
  }
  EXPECT_TRUE(stream::checkNetSimConfig({.roundTripMs = 50, .jitterMs = 10, .poseLoss = 1.0}));
}

TEST(NetSimDelayLine, HoldsMessagesUntilTheyArrive) {
  stream::DelayLine<int> line;
  line.push(100, 1);
  line.push(100, 2);
  line.push(250, 3);
  EXPECT_FALSE(line.popArrived(99));
  EXPECT_EQ(line.popArrived(100), 1);
  EXPECT_EQ(line.popArrived(100), 2);
  EXPECT_FALSE(line.popArrived(200));
  EXPECT_EQ(line.size(), 1u);
  EXPECT_EQ(line.popArrived(1000), 3);
  EXPECT_EQ(line.size(), 0u);
}

} // namespace
} // namespace mirage
