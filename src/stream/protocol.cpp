// Encoding and decoding of the stream messages (docs/stream.md, "Protocol"). The decoder reads
// through a bounds-checked cursor: every read says what it needs before it touches a byte, and every
// count is checked against the limits and against the bytes left (count x smallest entry) before
// a vector is sized, so a forged count cannot allocate more than the message itself holds.
#include "mirage/stream/protocol.h"

#include <bit>
#include <cmath>
#include <cstring>
#include <numbers>

#include "mirage/core/input_text.h"
#include "mirage/shaderio/atlas.h"

namespace mirage::stream {

std::string messageTypeName(MessageType type) {
  switch (type) {
  case MessageType::Hello:
    return "Hello";
  case MessageType::Welcome:
    return "Welcome";
  case MessageType::Pose:
    return "Pose";
  case MessageType::Frame:
    return "Frame";
  case MessageType::Close:
    return "Close";
  }
  return "type " + std::to_string(uint16_t(type));
}

MessageType messageType(const Message& message) { return MessageType(uint16_t(message.index() + 1)); }

namespace {

static_assert(std::variant_size_v<Message> == 5, "MessageType values are the variant index + 1");

// Fixed payload sizes and smallest entry sizes (bytes).
constexpr size_t kCameraBytes = 10 * 4;
constexpr size_t kPatchFixedBytes = 4 + 4 + 2 + 2; // id, triangleCount/alpha/blockLog2/reserved, x, y
constexpr size_t kPatchMinBytes = kPatchFixedBytes + 3 * 12;
constexpr size_t kColourBytes = 8;

struct Writer {
  std::vector<uint8_t> out;
  void u8(uint8_t v) { out.push_back(v); }
  void u16(uint16_t v) {
    for (int i = 0; i < 2; ++i) out.push_back(uint8_t(v >> (8 * i)));
  }
  void u32(uint32_t v) {
    for (int i = 0; i < 4; ++i) out.push_back(uint8_t(v >> (8 * i)));
  }
  void u64(uint64_t v) {
    for (int i = 0; i < 8; ++i) out.push_back(uint8_t(v >> (8 * i)));
  }
  void f32(float v) { u32(std::bit_cast<uint32_t>(v)); }
  void vec3(const glm::vec3& v) {
    f32(v.x);
    f32(v.y);
    f32(v.z);
  }
  void bytes(std::span<const uint8_t> b) { out.insert(out.end(), b.begin(), b.end()); }
  // Strings longer than a uint16 length can say are cut: the decoder's limits are far below that.
  void str16(std::string_view s) {
    size_t n = std::min<size_t>(s.size(), 0xffff);
    u16(uint16_t(n));
    out.insert(out.end(), s.begin(), s.begin() + ptrdiff_t(n));
  }
  void camera(const Camera& c) {
    vec3(c.eye);
    vec3(c.target);
    vec3(c.up);
    f32(c.fovY);
  }
};

void writePayload(Writer& w, const Hello& m) {
  w.str16(m.token);
  w.u32(m.capabilities);
  w.u32(m.viewportWidth);
  w.u32(m.viewportHeight);
  w.u8(m.stereo ? 1 : 0);
}

void writePayload(Writer& w, const Welcome& m) {
  w.u64(m.sessionId);
  w.vec3(m.sceneMin);
  w.vec3(m.sceneMax);
  w.u32(m.atlasWidth);
  w.u32(m.atlasHeight);
  w.u8(uint8_t(m.codec));
  w.u32(m.patchCount);
  w.u32(m.maxMessageBytes);
  w.u32(m.maxPoseRate);
}

void writePayload(Writer& w, const Pose& m) {
  w.u32(m.sequence);
  w.u64(m.clientTimeUs);
  w.camera(m.camera);
  w.camera(m.predicted);
  w.u32(m.viewportWidth);
  w.u32(m.viewportHeight);
}

void writePayload(Writer& w, const Frame& m) {
  w.u32(m.sequence);
  w.u32(m.poseSequence);
  w.u64(m.serverTimeUs);
  w.u32(uint32_t(m.removed.size()));
  for (uint32_t id : m.removed) w.u32(id);
  w.u32(uint32_t(m.updated.size()));
  for (const PatchUpdate& p : m.updated) {
    w.u32(p.id);
    w.u8(p.triangleCount);
    w.u8(uint8_t(p.alpha));
    w.u8(p.blockLog2);
    w.u8(0); // reserved
    w.u16(p.blockX);
    w.u16(p.blockY);
    uint32_t vertices = std::min<uint32_t>(patchVertexCount(p.triangleCount), 5);
    for (uint32_t v = 0; v < vertices; ++v) w.vec3(p.positions[v]);
  }
  w.u32(uint32_t(m.colours.size()));
  for (const PatchColour& c : m.colours) {
    w.u32(c.id);
    for (uint8_t channel : c.rgba) w.u8(channel);
  }
  w.u8(uint8_t(m.atlas.codec));
  w.u32(m.atlas.width);
  w.u32(m.atlas.height);
  w.u32(uint32_t(m.atlas.bytes.size()));
  w.bytes(m.atlas.bytes);
}

void writePayload(Writer& w, const Close& m) {
  w.u16(uint16_t(m.code));
  w.str16(m.reason);
}

// A bounds-checked cursor over one payload. A failed read leaves `error` naming the field.
class Reader {
public:
  explicit Reader(std::span<const uint8_t> bytes) : bytes_(bytes) {}
  std::string error;

