// Encoding and decoding of the stream messages (docs/stream.md, "Protocol"); a Frame's patch section
// is patch_section.cpp's, its particle section particle_section.cpp's. The decoder reads through a bounds-checked
// cursor (wire.h): every read says what it needs before it touches a byte, and every count is checked against the
// limits and against the bytes left (count x smallest entry) before a vector is sized, so a forged count cannot
// allocate more than the message itself holds.
#include "mirage/stream/protocol.h"

#include <bit>
#include <cmath>
#include <cstring>
#include <numbers>

#include <glm/vector_relational.hpp>

#include "mirage/core/input_text.h"
#include "patch_section.h"

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

using wire::Reader;
using wire::Writer;

static_assert(std::variant_size_v<Message> == 5, "MessageType values are the variant index + 1");

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
  w.f32(m.positionStep);
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
  wire::writePatchSection(w, m);
  wire::writeParticleSection(w, m);
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
      !r.f32(m.positionStep, "positionStep") || !r.u32(m.atlasWidth, "atlasWidth") ||
      !r.u32(m.atlasHeight, "atlasHeight") || !r.u8(codec, "codec") || !r.u32(m.patchCount, "patchCount") ||
      !r.u32(m.maxMessageBytes, "maxMessageBytes") || !r.u32(m.maxPoseRate, "maxPoseRate"))
    return false;
  if (glm::any(glm::greaterThan(m.sceneMin, m.sceneMax))) return r.fail("sceneMin", "above sceneMax");
  if (!(m.positionStep > 0.0f)) return r.fail("positionStep", std::to_string(m.positionStep) + " not above 0");
  glm::vec3 extent = m.sceneMax - m.sceneMin;
  double largest = std::max({double(extent.x), double(extent.y), double(extent.z)});
  if (largest / double(m.positionStep) > double(kPositionGridMax))
    return r.fail("positionStep", std::to_string(m.positionStep) + ": the grid does not span the scene bounds");
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

bool readPayload(Reader& r, Frame& m, const DecodeLimits& limits) {
  if (!r.u32(m.sequence, "sequence") || !r.u32(m.poseSequence, "poseSequence") ||
      !r.u64(m.serverTimeUs, "serverTimeUs"))
    return false;
  if (!wire::readPatchSection(r, m, limits) || !wire::readParticleSection(r, m, limits)) return false;
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
