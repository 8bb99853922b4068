#pragma once
// H.264 atlas codec (docs/stream.md, "Codecs") through libavcodec: libx264 encodes, FFmpeg's
// h264 decodes. The encoder takes YUV 4:2:0 (full range, BT.709; the stream server converts on the
// GPU, shaderio/atlas_shading.h) or RGBA8, converted with libswscale (rgbaToI420); the decoder gives
// RGBA8. Low latency: tune zerolatency (no lookahead, slice threads instead of frame threads), no
// B-frames, one packet out per frame in, the VBV buffer a few frames deep, periodic IDR or intra
// refresh, and a forced IDR on request.
//
// Alpha is not carried: H.264 has no alpha plane, decoded frames come back with alpha 255. The
// stream server stacks an atlas's alpha below its colour when the scene needs it (stream/session.h).
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "mirage/core/result.h"

namespace mirage::stream {

struct VideoConfig {
  uint32_t width = 0;  // even, > 0
  uint32_t height = 0; // even, > 0
  uint32_t fps = 60;
  uint32_t bitrateKbps = 20000;     // average bitrate target (ABR, capped by the VBV below)
  uint32_t vbvFrames = 2;           // VBV buffer in frames of the target: a frame's size stays near bitrate / fps
  uint32_t keyframeInterval = 0;    // frames between IDRs; 0: 4 seconds (fps * 4)
  bool intraRefresh = false;        // a moving intra column instead of periodic IDRs (steadier frame sizes)
  std::string preset = "ultrafast"; // x264 preset: ultrafast or veryfast for live use
  // x264's threads, each encoding one slice of every frame (zerolatency: no frame threads, which
  // would hold frames back). 0: x264 picks (the processors, at most one per 4 macroblock rows).
  uint32_t threads = 0;
};

// One encoded frame: Annex B H.264 (start codes), what the decoder takes.
struct VideoPacket {
  std::vector<uint8_t> data;
  bool keyframe = false;
};

class VideoEncoder {
public:
  // Errors: a bad config (odd or zero size, zero fps or bitrate) or libx264 missing or refusing it.
  static Result<VideoEncoder> create(const VideoConfig& config);
  VideoEncoder(VideoEncoder&&) noexcept;
  VideoEncoder& operator=(VideoEncoder&&) noexcept;
  ~VideoEncoder();

  // Encodes one RGBA8 frame (width * height * 4 bytes; alpha ignored), converted as rgbaToI420
  // does; forceKeyframe makes it an IDR.
  Result<VideoPacket> encode(std::span<const uint8_t> rgba, bool forceKeyframe = false);
  // Encodes one frame given as I420: full-range BT.709 YUV 4:2:0 planes Y (width x height), U, V
  // (width/2 x height/2) back to back, width * height * 3 / 2 bytes (copied: the caller may reuse
  // them once this returns).
  Result<VideoPacket> encodeI420(std::span<const uint8_t> i420, bool forceKeyframe = false);
  // A new average bitrate target (and VBV cap) from the next frame on: libavcodec's libx264
  // reconfigures x264 when it sees the context's rates change, keeping the stream going (no IDR).
  // The stream server lowers it by what a frame's other sections take (stream/link_budget.h).
  void setBitrate(uint32_t kbps);
  const VideoConfig& config() const;

  struct State;

private:
  explicit VideoEncoder(std::unique_ptr<State> state);
  Result<VideoPacket> encodeFrame(bool forceKeyframe); // the frame the State holds

  std::unique_ptr<State> state_;
};

// The conversion encode() applies (libswscale: BT.709, full range, chroma the mean of each 2 x 2
// quad): width x height RGBA8 (alpha ignored; both even) -> I420 as encodeI420 takes it. Errors: a
// size that does not match or is odd.
Result<std::vector<uint8_t>> rgbaToI420(std::span<const uint8_t> rgba, uint32_t width, uint32_t height);

class VideoDecoder {
public:
  static Result<VideoDecoder> create();
  VideoDecoder(VideoDecoder&&) noexcept;
  VideoDecoder& operator=(VideoDecoder&&) noexcept;
  ~VideoDecoder();

  // Feeds one packet; true when a frame came out (then image() holds it, RGBA8, alpha 255), false
  // when the decoder needs more data (garbage without start codes is consumed this way). An error
  // for data the decoder rejects or an image larger than 16384 on a side.
  Result<bool> decode(std::span<const uint8_t> packet);
  const std::vector<uint8_t>& image() const;
  uint32_t width() const;
  uint32_t height() const;

  struct State;

private:
  explicit VideoDecoder(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

} // namespace mirage::stream
