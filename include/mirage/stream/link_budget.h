#pragma once
// One bitrate for everything a client's frames carry (docs/stream.md, "Link budget"). The atlas
// video is the only section whose size can be chosen: the patch and particle sections are what the
// view needs. So the video gets what the others leave: the link's bytes per frame less an estimate
// of the other sections (a moving average) less a share of the bytes sent over the budget so far
// (the first frames' geometry burst, a camera cut), never below a floor that keeps the atlas
// readable. Bytes left unspent (x264 spends about three quarters of its target on an atlas that
// changes little) are a credit, up to a link buffer's worth, that raises the next targets: the link
// is used, not just respected. The bytes sent over any prefix of a path exceed the link's by the
// debt not yet repaid, never by a credit (it is earned before it is spent).
#include <cstdint>

namespace mirage::stream {

struct LinkBudgetConfig {
  uint32_t kbps = 20000;       // the link: every section of every frame, in kbit/s
  uint32_t fps = 60;           // frames per second the budget is spread over
  float minVideoShare = 0.25f; // the video's target never goes below this share of the link
  float averageFrames = 8.0f;  // the other sections' moving average spans about this many frames
  float repayFrames = 16.0f;   // a debt is repaid (a credit spent) over about this many frames
  float creditFrames = 15.0f;  // bytes left unspent are kept up to this many frames of the link
  float maxVideoShare = 2.0f;  // the video's target never goes above this share of the link
};

class LinkBudget {
public:
  explicit LinkBudget(const LinkBudgetConfig& config) : config_(config) {}
  // The next frame's video target, in kbit/s (the encoder's bitrate: VideoEncoder::setBitrate).
  uint32_t videoKbps() const;
  // A frame went out with these bytes: the video, and the other sections (patches, particles).
  void account(uint64_t videoBytes, uint64_t otherBytes);
  double frameBytes() const;                 // the link's bytes per frame
  double debtBytes() const { return debt_; } // < 0: a credit

private:
  LinkBudgetConfig config_;
  double otherAverage_ = 0.0; // moving average of the other sections' bytes per frame
  double debt_ = 0.0;         // bytes sent over the budget and not repaid; negative: unspent, up to the credit
};

} // namespace mirage::stream
