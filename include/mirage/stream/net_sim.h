#pragma once
// A simulated network between the stream client and its server (docs/stream.md, "Simulated
// network"): message-level, on a virtual clock in microseconds, deterministic for a seed. Each
// direction delays a message by half the round trip plus a uniform jitter and keeps messages in
// order (the stream travels on TCP, where a late segment holds back the ones behind it). Poses may
// be lost (the server answers the next one); frames never are (their geometry deltas are stateful,
// and TCP turns a lost segment into delay).
#include <cstdint>
#include <deque>
#include <optional>
#include <utility>

#include "mirage/core/result.h"

namespace mirage::stream {

struct NetSimConfig {
  double roundTripMs = 0; // base round trip: half of it each way
  double jitterMs = 0;    // per message and direction: + uniform in [0, jitterMs)
  double poseLoss = 0;    // probability that a pose is lost, in [0, 1]; the session's first pose never is
  uint64_t seed = 1;      // same seed, same delays and losses
};

// One line naming the field that is not a finite value in range.
Status checkNetSimConfig(const NetSimConfig& config);

// The mean round trip of `config`: the base plus the mean jitter of both directions.
double meanRoundTripMs(const NetSimConfig& config);

class NetSim {
public:
  explicit NetSim(const NetSimConfig& config);

  // When a message sent at `sendUs` reaches the other side: sendUs + half the round trip + jitter,
  // and never before the previous message of that direction.
  uint64_t uplinkArrival(uint64_t sendUs) { return arrival(uplink_, sendUs); }
  uint64_t downlinkArrival(uint64_t sendUs) { return arrival(downlink_, sendUs); }
  // Draws whether the next pose is lost. The first pose is delivered: it starts the session, and a
  // client that never got a frame would have nothing to draw. Losses and jitter draw from separate
  // streams, so a different jitter keeps the same poses lost.
  bool losePose();

private:
  struct Direction {
    uint64_t lastArrivalUs = 0;
  };
  uint64_t arrival(Direction& direction, uint64_t sendUs);

  NetSimConfig config_;
  uint64_t jitterState_ = 0, lossState_ = 0;
  Direction uplink_, downlink_;
  bool firstPose_ = true;
};

// Messages of one direction held until their arrival time. Arrival times pushed never decrease
// (NetSim's arrivals keep order), so the oldest message is the next to arrive.
template <class T> class DelayLine {
public:
  void push(uint64_t arrivalUs, T message) { queue_.emplace_back(arrivalUs, std::move(message)); }
  // The oldest message, once it has arrived by `nowUs`.
  std::optional<T> popArrived(uint64_t nowUs) {
    if (queue_.empty() || queue_.front().first > nowUs) return std::nullopt;
    T message = std::move(queue_.front().second);
    queue_.pop_front();
    return message;
  }
  size_t size() const { return queue_.size(); }

private:
  std::deque<std::pair<uint64_t, T>> queue_;
};

} // namespace mirage::stream
