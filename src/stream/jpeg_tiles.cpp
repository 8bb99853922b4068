#include "mirage/stream/jpeg_tiles.h"

#include <algorithm>
#include <cstring>
#include <string>

// Static copies of stb: other Mirage libraries get stb's symbols through tinygltf, and two external
// definitions would clash at link time.
#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_JPEG
#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_IMPLEMENTATION
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wdouble-promotion"
#pragma GCC diagnostic ignored "-Wold-style-cast"
#pragma GCC diagnostic ignored "-Wcast-qual"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#if !defined(__clang__) // GCC's own groups: clang warns about groups it does not know
#pragma GCC diagnostic ignored "-Wuseless-cast"
#pragma GCC diagnostic ignored "-Wduplicated-branches"
#endif
#pragma GCC diagnostic ignored "-Wnull-dereference"
#endif
#include <stb/stb_image.h>
#include <stb/stb_image_write.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

namespace mirage::stream {

namespace {

void putU16(std::vector<uint8_t>& out, uint16_t v) {
  for (int i = 0; i < 2; ++i) out.push_back(uint8_t(v >> (8 * i)));
}
void putU32(std::vector<uint8_t>& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(uint8_t(v >> (8 * i)));
}
uint32_t getU32(const uint8_t* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}
uint16_t getU16(const uint8_t* p) { return uint16_t(p[0] | p[1] << 8); }

// Texel rectangle of a run of `tiles` tiles starting at tile (column, row), clipped at the atlas edge.
struct Rect {
  uint32_t x, y, width, height;
};
Rect stripRect(uint32_t column, uint32_t row, uint32_t tiles, uint32_t width, uint32_t height) {
  uint32_t x = column * kJpegTileSide, y = row * kJpegTileSide;
  return {x, y, std::min(tiles * kJpegTileSide, width - x), std::min(kJpegTileSide, height - y)};
}

bool tileChanged(std::span<const uint8_t> rgba, const std::vector<uint8_t>& previousRgb, Rect tile, uint32_t width) {
  for (uint32_t y = tile.y; y < tile.y + tile.height; ++y)
    for (uint32_t x = tile.x; x < tile.x + tile.width; ++x) {
      const uint8_t* now = &rgba[(size_t(y) * width + x) * 4];
      const uint8_t* before = &previousRgb[(size_t(y) * width + x) * 3];
      if (now[0] != before[0] || now[1] != before[1] || now[2] != before[2]) return true;
    }
  return false;
}

void appendBytes(void* context, void* data, int size) {
  auto* out = static_cast<std::vector<uint8_t>*>(context);
  auto* bytes = static_cast<const uint8_t*>(data);
  out->insert(out->end(), bytes, bytes + size);
}

} // namespace

JpegTileEncoder::JpegTileEncoder(uint32_t width, uint32_t height, JpegTileOptions options)
    : width_(width), height_(height), options_(options), previous_(size_t(width) * height * 3, 0) {
  options_.quality = std::clamp(options_.quality, 1, 100);
  options_.maxStripTiles = std::clamp<uint32_t>(options_.maxStripTiles, 1, 0xffff);
}

int JpegTileEncoder::stbQuality() const {
  return options_.subsampleChroma ? std::min(options_.quality, 90) : std::max(options_.quality, 91);
}

Result<std::vector<uint8_t>> JpegTileEncoder::encode(std::span<const uint8_t> rgba) {
  if (rgba.size() != size_t(width_) * height_ * 4)
    return makeError("jpeg tiles", "image of " + std::to_string(rgba.size()) + " bytes, expected " +
                                       std::to_string(size_t(width_) * height_ * 4) + " (" + std::to_string(width_) +
                                       "x" + std::to_string(height_) + " RGBA8)");
  bool keyframe = keyframe_;
  uint32_t columns = jpegTileColumns(width_), rows = jpegTileRows(height_);
  std::vector<uint8_t> changed(size_t(columns) * rows, keyframe ? 1 : 0);
  if (!keyframe)
    for (uint32_t row = 0; row < rows; ++row)
      for (uint32_t column = 0; column < columns; ++column)
        changed[size_t(row) * columns + column] =
            tileChanged(rgba, previous_, stripRect(column, row, 1, width_, height_), width_) ? 1 : 0;

  std::vector<uint8_t> out(kJpegTilesMagic.begin(), kJpegTilesMagic.end());
  putU32(out, width_);
  putU32(out, height_);
  putU32(out, frame_);
  putU32(out, keyframe ? frame_ : frame_ - 1);
  size_t stripCountAt = out.size();
  putU32(out, 0);

  std::vector<uint32_t> tiles;
  for (uint32_t t = 0; t < changed.size(); ++t)
    if (changed[t]) tiles.push_back(t);
  uint32_t strips = 0;
  std::vector<uint8_t> rgb;
  for (size_t first = 0; first < tiles.size(); first += options_.maxStripTiles) {
    uint32_t count = uint32_t(std::min<size_t>(options_.maxStripTiles, tiles.size() - first));
    uint32_t stripWidth = count * kJpegTileSide;
    rgb.resize(size_t(stripWidth) * kJpegTileSide * 3);
    for (uint32_t k = 0; k < count; ++k) {
      uint32_t tile = tiles[first + k];
      Rect rect = stripRect(tile % columns, tile / columns, 1, width_, height_);
      // Clipped tiles repeat their edge texels: no hard edge for the DCT to ring on.
      for (uint32_t y = 0; y < kJpegTileSide; ++y)
        for (uint32_t x = 0; x < kJpegTileSide; ++x) {
          uint32_t sx = rect.x + std::min(x, rect.width - 1), sy = rect.y + std::min(y, rect.height - 1);
          std::memcpy(&rgb[(size_t(y) * stripWidth + k * kJpegTileSide + x) * 3], &rgba[(size_t(sy) * width_ + sx) * 4],
                      3);
        }
    }
    putU16(out, uint16_t(count));
    putU16(out, 0);
    size_t lengthAt = out.size();
    putU32(out, 0);
    for (uint32_t k = 0; k < count; ++k) putU32(out, tiles[first + k]);
    size_t jpegStart = out.size();
    if (!stbi_write_jpg_to_func(appendBytes, &out, int(stripWidth), int(kJpegTileSide), 3, rgb.data(), stbQuality()))
      return makeError("jpeg tiles", "stb_image_write failed on a strip of " + std::to_string(count) + " tiles");
    uint32_t jpegBytes = uint32_t(out.size() - jpegStart);
    for (int i = 0; i < 4; ++i) out[lengthAt + size_t(i)] = uint8_t(jpegBytes >> (8 * i));
    ++strips;
  }
  for (int i = 0; i < 4; ++i) out[stripCountAt + size_t(i)] = uint8_t(strips >> (8 * i));

  for (size_t i = 0, n = size_t(width_) * height_; i < n; ++i) std::memcpy(&previous_[i * 3], &rgba[i * 4], 3);
  keyframe_ = false;
  ++frame_;
  return out;
}

Result<JpegTilesHeader> readJpegTilesHeader(std::span<const uint8_t> payload, std::string_view source) {
  std::string name(source);
  if (payload.size() < kJpegTilesHeaderBytes)
    return makeError(name, "JPEG tiles payload of " + std::to_string(payload.size()) +
                               " bytes, shorter than the 24-byte header");
  if (std::memcmp(payload.data(), kJpegTilesMagic.data(), 4) != 0)
    return makeError(name, "not a JPEG tiles payload (magic is not 'MJT1')");
  const uint8_t* p = payload.data();
  JpegTilesHeader h{getU32(p + 4), getU32(p + 8), getU32(p + 12), getU32(p + 16), getU32(p + 20)};
  if (h.width == 0 || h.height == 0 || h.width > 16384 || h.height > 16384)
    return makeError(name, "JPEG tiles size " + std::to_string(h.width) + "x" + std::to_string(h.height) +
                               " not in 1..16384");
  uint64_t tiles = uint64_t(jpegTileColumns(h.width)) * jpegTileRows(h.height);
  if (h.stripCount > tiles)
    return makeError(name, "JPEG tiles strip count " + std::to_string(h.stripCount) + " over the " +
                               std::to_string(tiles) + " tiles of the atlas");
  if (uint64_t(h.stripCount) * (kJpegStripHeaderBytes + 4) > payload.size() - kJpegTilesHeaderBytes)
    return makeError(name, "JPEG tiles strip count " + std::to_string(h.stripCount) + " needs more than the " +
                               std::to_string(payload.size() - kJpegTilesHeaderBytes) + " bytes left");
  return h;
}

JpegTileDecoder::JpegTileDecoder(uint32_t width, uint32_t height)
    : width_(width), height_(height), rgba_(size_t(width) * height * 4, 0) {
  for (size_t i = 3; i < rgba_.size(); i += 4) rgba_[i] = 255;
}

namespace {

// Whether every Huffman table (DHT segment) of a JPEG stream declares at most 256 codes. Debian's
// stb_image writes past its 257-entry size list for a table that declares more (undefined
// behaviour found by the sanitized corrupt-payload test), so such streams never reach it. Walks
// every marker segment, the entropy-coded data after each SOS included (a DHT may follow a scan).
bool jpegHuffmanTablesFit(const uint8_t* data, size_t size) {
  size_t pos = 2; // after SOI
  while (pos + 4 <= size) {
    if (data[pos] != 0xFF) return false;
    uint8_t marker = data[pos + 1];
    if (marker == 0xFF) { // fill byte
      ++pos;
      continue;
    }
    if (marker == 0xD9) return true;                            // EOI
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) { // no length
      pos += 2;
      continue;
    }
    size_t length = size_t(data[pos + 2]) << 8 | data[pos + 3];
    if (length < 2 || pos + 2 + length > size) return false;
    if (marker == 0xC4) {
      size_t q = pos + 4, end = pos + 2 + length;
      while (q < end) {
        if (q + 17 > end) return false;
        size_t codes = 0;
        for (size_t i = 1; i <= 16; ++i) codes += data[q + i];
        if (codes > 256 || q + 17 + codes > end) return false;
        q += 17 + codes;
      }
    }
    pos += 2 + length;
    if (marker == 0xDA) // entropy-coded data: up to the next marker that is not a stuffed 0 or RSTn
      while (pos + 1 < size &&
             !(data[pos] == 0xFF && data[pos + 1] != 0x00 && !(data[pos + 1] >= 0xD0 && data[pos + 1] <= 0xD7)))
        ++pos;
  }
  return true; // what is left is too short to hold a table: stb reports the truncation
}

} // namespace

