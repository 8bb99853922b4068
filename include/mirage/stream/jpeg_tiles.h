#pragma once
// JPEG tile atlas codec (docs/stream.md, "The browser client"): the atlas payload a browser decodes without WebCodecs.
// The atlas is cut into 32x32 tiles; a frame carries only the tiles whose RGB changed since the
// encoder's previous frame (a keyframe carries all). Changed tiles, wherever they lie, are packed
// side by side into strips of up to maxStripTiles tiles, each strip one baseline JPEG
// (stb_image_write): every JPEG repeats ~620 bytes of tables, so one JPEG per tile would cost
// 4-5x the bytes (measured in docs/stream.md, "The browser client"). A browser decodes a strip with createImageBitmap
// and copies each tile out of it with texSubImage2D. Alpha is not carried (like H.264; the server stacks it below the
// colour when needed).
//
// Payload, little-endian:
//   header (24 bytes): magic "MJT1", uint32 width, uint32 height, uint32 frame, uint32 baseFrame,
//                      uint32 stripCount. baseFrame == frame: a keyframe (every tile present);
//                      else the strips replace tiles of frame baseFrame's image.
//   per strip: uint16 tileCount (>= 1), uint16 reserved (0), uint32 jpegBytes, tileCount x uint32
//              tile index (row-major; strictly increasing over the whole payload), the JPEG:
//              tileCount * 32 wide, 32 high, tile k at x = 32 k. A tile clipped by the atlas edge
//              fills its top-left part (the rest repeats its edge texels).
#include <array>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "mirage/core/result.h"

namespace mirage::stream {

inline constexpr std::array<uint8_t, 4> kJpegTilesMagic = {'M', 'J', 'T', '1'};
inline constexpr uint32_t kJpegTileSide = 32;
inline constexpr size_t kJpegTilesHeaderBytes = 24;
inline constexpr size_t kJpegStripHeaderBytes = 8; // before the tile indices

struct JpegTileOptions {
  int quality = 90; // stb_image_write JPEG quality 1..100
  // stb_image_write halves chroma (4:2:0) at quality <= 90 and keeps it whole above. A decoder's
  // chroma upsampling blends across the border of two tiles packed side by side in a strip, which
  // are unrelated unless neighbours in the atlas; so by default chroma stays whole (the quality
  // handed to stb is raised to 91 when it is lower). true: 4:2:0, stb's quality capped at 90 (fewer
  // bytes; texels at tile edges take colour from the tile packed next to them).
  bool subsampleChroma = false;
  // Tiles per strip JPEG; 1 sends every tile as its own JPEG. Larger strips amortize the JPEG tables
  // further but make one createImageBitmap call (and its latency) longer.
  uint32_t maxStripTiles = 16;
};

// Tiles of a `width` x `height` atlas: columns, rows.
inline uint32_t jpegTileColumns(uint32_t width) { return (width + kJpegTileSide - 1) / kJpegTileSide; }
inline uint32_t jpegTileRows(uint32_t height) { return (height + kJpegTileSide - 1) / kJpegTileSide; }

class JpegTileEncoder {
public:
  JpegTileEncoder(uint32_t width, uint32_t height, JpegTileOptions options = {});

  // `rgba`: width * height RGBA8 texels, row-major, top row first. The first frame and a frame
  // after requestKeyframe() is a keyframe; otherwise only the tiles whose RGB differs from the
  // previous call's are sent (an unchanged atlas costs the 24-byte header). Wrong size: an error.
  Result<std::vector<uint8_t>> encode(std::span<const uint8_t> rgba);
  // The next encode sends every tile (a client joined or lost a frame).
  void requestKeyframe() { keyframe_ = true; }
  // Frames encoded so far (the next frame's number).
  uint32_t frameCount() const { return frame_; }

private:
  int stbQuality() const;

  uint32_t width_, height_;
  JpegTileOptions options_;
  std::vector<uint8_t> previous_; // RGB of the last encoded frame
  uint32_t frame_ = 0;
  bool keyframe_ = true;
};

// What a payload holds, from its header alone (checked against the bytes that follow).
struct JpegTilesHeader {
  uint32_t width = 0, height = 0, frame = 0, baseFrame = 0, stripCount = 0;
  bool keyframe() const { return frame == baseFrame; }
};
// `source` names the payload in the error ("<source>: ...").
Result<JpegTilesHeader> readJpegTilesHeader(std::span<const uint8_t> payload, std::string_view source);

// The reference decoder (tests, tools; the browser has its own in web/atlas_codec.js).
class JpegTileDecoder {
public:
  JpegTileDecoder(uint32_t width, uint32_t height);

  // Applies one payload to the image. A delta whose baseFrame is not the last frame decoded, a size
  // other than the decoder's, or any malformed strip is an error naming `source`; the image is then
  // left as it was (strips are decoded before any is written).
  Status decode(std::span<const uint8_t> payload, std::string_view source);
  // RGBA8, alpha 255; black before the first keyframe.
  const std::vector<uint8_t>& rgba() const { return rgba_; }
  bool hasFrame() const { return hasFrame_; }
  uint32_t frame() const { return frame_; }

private:
  uint32_t width_, height_;
  std::vector<uint8_t> rgba_;
  uint32_t frame_ = 0;
  bool hasFrame_ = false;
};

} // namespace mirage::stream
