#include "mirage/stream/link_budget.h"

#include <algorithm>
#include <cmath>

namespace mirage::stream {

double LinkBudget::frameBytes() const { return double(config_.kbps) * 1000.0 / 8.0 / double(config_.fps); }

uint32_t LinkBudget::videoKbps() const {
  const double frame = frameBytes();
  const double floor = frame * double(config_.minVideoShare);
  double target = frame - otherAverage_ - debt_ / double(config_.repayFrames);
  target = std::clamp(target, floor, frame * double(config_.maxVideoShare));
  return uint32_t(std::max(1.0, std::floor(target * 8.0 * double(config_.fps) / 1000.0)));
}

void LinkBudget::account(uint64_t videoBytes, uint64_t otherBytes) {
  const double other = double(otherBytes);
  // A burst (the first frames' geometry, a camera cut) moves the average by a share only; the
  // debt pays for the rest.
  const double a = 1.0 / std::max(1.0, double(config_.averageFrames));
  otherAverage_ += a * (other - otherAverage_);
  const double credit = double(config_.creditFrames) * frameBytes();
  debt_ = std::max(-credit, debt_ + double(videoBytes) + other - frameBytes());
}

} // namespace mirage::stream