Status JpegTileDecoder::decode(std::span<const uint8_t> payload, std::string_view source) {
  std::string name(source);
  Result<JpegTilesHeader> header = readJpegTilesHeader(payload, source);
  if (!header) return header.error();
  const JpegTilesHeader& h = *header;
  if (h.width != width_ || h.height != height_)
    return makeError(name, "JPEG tiles of " + std::to_string(h.width) + "x" + std::to_string(h.height) +
                               " for an atlas of " + std::to_string(width_) + "x" + std::to_string(height_));
  if (!h.keyframe() && (!hasFrame_ || h.baseFrame != frame_))
    return makeError(name, "JPEG tiles frame " + std::to_string(h.frame) + " is a delta on frame " +
                               std::to_string(h.baseFrame) + " but the last frame decoded is " +
                               (hasFrame_ ? std::to_string(frame_) : std::string("none")));

  struct Strip {
    std::vector<uint32_t> tiles;
    std::vector<uint8_t> rgb; // tiles.size() * 32 wide, 32 high
  };
  std::vector<Strip> strips;
  uint64_t tileCount = uint64_t(jpegTileColumns(width_)) * jpegTileRows(height_);
  int64_t lastTile = -1;
  size_t pos = kJpegTilesHeaderBytes;
  for (uint32_t s = 0; s < h.stripCount; ++s) {
    std::string field = "strip " + std::to_string(s);
    if (payload.size() - pos < kJpegStripHeaderBytes) return makeError(name, field + ": truncated header");
    uint16_t count = getU16(&payload[pos]), reserved = getU16(&payload[pos + 2]);
    uint32_t bytes = getU32(&payload[pos + 4]);
    pos += kJpegStripHeaderBytes;
    if (count == 0 || count > tileCount)
      return makeError(name, field + ": " + std::to_string(count) + " tiles, not in 1.." + std::to_string(tileCount));
    if (reserved != 0) return makeError(name, field + ": reserved field " + std::to_string(reserved) + " not 0");
    if (uint64_t(count) * 4 > payload.size() - pos) return makeError(name, field + ": truncated tile list");
    Strip strip;
    for (uint32_t k = 0; k < count; ++k, pos += 4) {
      uint32_t tile = getU32(&payload[pos]);
      if (tile >= tileCount || int64_t(tile) <= lastTile)
        return makeError(name, field + ": tile " + std::to_string(tile) + " outside the " + std::to_string(tileCount) +
                                   " tiles or not after tile " + std::to_string(lastTile));
      lastTile = tile;
      strip.tiles.push_back(tile);
    }
    if (bytes > payload.size() - pos)
      return makeError(name, field + ": JPEG of " + std::to_string(bytes) + " bytes, " +
                                 std::to_string(payload.size() - pos) + " left");
    uint32_t stripWidth = count * kJpegTileSide;
    int w = 0, hh = 0, channels = 0;
    const auto* jpeg = reinterpret_cast<const stbi_uc*>(&payload[pos]);
    if (!jpegHuffmanTablesFit(&payload[pos], bytes))
      return makeError(name, field + ": JPEG with a Huffman table of more than 256 codes");
    // Size check before decoding: a hostile header must not make stb allocate a huge image.
    if (!stbi_info_from_memory(jpeg, int(bytes), &w, &hh, &channels) || uint32_t(w) != stripWidth ||
        uint32_t(hh) != kJpegTileSide)
      return makeError(name, field + ": not a " + std::to_string(stripWidth) + "x32 JPEG");
    stbi_uc* pixels = stbi_load_from_memory(jpeg, int(bytes), &w, &hh, &channels, 3);
    if (!pixels) return makeError(name, field + ": JPEG does not decode (" + stbi_failure_reason() + ")");
    strip.rgb.assign(pixels, pixels + size_t(w) * size_t(hh) * 3);
    stbi_image_free(pixels);
    strips.push_back(std::move(strip));
    pos += bytes;
  }
  if (pos != payload.size())
    return makeError(name, std::to_string(payload.size() - pos) + " bytes after the last JPEG tiles strip");

  uint32_t columns = jpegTileColumns(width_);
  for (const Strip& strip : strips) {
    uint32_t stripWidth = uint32_t(strip.tiles.size()) * kJpegTileSide;
    for (size_t k = 0; k < strip.tiles.size(); ++k) {
      Rect rect = stripRect(strip.tiles[k] % columns, strip.tiles[k] / columns, 1, width_, height_);
      for (uint32_t y = 0; y < rect.height; ++y)
        for (uint32_t x = 0; x < rect.width; ++x) {
          uint8_t* texel = &rgba_[(size_t(rect.y + y) * width_ + rect.x + x) * 4];
          std::memcpy(texel, &strip.rgb[(size_t(y) * stripWidth + k * kJpegTileSide + x) * 3], 3);
          texel[3] = 255;
        }
    }
  }
  frame_ = h.frame;
  hasFrame_ = true;
  return Ok{};
}

} // namespace mirage::stream
