// Lossless zstd tile-delta atlas codec (docs/stream.md, "Codecs").
#include "mirage/stream/tile_codec.h"

#include <algorithm>
#include <cstring>
#include <memory>
#include <string>

#include <zstd.h>

namespace mirage::stream {
namespace {

constexpr uint32_t kMagic = 0x3144544d; // "MTD1" little-endian

struct TileGrid {
  uint32_t width, height, columns, rows;
  explicit TileGrid(uint32_t w, uint32_t h)
      : width(w), height(h), columns((w + kAtlasTileSide - 1) / kAtlasTileSide),
        rows((h + kAtlasTileSide - 1) / kAtlasTileSide) {}
  uint32_t count() const { return columns * rows; }
  uint32_t x0(uint32_t tile) const { return tile % columns * kAtlasTileSide; }
  uint32_t y0(uint32_t tile) const { return tile / columns * kAtlasTileSide; }
  uint32_t tileWidth(uint32_t tile) const { return std::min(kAtlasTileSide, width - x0(tile)); }
  uint32_t tileHeight(uint32_t tile) const { return std::min(kAtlasTileSide, height - y0(tile)); }
  size_t rowOffset(uint32_t tile, uint32_t row) const { return (size_t(y0(tile) + row) * width + x0(tile)) * 4; }
};

void putU32(std::vector<uint8_t>& out, uint32_t value) {
  for (int shift = 0; shift < 32; shift += 8) out.push_back(uint8_t(value >> shift));
}

uint32_t getU32(const uint8_t* in) {
  return uint32_t(in[0]) | uint32_t(in[1]) << 8 | uint32_t(in[2]) << 16 | uint32_t(in[3]) << 24;
}

Error fail(const std::string& problem) { return Error{"atlas tile frame: " + problem}; }

bool tileChanged(const TileGrid& grid, uint32_t tile, const uint8_t* now, const uint8_t* before) {
  size_t rowBytes = size_t(grid.tileWidth(tile)) * 4;
  for (uint32_t row = 0; row < grid.tileHeight(tile); ++row) {
    size_t offset = grid.rowOffset(tile, row);
    if (std::memcmp(now + offset, before + offset, rowBytes) != 0) return true;
  }
  return false;
}

} // namespace

TileDeltaEncoder::TileDeltaEncoder(uint32_t width, uint32_t height, int zstdLevel)
    : width_(width), height_(height), level_(zstdLevel) {}

Result<std::vector<uint8_t>> TileDeltaEncoder::encode(std::span<const uint8_t> rgba) {
  if (width_ == 0 || height_ == 0 || width_ > kMaxTileCodecSide || height_ > kMaxTileCodecSide) {
    return fail("size " + std::to_string(width_) + "x" + std::to_string(height_) + " outside [1, " +
                std::to_string(kMaxTileCodecSide) + "]");
  }
  if (rgba.size() != size_t(width_) * height_ * 4) {
    return fail("image of " + std::to_string(rgba.size()) + " bytes, expected " + std::to_string(width_) + "x" +
                std::to_string(height_) + " RGBA8");
  }
  TileGrid grid(width_, height_);
  bool keyframe = keyframe_ || previous_.size() != rgba.size();
  std::vector<uint32_t> tiles;
  for (uint32_t tile = 0; tile < grid.count(); ++tile) {
    if (keyframe || tileChanged(grid, tile, rgba.data(), previous_.data())) tiles.push_back(tile);
  }
  std::vector<uint8_t> body;
  for (uint32_t tile : tiles) putU32(body, tile);
  for (uint32_t tile : tiles) {
    size_t rowBytes = size_t(grid.tileWidth(tile)) * 4;
    for (uint32_t row = 0; row < grid.tileHeight(tile); ++row) {
      const uint8_t* source = rgba.data() + grid.rowOffset(tile, row);
      body.insert(body.end(), source, source + rowBytes);
    }
  }
  std::vector<uint8_t> compressed;
  if (!body.empty()) {
    // The frame's content checksum lets the decoder reject corrupted bodies, not just malformed ones.
    std::unique_ptr<ZSTD_CCtx, size_t (*)(ZSTD_CCtx*)> context(ZSTD_createCCtx(), ZSTD_freeCCtx);
    if (!context) return fail("zstd: out of memory");
    ZSTD_CCtx_setParameter(context.get(), ZSTD_c_compressionLevel, level_);
    ZSTD_CCtx_setParameter(context.get(), ZSTD_c_checksumFlag, 1);
    compressed.resize(ZSTD_compressBound(body.size()));
    size_t written = ZSTD_compress2(context.get(), compressed.data(), compressed.size(), body.data(), body.size());
    if (ZSTD_isError(written)) return fail(std::string("zstd: ") + ZSTD_getErrorName(written));
    compressed.resize(written);
  }

  std::vector<uint8_t> out;
  out.reserve(kTileDeltaHeaderBytes + compressed.size());
  putU32(out, kMagic);
  putU32(out, width_);
  putU32(out, height_);
  putU32(out, frame_);
  putU32(out, keyframe ? kNoBaseFrame : frame_ - 1);
  putU32(out, uint32_t(tiles.size()));
  putU32(out, uint32_t(body.size()));
  putU32(out, uint32_t(compressed.size()));
  out.insert(out.end(), compressed.begin(), compressed.end());

  previous_.assign(rgba.begin(), rgba.end());
  keyframe_ = false;
  frame_++;
  return out;
}

Status TileDeltaDecoder::decode(std::span<const uint8_t> payload) {
  if (payload.size() < kTileDeltaHeaderBytes) {
    return fail("truncated: " + std::to_string(payload.size()) + " bytes, header needs " +
                std::to_string(kTileDeltaHeaderBytes));
  }
  const uint8_t* header = payload.data();
  if (getU32(header) != kMagic) return fail("bad magic");
  uint32_t width = getU32(header + 4), height = getU32(header + 8), frame = getU32(header + 12);
  uint32_t baseFrame = getU32(header + 16), tileCount = getU32(header + 20), rawSize = getU32(header + 24);
  uint32_t compressedSize = getU32(header + 28);
  if (width == 0 || height == 0 || width > kMaxTileCodecSide || height > kMaxTileCodecSide) {
    return fail("size " + std::to_string(width) + "x" + std::to_string(height) + " outside [1, " +
                std::to_string(kMaxTileCodecSide) + "]");
  }
  if (compressedSize != payload.size() - kTileDeltaHeaderBytes) {
    return fail("compressed size " + std::to_string(compressedSize) + " but " +
                std::to_string(payload.size() - kTileDeltaHeaderBytes) + " bytes follow the header");
  }
  TileGrid grid(width, height);
  bool keyframe = baseFrame == kNoBaseFrame;
  if (keyframe && tileCount != grid.count()) {
    return fail("keyframe with " + std::to_string(tileCount) + " of " + std::to_string(grid.count()) + " tiles");
  }
  if (!keyframe) {
    if (!hasFrame_ || baseFrame != frame_) {
      return fail("frame " + std::to_string(frame) + " is a delta against frame " + std::to_string(baseFrame) +
                  (hasFrame_ ? ", have frame " + std::to_string(frame_) : ", have none") + ": keyframe needed");
    }
    if (width != width_ || height != height_) return fail("delta frame changes the atlas size");
    if (tileCount > grid.count())
      return fail(std::to_string(tileCount) + " tiles, atlas has " + std::to_string(grid.count()));
  }
  uint64_t maxRaw = uint64_t(tileCount) * (4 + kAtlasTileSide * kAtlasTileSide * 4);
  if (rawSize < uint64_t(tileCount) * 4 || rawSize > maxRaw) return fail("body size does not match the tile count");
  if ((rawSize == 0) != (compressedSize == 0)) return fail("empty body mismatch");

  std::vector<uint8_t> body(rawSize);
  if (rawSize > 0) {
    const uint8_t* compressed = payload.data() + kTileDeltaHeaderBytes;
    unsigned long long content = ZSTD_getFrameContentSize(compressed, compressedSize);
    if (content != rawSize) return fail("corrupt zstd frame (content size)");
    size_t got = ZSTD_decompress(body.data(), body.size(), compressed, compressedSize);
    if (ZSTD_isError(got)) return fail(std::string("corrupt zstd data: ") + ZSTD_getErrorName(got));
    if (got != rawSize) return fail("zstd body shorter than announced");
  }

  // Validate every tile index and the body size before touching the image.
  uint64_t expected = uint64_t(tileCount) * 4;
  for (uint32_t i = 0; i < tileCount; ++i) {
    uint32_t tile = getU32(body.data() + 4 * size_t(i));
    if (tile >= grid.count() || (i > 0 && tile <= getU32(body.data() + 4 * size_t(i - 1)))) {
      return fail("tile index " + std::to_string(tile) + " out of order or outside the atlas");
    }
    expected += uint64_t(grid.tileWidth(tile)) * grid.tileHeight(tile) * 4;
  }
  if (expected != rawSize)
    return fail("body holds " + std::to_string(rawSize) + " bytes, tiles need " + std::to_string(expected));

  if (keyframe) {
    image_.assign(size_t(width) * height * 4, 0);
    width_ = width;
    height_ = height;
  }
  const uint8_t* pixels = body.data() + size_t(tileCount) * 4;
  for (uint32_t i = 0; i < tileCount; ++i) {
    uint32_t tile = getU32(body.data() + 4 * size_t(i));
    size_t rowBytes = size_t(grid.tileWidth(tile)) * 4;
    for (uint32_t row = 0; row < grid.tileHeight(tile); ++row) {
      std::memcpy(image_.data() + grid.rowOffset(tile, row), pixels, rowBytes);
      pixels += rowBytes;
    }
  }
  frame_ = frame;
  hasFrame_ = true;
  return Ok{};
}

} // namespace mirage::stream
