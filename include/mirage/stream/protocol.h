#pragma once
// The shading atlas streaming wire protocol (docs/stream.md, "Protocol"): versioned binary messages,
// little-endian, one message per WebSocket binary frame. Every message starts with a 12-byte header
// (magic "MRGS", uint16 version, uint16 type, uint32 payload length) followed by its payload.
// Messages are plain structs; encodeMessage writes them, decodeMessage checks every length and count
// against the bytes left and against DecodeLimits before it reads, so a hostile peer gets a one-line
// error, never an out-of-bounds read or a huge allocation. A Frame's patch changes travel in a compact
// patch section (docs/stream.md, "Patch section"): varints, positions on an integer grid, block-only
// entries for geometry the client already has, optionally zstd.
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include <glm/vec3.hpp>

#include "mirage/core/result.h"

namespace mirage::stream {

inline constexpr std::array<uint8_t, 4> kMessageMagic = {'M', 'R', 'G', 'S'};
// 3: Frame carries a particle section after the patch section (docs/stream.md, "Particle section").
inline constexpr uint16_t kProtocolVersion = 3;
inline constexpr size_t kMessageHeaderBytes = 12;

enum class MessageType : uint16_t { Hello = 1, Welcome = 2, Pose = 3, Frame = 4, Close = 5 };
// "Hello", "Welcome", ... ("type N" for a value outside the enum).
std::string messageTypeName(MessageType type);

// Hello.capabilities bits: the atlas codecs a client can decode, and whether it decodes a zstd patch
// section (Frame.patchCodec; browsers without DecompressionStream("zstd") do not).
enum CodecCapability : uint32_t {
  kCapabilityZstdTiles = 1u << 0,
  kCapabilityH264 = 1u << 1,
  kCapabilityJpegTiles = 1u << 2,
  kCapabilityZstdPatches = 1u << 3,
};
inline constexpr uint32_t kKnownCapabilities =
    kCapabilityZstdTiles | kCapabilityH264 | kCapabilityJpegTiles | kCapabilityZstdPatches;

// The codec of an atlas payload. None: the frame carries no atlas (geometry or colours only).
enum class AtlasCodec : uint8_t { None = 0, ZstdTiles = 1, H264 = 2, JpegTiles = 3 };
inline constexpr uint8_t kAtlasCodecCount = 4;

// How the client blends a patch: opaque patches write depth, blended ones go to the per-pixel lists.
enum class AlphaMode : uint8_t { Opaque = 0, Mask = 1, Blend = 2 };
inline constexpr uint8_t kAlphaModeCount = 3;

// Why a peer closes (Close.code). The transport also closes the WebSocket with a matching
// status code (closeStatusFor in transport.h).
enum class CloseCode : uint16_t {
  Normal = 0,       // the peer is done (server stopping, client quitting)
  BadToken = 1,     // Hello's token is wrong
  Malformed = 2,    // a message failed to decode
  OutOfOrder = 3,   // Pose before Hello, a second Hello, a pose sequence not increasing, wrong direction
  TooLarge = 4,     // a message over the byte limit
  ServerFull = 5,   // max clients reached
  HelloTimeout = 6, // no Hello within the handshake timeout
  Overloaded = 7,   // the peer does not keep up
  Unsupported = 8,  // no common codec, unknown version
};
inline constexpr uint16_t kCloseCodeCount = 9;

// Client -> server, the first message on a connection.
struct Hello {
  std::string token;         // the shared secret (compared in constant time)
  uint32_t capabilities = 0; // CodecCapability bits
  uint32_t viewportWidth = 0, viewportHeight = 0;
  bool stereo = false;
  bool operator==(const Hello&) const = default;
};

// Patch positions travel as integer coordinates q (each below 2^kPositionGridBits) on a grid: world
// = sceneMin + q * Welcome.positionStep, per axis. The server rounds to the nearest grid point, so a
// position is off by at most positionStep / 2 per axis; a vertex shared by two patches lands on the
// same grid point in both (no cracks).
inline constexpr uint32_t kPositionGridBits = 24;
inline constexpr uint32_t kPositionGridMax = (1u << kPositionGridBits) - 1;

// Server -> client, the answer to an accepted Hello.
struct Welcome {
  uint64_t sessionId = 0;
  glm::vec3 sceneMin{0.0f}, sceneMax{0.0f}; // world-space bounds of the scene
  float positionStep = 1.0f;                // the position grid's spacing (> 0; the grid covers the bounds)
  uint32_t atlasWidth = 0, atlasHeight = 0; // texels
  AtlasCodec codec = AtlasCodec::ZstdTiles; // chosen from the client's capabilities
  uint32_t patchCount = 0;                  // patches in the scene (ids are below it)
  // Server limits: a client must not exceed them.
  uint32_t maxMessageBytes = 0; // largest message the server accepts
  uint32_t maxPoseRate = 0;     // poses per second the server answers (0: no limit)
  bool operator==(const Welcome&) const = default;
};

struct Camera {
  glm::vec3 eye{0.0f}, target{0.0f, 0.0f, -1.0f}, up{0.0f, 1.0f, 0.0f};
  float fovY = 1.0f; // vertical field of view, radians, in (0, pi)
  bool operator==(const Camera&) const = default;
};

// Client -> server, once per client frame (or less often).
struct Pose {
  uint32_t sequence = 0;     // strictly increasing per connection
  uint64_t clientTimeUs = 0; // the client's clock when the pose was taken
  Camera camera;             // the current view
  Camera predicted;          // the view the client expects when the answer arrives
  uint32_t viewportWidth = 0, viewportHeight = 0;
  bool operator==(const Pose&) const = default;
};

// Block of a patch that did not fit in the atlas: it is drawn with one colour (Frame.colours).
inline constexpr uint8_t kColourOnlyBlock = 0xff;

// Frames a client keeps the geometry of a patch it was told to remove: a removal in frame n (the
// n-th Frame of the connection) may be answered by a block-only entry in frames n .. n + this - 1.
// Server and client count alike, so the server never refers to geometry the client dropped.
inline constexpr uint32_t kKeptGeometryFrames = 256;

// A patch added to the client's set or given a new block (docs/stream.md, "Patch section").
struct PatchUpdate {
  uint32_t id = 0;           // global patch id (below Welcome.patchCount)
  uint8_t triangleCount = 1; // 1..3
  // True: alpha and positions travel (a patch the client has no geometry of). False: a block-only
  // entry: the client's own geometry of the patch (held, or kept since its removal) takes the block;
  // alpha and positions are then Opaque and zero.
  bool geometry = true;
  AlphaMode alpha = AlphaMode::Opaque;
  // Grid coordinates (kPositionGridBits) of vertex slots a..e (shaderio/atlas.h); the first
  // triangleCount + 2 travel.
  std::array<glm::uvec3, 5> positions{};
  uint16_t blockX = 0, blockY = 0; // the block's first texel (a multiple of 2^blockLog2)
  uint8_t blockLog2 = 1;           // MIRAGE_ATLAS_MIN_BLOCK_LOG2..MAX, or kColourOnlyBlock
  bool operator==(const PatchUpdate&) const = default;
};
// Vertex slots a patch of `triangleCount` triangles uses (3, 4 or 5).
inline uint32_t patchVertexCount(uint32_t triangleCount) { return triangleCount + 2; }

struct PatchColour {
  uint32_t id = 0;
  std::array<uint8_t, 4> rgba{};
  bool operator==(const PatchColour&) const = default;
};

struct AtlasPayload {
  AtlasCodec codec = AtlasCodec::None;
  uint32_t width = 0, height = 0; // texels of the region the bytes encode
  std::vector<uint8_t> bytes;
  bool operator==(const AtlasPayload&) const = default;
};

// How a Frame's patch section travels: as is, or as one zstd frame (for clients announcing
// kCapabilityZstdPatches).
enum class PatchCodec : uint8_t { Raw = 0, Zstd = 1 };
inline constexpr uint8_t kPatchCodecCount = 2;

// A particle look's atlas block, sent when it changed (docs/stream.md, "Particle section"): a wide
// block (2h x h) holding the look's texture and its mips (shaderio/atlas.h, atlasParticleLevelTexel),
// or when blockLog2 is kColourOnlyBlock one colour (sRGB rgb, linear alpha, as the atlas).
struct ParticleLook {
  uint32_t id = 0;                 // look id (server-chosen; the client keeps what its particles use)
  uint16_t blockX = 0, blockY = 0; // the block's first texel (a multiple of 2^blockLog2)
  uint8_t blockLog2 = 1;           // MIRAGE_ATLAS_MIN_BLOCK_LOG2..MAX, or kColourOnlyBlock
  std::array<uint8_t, 4> rgba{};   // colour-only looks; zero otherwise
  bool operator==(const ParticleLook&) const = default;
};

// Particle positions travel on a 16-bit grid per axis over the frame's particles: world = origin +
// q x step (Frame.particleOrigin, particleStep).
inline constexpr uint32_t kParticleGridMax = 0xffff;

// One visible particle, quantized (quantizeParticle): a camera-facing billboard the client draws
// with its look's block times its colour.
struct StreamParticle {
  uint32_t look = 0;                  // a look the client holds after this frame's looks
  std::array<uint16_t, 3> position{}; // grid coordinates
  uint16_t size = 0;                  // billboard edge, world units, IEEE half (finite, not negative)
  uint16_t rotation = 0;              // about the view axis: rotation x 2 pi / 65536 radians
  std::array<uint8_t, 4> rgba{};      // the particle's colour (linear, straight alpha), r first
  bool operator==(const StreamParticle&) const = default;
};

// Server -> client, the answer to a pose. The patch section (removed, updated, colours) lists ids in
// strictly increasing order each (encodeMessage asserts it, the decoder rejects anything else).
struct Frame {
  uint32_t sequence = 0;     // frame number: 1, 2, ... on a connection
  uint32_t poseSequence = 0; // the Pose.sequence this frame was rendered for
  uint64_t serverTimeUs = 0;
  PatchCodec patchCodec = PatchCodec::Raw;
  std::vector<uint32_t> removed;    // patch ids the client drops (it keeps their geometry a while)
  std::vector<PatchUpdate> updated; // patches added or given a new block
  std::vector<PatchColour> colours; // colours of colour-only patches that changed
  // The particle section: the looks whose block (or colour) the client does not have yet, ids
  // strictly increasing, each used by a particle; every visible particle (none: origin and step
  // do not travel).
  PatchCodec particleCodec = PatchCodec::Raw;
  std::vector<ParticleLook> looks;
  glm::vec3 particleOrigin{0.0f}; // the particle grid (finite)
  float particleStep = 1.0f;      // > 0, finite
  std::vector<StreamParticle> particles;
  AtlasPayload atlas;
  bool operator==(const Frame&) const = default;
};

// Either way: the sender closes the connection after it.
struct Close {
  CloseCode code = CloseCode::Normal;
  std::string reason; // one line, for logs
  bool operator==(const Close&) const = default;
};

using Message = std::variant<Hello, Welcome, Pose, Frame, Close>;
MessageType messageType(const Message& message);

// What the decoder accepts. A peer's message past any of these is rejected before anything is allocated.
struct DecodeLimits {
  uint32_t maxMessageBytes = 64u << 20;   // header included
  uint32_t maxPatchesPerFrame = 1u << 20; // updated entries
  uint32_t maxRemovedPerFrame = 1u << 20;
  uint32_t maxColoursPerFrame = 1u << 20;
  uint32_t maxPatchSectionBytes = 64u << 20; // a Frame's patch or particle section, decompressed
  uint32_t maxParticlesPerFrame = 1u << 22;
  uint32_t maxLooksPerFrame = 1u << 22;
  uint32_t maxTokenBytes = 256;
  uint32_t maxReasonBytes = 1024;
  uint32_t maxViewportSide = 16384;
  uint32_t maxAtlasSide = 16384; // atlas width/height; blocks must lie inside
};

std::vector<uint8_t> encodeMessage(const Message& message);

// The bytes a Frame's patch section takes in the message, as `frame.patchCodec` says (compressed
// when Zstd): what the server compares to choose the codec, and what statistics count.
size_t patchSectionBytes(const Frame& frame);
// The same for the particle section (frame.particleCodec).
size_t particleSectionBytes(const Frame& frame);

// The position grid (Welcome.positionStep): the spacing that spans the largest extent of the bounds
// with 2^bits - 1 steps (bits 1..kPositionGridBits); quantization and its inverse.
float positionGridStep(const glm::vec3& sceneMin, const glm::vec3& sceneMax, uint32_t bits);
glm::uvec3 quantizePosition(const glm::vec3& position, const glm::vec3& sceneMin, float step);
glm::vec3 dequantizePosition(const glm::uvec3& q, const glm::vec3& sceneMin, float step);

// The particle grid spanning [min, max] (the frame's particle centres) with kParticleGridMax steps
// per axis of the largest extent; a particle's wire form on it and back.
float particleGridStep(const glm::vec3& min, const glm::vec3& max);
StreamParticle quantizeParticle(const glm::vec3& position, float size, float rotation, uint32_t rgba, uint32_t look,
                                const glm::vec3& origin, float step);
glm::vec3 particlePosition(const StreamParticle& particle, const glm::vec3& origin, float step);
float particleSize(uint16_t size);
float particleRotation(uint16_t rotation);

struct MessageHeader {
  MessageType type = MessageType::Hello;
  uint32_t payloadBytes = 0;
};
// The header alone (magic, version, known type, payload length within limits and equal to the bytes
// after the header). `peer` names the sender in the error: "<peer>: ...".
Result<MessageHeader> decodeMessageHeader(std::span<const uint8_t> bytes, const DecodeLimits& limits,
                                          std::string_view peer);
// One whole message. Errors name the message type and field: "<peer>: Frame: updated[3].triangleCount 4 not in 1..3".
Result<Message> decodeMessage(std::span<const uint8_t> bytes, const DecodeLimits& limits, std::string_view peer);

// The order rules of one connection, seen from the server: the first message is Hello, only once;
// then Pose (sequence strictly increasing) or Close. Welcome and Frame never come from a client.
struct ClientMessageOrder {
  bool helloSeen = false;
  bool poseSeen = false;
  uint32_t lastPoseSequence = 0;
};
// Advances `order` by `message` or says (one line, naming `peer`) why it is out of order.
Status acceptClientMessage(ClientMessageOrder& order, const Message& message, std::string_view peer);

} // namespace mirage::stream