  size_t left() const { return bytes_.size() - pos_; }
  bool need(size_t n, std::string_view field) {
    if (n <= left()) return true;
    error =
        std::string(field) + ": truncated (needs " + std::to_string(n) + " bytes, " + std::to_string(left()) + " left)";
    return false;
  }
  bool u8(uint8_t& v, std::string_view field) {
    if (!need(1, field)) return false;
    v = bytes_[pos_++];
    return true;
  }
  bool u16(uint16_t& v, std::string_view field) {
    if (!need(2, field)) return false;
    v = uint16_t(bytes_[pos_] | (bytes_[pos_ + 1] << 8));
    pos_ += 2;
    return true;
  }
  bool u32(uint32_t& v, std::string_view field) {
    if (!need(4, field)) return false;
    v = 0;
    for (int i = 0; i < 4; ++i) v |= uint32_t(bytes_[pos_ + i]) << (8 * i);
    pos_ += 4;
    return true;
  }
  bool u64(uint64_t& v, std::string_view field) {
    if (!need(8, field)) return false;
    v = 0;
    for (int i = 0; i < 8; ++i) v |= uint64_t(bytes_[pos_ + i]) << (8 * i);
    pos_ += 8;
    return true;
  }
  // Finite floats only: a NaN or infinity reaching a view matrix or a vertex is never meant.
  bool f32(float& v, std::string_view field) {
    uint32_t bits = 0;
    if (!u32(bits, field)) return false;
    v = std::bit_cast<float>(bits);
    if (std::isfinite(v)) return true;
    error = std::string(field) + ": not a finite number";
    return false;
  }
  bool vec3(glm::vec3& v, std::string_view field) {
    return f32(v.x, std::string(field) + ".x") && f32(v.y, std::string(field) + ".y") &&
           f32(v.z, std::string(field) + ".z");
  }
  bool str16(std::string& s, uint32_t maxBytes, std::string_view field) {
    uint16_t n = 0;
    if (!u16(n, std::string(field) + " length")) return false;
    if (n > maxBytes)
      return fail(field, "length " + std::to_string(n) + " over the limit of " + std::to_string(maxBytes));
    if (!need(n, field)) return false;
    s.assign(reinterpret_cast<const char*>(bytes_.data() + pos_), n);
    pos_ += n;
    return true;
  }
  bool bytes(std::vector<uint8_t>& out, size_t n, std::string_view field) {
    if (!need(n, field)) return false;
    out.assign(bytes_.begin() + ptrdiff_t(pos_), bytes_.begin() + ptrdiff_t(pos_ + n));
    pos_ += n;
    return true;
  }
  // A count of entries of at least `entryBytes` each: within `limit` and within the bytes left.
  bool count(uint32_t& n, uint32_t limit, size_t entryBytes, std::string_view field) {
    if (!u32(n, field)) return false;
    if (n > limit) return fail(field, std::to_string(n) + " over the limit of " + std::to_string(limit));
    if (uint64_t(n) * entryBytes > left())
      return fail(field, std::to_string(n) + " entries need " + std::to_string(uint64_t(n) * entryBytes) + " bytes, " +
                             std::to_string(left()) + " left");
    return true;
  }
  bool fail(std::string_view field, const std::string& problem) {
    error = std::string(field) + " " + problem;
    return false;
  }

private:
  std::span<const uint8_t> bytes_;
  size_t pos_ = 0;
};

bool readViewport(Reader& r, uint32_t& width, uint32_t& height, const DecodeLimits& limits) {
  if (!r.u32(width, "viewportWidth") || !r.u32(height, "viewportHeight")) return false;
  if (width == 0 || width > limits.maxViewportSide)
    return r.fail("viewportWidth", std::to_string(width) + " not in 1.." + std::to_string(limits.maxViewportSide));
  if (height == 0 || height > limits.maxViewportSide)
    return r.fail("viewportHeight", std::to_string(height) + " not in 1.." + std::to_string(limits.maxViewportSide));
  return true;
}

bool readPayload(Reader& r, Hello& m, const DecodeLimits& limits) {
  uint8_t stereo = 0;
  if (!r.str16(m.token, limits.maxTokenBytes, "token") || !r.u32(m.capabilities, "capabilities") ||
      !readViewport(r, m.viewportWidth, m.viewportHeight, limits) || !r.u8(stereo, "stereo"))
    return false;
  if (m.capabilities & ~kKnownCapabilities)
    return r.fail("capabilities", "has unknown bits " + std::to_string(m.capabilities));
  if (stereo > 1) return r.fail("stereo", std::to_string(stereo) + " not 0 or 1");
  m.stereo = stereo == 1;
  return true;
}

bool readPayload(Reader& r, Welcome& m, const DecodeLimits& limits) {
  uint8_t codec = 0;
  if (!r.u64(m.sessionId, "sessionId") || !r.vec3(m.sceneMin, "sceneMin") || !r.vec3(m.sceneMax, "sceneMax") ||
      !r.u32(m.atlasWidth, "atlasWidth") || !r.u32(m.atlasHeight, "atlasHeight") || !r.u8(codec, "codec") ||
      !r.u32(m.patchCount, "patchCount") || !r.u32(m.maxMessageBytes, "maxMessageBytes") ||
      !r.u32(m.maxPoseRate, "maxPoseRate"))
    return false;
  if (glm::any(glm::greaterThan(m.sceneMin, m.sceneMax))) return r.fail("sceneMin", "above sceneMax");
  if (m.atlasWidth == 0 || m.atlasWidth > limits.maxAtlasSide)
    return r.fail("atlasWidth", std::to_string(m.atlasWidth) + " not in 1.." + std::to_string(limits.maxAtlasSide));
  if (m.atlasHeight == 0 || m.atlasHeight > limits.maxAtlasSide)
    return r.fail("atlasHeight", std::to_string(m.atlasHeight) + " not in 1.." + std::to_string(limits.maxAtlasSide));
  if (codec == 0 || codec >= kAtlasCodecCount) return r.fail("codec", std::to_string(codec) + " not a codec id (1..3)");
  m.codec = AtlasCodec(codec);
  if (m.maxMessageBytes < kMessageHeaderBytes)
    return r.fail("maxMessageBytes", std::to_string(m.maxMessageBytes) + " below a header");
  return true;
}

bool readCamera(Reader& r, Camera& c, std::string_view field) {
  std::string f(field);
  if (!r.vec3(c.eye, f + ".eye") || !r.vec3(c.target, f + ".target") || !r.vec3(c.up, f + ".up") ||
      !r.f32(c.fovY, f + ".fovY"))
    return false;
  if (!(c.fovY > 0.0f && c.fovY < std::numbers::pi_v<float>))
    return r.fail(f + ".fovY", std::to_string(c.fovY) + " not in (0, pi)");
  if (c.eye == c.target) return r.fail(f + ".target", "equals eye");
  if (c.up == glm::vec3(0.0f)) return r.fail(f + ".up", "is zero");
  return true;
}

bool readPayload(Reader& r, Pose& m, const DecodeLimits& limits) {
  return r.u32(m.sequence, "sequence") && r.u64(m.clientTimeUs, "clientTimeUs") && readCamera(r, m.camera, "camera") &&
         readCamera(r, m.predicted, "predicted") && readViewport(r, m.viewportWidth, m.viewportHeight, limits);
}

bool readPatch(Reader& r, PatchUpdate& p, const DecodeLimits& limits) {
  uint8_t alpha = 0, reserved = 0;
  if (!r.u32(p.id, "id") || !r.u8(p.triangleCount, "triangleCount") || !r.u8(alpha, "alpha") ||
      !r.u8(p.blockLog2, "blockLog2") || !r.u8(reserved, "reserved") || !r.u16(p.blockX, "blockX") ||
      !r.u16(p.blockY, "blockY"))
    return false;
  if (p.triangleCount < 1 || p.triangleCount > MIRAGE_ATLAS_MAX_PATCH_TRIANGLES)
    return r.fail("triangleCount", std::to_string(p.triangleCount) + " not in 1..3");
  if (alpha >= kAlphaModeCount) return r.fail("alpha", std::to_string(alpha) + " not an alpha mode (0..2)");
  p.alpha = AlphaMode(alpha);
  if (reserved != 0) return r.fail("reserved", std::to_string(reserved) + " not 0");
  if (p.blockLog2 == kColourOnlyBlock) {
    if (p.blockX != 0 || p.blockY != 0) return r.fail("blockX", "not 0 for a colour-only patch");
  } else {
    if (p.blockLog2 < MIRAGE_ATLAS_MIN_BLOCK_LOG2 || p.blockLog2 > MIRAGE_ATLAS_MAX_BLOCK_LOG2)
      return r.fail("blockLog2", std::to_string(p.blockLog2) + " not in 1..7 or 255 (colour-only)");
    uint32_t width = shaderio::atlasBlockWidth(p.triangleCount, p.blockLog2);
    uint32_t height = 1u << p.blockLog2;
    if (p.blockX + width > limits.maxAtlasSide || p.blockY + height > limits.maxAtlasSide)
      return r.fail("blockX", "block at (" + std::to_string(p.blockX) + ", " + std::to_string(p.blockY) + ") size " +
                                  std::to_string(width) + "x" + std::to_string(height) + " outside the atlas side " +
                                  std::to_string(limits.maxAtlasSide));
  }
  for (uint32_t v = 0; v < patchVertexCount(p.triangleCount); ++v)
    if (!r.vec3(p.positions[v], "positions[" + std::to_string(v) + "]")) return false;
  return true;
}

bool readPayload(Reader& r, Frame& m, const DecodeLimits& limits) {
  if (!r.u32(m.sequence, "sequence") || !r.u32(m.poseSequence, "poseSequence") ||
      !r.u64(m.serverTimeUs, "serverTimeUs"))
    return false;
  uint32_t n = 0;
  if (!r.count(n, limits.maxRemovedPerFrame, 4, "removed count")) return false;
  m.removed.resize(n);
  for (uint32_t i = 0; i < n; ++i)
    if (!r.u32(m.removed[i], "removed[" + std::to_string(i) + "]")) return false;
  if (!r.count(n, limits.maxPatchesPerFrame, kPatchMinBytes, "updated count")) return false;
  m.updated.resize(n);
  for (uint32_t i = 0; i < n; ++i) {
    if (!readPatch(r, m.updated[i], limits)) {
      r.error = "updated[" + std::to_string(i) + "]." + r.error;
      return false;
    }
  }
  if (!r.count(n, limits.maxColoursPerFrame, kColourBytes, "colours count")) return false;
  m.colours.resize(n);
  for (uint32_t i = 0; i < n; ++i) {
    PatchColour& c = m.colours[i];
    std::string field = "colours[" + std::to_string(i) + "]";
    if (!r.u32(c.id, field + ".id")) return false;
    for (uint8_t& channel : c.rgba)
      if (!r.u8(channel, field + ".rgba")) return false;
  }
  uint8_t codec = 0;
  uint32_t byteCount = 0;
  if (!r.u8(codec, "atlas.codec") || !r.u32(m.atlas.width, "atlas.width") || !r.u32(m.atlas.height, "atlas.height") ||
      !r.u32(byteCount, "atlas.byteCount"))
    return false;
  if (codec >= kAtlasCodecCount) return r.fail("atlas.codec", std::to_string(codec) + " not a codec id (0..3)");
  m.atlas.codec = AtlasCodec(codec);
  if (m.atlas.codec == AtlasCodec::None) {
    if (m.atlas.width != 0 || m.atlas.height != 0 || byteCount != 0)
      return r.fail("atlas.codec", "none but the payload has a size or bytes");
    return true;
  }
  if (m.atlas.width == 0 || m.atlas.width > limits.maxAtlasSide || m.atlas.height == 0 ||
      m.atlas.height > limits.maxAtlasSide)
    return r.fail("atlas.width", std::to_string(m.atlas.width) + "x" + std::to_string(m.atlas.height) + " not in 1.." +
                                     std::to_string(limits.maxAtlasSide));
  if (byteCount == 0) return r.fail("atlas.byteCount", "0 for a codec other than none");
  return r.bytes(m.atlas.bytes, byteCount, "atlas.bytes");
}

bool readPayload(Reader& r, Close& m, const DecodeLimits& limits) {
  uint16_t code = 0;
  if (!r.u16(code, "code") || !r.str16(m.reason, limits.maxReasonBytes, "reason")) return false;
  if (code >= kCloseCodeCount)
    return r.fail("code", std::to_string(code) + " not a close code (0.." + std::to_string(kCloseCodeCount - 1) + ")");
  m.code = CloseCode(code);
  return true;
}

template <class T>
Result<Message> decodeAs(std::span<const uint8_t> payload, const DecodeLimits& limits, std::string_view peer,
                         MessageType type) {
  Reader r(payload);
  T message;
  if (!readPayload(r, message, limits)) return makeError(std::string(peer), messageTypeName(type) + ": " + r.error);
  if (r.left() != 0)
    return makeError(std::string(peer),
                     messageTypeName(type) + ": " + std::to_string(r.left()) + " bytes after the last field");
  return Message(std::move(message));
}

} // namespace

std::vector<uint8_t> encodeMessage(const Message& message) {
  Writer w;
  w.out.reserve(64);
  w.bytes(kMessageMagic);
  w.u16(kProtocolVersion);
  w.u16(uint16_t(messageType(message)));
  w.u32(0); // payload length, patched below
  std::visit([&](const auto& m) { writePayload(w, m); }, message);
  uint32_t payload = uint32_t(w.out.size() - kMessageHeaderBytes);
  for (int i = 0; i < 4; ++i) w.out[8 + i] = uint8_t(payload >> (8 * i));
  return std::move(w.out);
}

Result<MessageHeader> decodeMessageHeader(std::span<const uint8_t> bytes, const DecodeLimits& limits,
                                          std::string_view peer) {
  std::string p(peer);
  if (bytes.size() > limits.maxMessageBytes)
    return makeError(p, "message of " + std::to_string(bytes.size()) + " bytes over the limit of " +
                            std::to_string(limits.maxMessageBytes));
  if (bytes.size() < kMessageHeaderBytes)
    return makeError(p, "message of " + std::to_string(bytes.size()) + " bytes, shorter than the 12-byte header");
  if (std::memcmp(bytes.data(), kMessageMagic.data(), 4) != 0)
    return makeError(p, "not a stream message (magic " +
                            quoteInput(std::string_view(reinterpret_cast<const char*>(bytes.data()), 4)) +
                            ", expected 'MRGS')");
  Reader r(bytes.subspan(4));
  uint16_t version = 0, type = 0;
  uint32_t length = 0;
  (void)(r.u16(version, "version") && r.u16(type, "type") && r.u32(length, "length"));
  if (version != kProtocolVersion)
    return makeError(p, "protocol version " + std::to_string(version) + ", this build speaks version " +
                            std::to_string(kProtocolVersion));
  if (type < 1 || type > std::variant_size_v<Message>)
    return makeError(p, "unknown message type " + std::to_string(type));
  MessageHeader header{MessageType(type), length};
  if (length != bytes.size() - kMessageHeaderBytes)
    return makeError(p, messageTypeName(header.type) + ": header length " + std::to_string(length) + " but " +
                            std::to_string(bytes.size() - kMessageHeaderBytes) + " payload bytes");
  return header;
}

Result<Message> decodeMessage(std::span<const uint8_t> bytes, const DecodeLimits& limits, std::string_view peer) {
  Result<MessageHeader> header = decodeMessageHeader(bytes, limits, peer);
  if (!header) return header.error();
  std::span<const uint8_t> payload = bytes.subspan(kMessageHeaderBytes);
  switch (header->type) {
  case MessageType::Hello:
    return decodeAs<Hello>(payload, limits, peer, header->type);
  case MessageType::Welcome:
    return decodeAs<Welcome>(payload, limits, peer, header->type);
  case MessageType::Pose:
    return decodeAs<Pose>(payload, limits, peer, header->type);
  case MessageType::Frame:
    return decodeAs<Frame>(payload, limits, peer, header->type);
  case MessageType::Close:
    return decodeAs<Close>(payload, limits, peer, header->type);
  }
  return makeError(std::string(peer), "unknown message type"); // decodeMessageHeader checked the type
}

Status acceptClientMessage(ClientMessageOrder& order, const Message& message, std::string_view peer) {
  std::string p(peer);
  MessageType type = messageType(message);
  if (type == MessageType::Welcome || type == MessageType::Frame)
    return makeError(p, messageTypeName(type) + " is a server message, not accepted from a client");
  if (type == MessageType::Hello) {
    if (order.helloSeen) return makeError(p, "second Hello on one connection");
    order.helloSeen = true;
    return Ok{};
  }
  if (type == MessageType::Close) return Ok{};
  if (!order.helloSeen) return makeError(p, "Pose before Hello");
  uint32_t sequence = std::get<Pose>(message).sequence;
  if (order.poseSeen && sequence <= order.lastPoseSequence)
    return makeError(p, "Pose sequence " + std::to_string(sequence) + " not above the previous " +
                            std::to_string(order.lastPoseSequence));
  order.poseSeen = true;
  order.lastPoseSequence = sequence;
  return Ok{};
}

} // namespace mirage::stream
