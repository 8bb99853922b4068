// The simulated network's delays and losses (net_sim.h; docs/stream.md, "Simulated network").
#include "mirage/stream/net_sim.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

namespace mirage::stream {

namespace {

// splitmix64: tiny, and the same numbers on every platform and standard library (the standard
// distributions are not), which keeps a seed's run reproducible everywhere.
uint64_t nextRandom(uint64_t& state) {
  uint64_t z = (state += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

// Uniform in [0, 1), 53 bits.
double nextUniform(uint64_t& state) { return double(nextRandom(state) >> 11) * 0x1.0p-53; }

Error outOfRange(const char* what, double value, const char* unit, double hi) {
  std::ostringstream line;
  line << "network simulation: " << what << " " << value << unit << " not in [0, " << hi << "]";
  return Error{line.str()};
}

// Delays beyond an hour are a typing error, not a network.
constexpr double kMaxDelayMs = 3600.0 * 1000.0;

} // namespace

Status checkNetSimConfig(const NetSimConfig& config) {
  auto inRange = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  if (!inRange(config.roundTripMs, 0.0, kMaxDelayMs))
    return outOfRange("round trip", config.roundTripMs, " ms", kMaxDelayMs);
  if (!inRange(config.jitterMs, 0.0, kMaxDelayMs)) return outOfRange("jitter", config.jitterMs, " ms", kMaxDelayMs);
  if (!inRange(config.poseLoss, 0.0, 1.0)) return outOfRange("pose loss", config.poseLoss, "", 1.0);
  return Ok{};
}

double meanRoundTripMs(const NetSimConfig& config) { return config.roundTripMs + config.jitterMs; }

NetSim::NetSim(const NetSimConfig& config)
    : config_(config), jitterState_(config.seed), lossState_(config.seed ^ 0x6c6f73735f736565ull) {}

uint64_t NetSim::arrival(Direction& direction, uint64_t sendUs) {
  double delayMs = 0.5 * config_.roundTripMs + config_.jitterMs * nextUniform(jitterState_);
  uint64_t arrivalUs = sendUs + uint64_t(std::llround(delayMs * 1000.0));
  direction.lastArrivalUs = std::max(direction.lastArrivalUs, arrivalUs);
  return direction.lastArrivalUs;
}

bool NetSim::losePose() {
  bool first = std::exchange(firstPose_, false);
  double draw = nextUniform(lossState_); // drawn for the first pose too: pose k's draw is the same whatever came first
  return !first && draw < config_.poseLoss;
}

} // namespace mirage::stream
