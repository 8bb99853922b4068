#pragma once
// Lossless atlas codec (docs/stream.md, "Codecs"): the RGBA8 atlas split into 32 x 32 tiles;
// a frame carries only the tiles that changed since the frame before it (a keyframe carries all),
// zstd-compressed. Exact, so tests can compare atlases bit for bit; H.264 (video.h) is for real use.
//
// Payload: a 32-byte header, little-endian u32s
//   magic "MTD1", width, height, frame, baseFrame (kNoBaseFrame for a keyframe), tileCount,
//   rawSize (bytes of the body once decompressed), compressedSize
// then the zstd-compressed body (absent when rawSize is 0): tileCount ascending u32 tile indices
// (row-major, tilesX = ceil(width / 32)), then each tile's pixels row by row (edge tiles clipped
// to the image).
#include <cstdint>
#include <span>
#include <vector>

#include "mirage/core/result.h"

namespace mirage::stream {

constexpr uint32_t kAtlasTileSide = 32;
constexpr uint32_t kNoBaseFrame = 0xffffffffu;
constexpr size_t kTileDeltaHeaderBytes = 32;
constexpr uint32_t kMaxTileCodecSide = 16384;

class TileDeltaEncoder {
public:
  // width, height in [1, kMaxTileCodecSide] (checked by encode).
  TileDeltaEncoder(uint32_t width, uint32_t height, int zstdLevel = 3);

  // Encodes `rgba` (width * height * 4 bytes) against the previous frame encoded; the first frame,
  // and any after requestKeyframe(), is a keyframe. An error for a wrong-sized image.
  Result<std::vector<uint8_t>> encode(std::span<const uint8_t> rgba);
  // The next frame carries every tile (a client joined or lost a frame).
  void requestKeyframe() { keyframe_ = true; }
  uint32_t frame() const { return frame_; } // frames encoded so far

private:
  uint32_t width_, height_;
  int level_;
  bool keyframe_ = true;
  uint32_t frame_ = 0;
  std::vector<uint8_t> previous_;
};

class TileDeltaDecoder {
public:
  // Applies a payload: a keyframe (re)sizes the image; a delta must be against the last frame
  // applied. Errors (bad magic, sizes, tile indices, a missing base frame, truncated or corrupt
  // data) leave the image unchanged; after a missing base frame, ask for a keyframe.
  Status decode(std::span<const uint8_t> payload);

  const std::vector<uint8_t>& image() const { return image_; } // width * height * 4 bytes, RGBA8
  uint32_t width() const { return width_; }
  uint32_t height() const { return height_; }
  bool hasFrame() const { return hasFrame_; }
  uint32_t frame() const { return frame_; } // the last frame applied

private:
  std::vector<uint8_t> image_;
  uint32_t width_ = 0, height_ = 0;
  uint32_t frame_ = 0;
  bool hasFrame_ = false;
};

} // namespace mirage::stream
