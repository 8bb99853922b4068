#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "mirage/stream/protocol.h"
#include "stream/protocol_test_util.h"

using namespace mirage;
using namespace mirage::stream;

namespace {

Camera camera(float shift) {
  Camera c;
  c.eye = {1.5f + shift, 2.0f, -3.25f};
  c.target = {0.0f, 0.5f, shift};
  c.up = {0.0f, 1.0f, 0.0f};
  c.fovY = 0.9f;
  return c;
}

PatchUpdate patch(uint32_t id, uint8_t triangles, uint8_t log2) {
  PatchUpdate p;
  p.id = id;
  p.triangleCount = triangles;
  p.alpha = triangles == 2 ? stream::AlphaMode::Blend : stream::AlphaMode::Opaque;
  for (uint32_t v = 0; v < patchVertexCount(triangles); ++v) // far apart and on the grid's edges
    p.positions[v] = {v * 1000u, id % 1000u * 77u, v == 4 ? kPositionGridMax : kPositionGridMax - v - id % 1000u};
  p.blockLog2 = log2;
  if (log2 != kColourOnlyBlock) {
    p.blockX = uint16_t(128 * id);
    p.blockY = 256;
  }
  return p;
}

// A block-only entry: the client's own geometry of the patch at a new block.
PatchUpdate blockOnlyPatch(uint32_t id, uint8_t triangles, uint8_t log2) {
  PatchUpdate p;
  p.id = id;
  p.triangleCount = triangles;
  p.geometry = false;
  p.blockLog2 = log2;
  if (log2 != kColourOnlyBlock) {
    p.blockX = uint16_t(64 << log2);
    p.blockY = uint16_t(3 << log2);
  }
  return p;
}

Frame sampleFrame() {
  Frame f;
  f.sequence = 77;
  f.poseSequence = 41;
  f.serverTimeUs = 123456789012ull;
  f.removed = {5, 9, 1000, 0xffffffffu};
  f.updated = {patch(1, 1, 1),
               patch(2, 2, 4),
               patch(3, 3, 7),
               patch(4, 3, kColourOnlyBlock),
               blockOnlyPatch(6, 2, 5),
               blockOnlyPatch(7, 3, 6),
               blockOnlyPatch(70000, 1, kColourOnlyBlock),
               patch(0xfffffff0u, 2, 1)};
  f.updated.back().blockX = 16382; // the last block along the widest atlas
  f.updated.back().blockY = 0;
  f.colours = {{4, {10, 20, 30, 255}}, {8, {0, 0, 0, 0}}, {70000, {1, 2, 3, 4}}};
  // Particles: a look with a block, a colour-only one, and particles of those and of a look the
  // client holds from an earlier frame.
  f.looks = {{3, 64, 32, 5, {}}, {200, 0, 0, kColourOnlyBlock, {9, 8, 7, 6}}};
  f.particleOrigin = {-2.0f, 0.5f, 3.0f};
  f.particleStep = 1e-4f;
  f.particles = {{3, {0, 1, 2}, 0x3c00, 0, {255, 128, 0, 200}},
                 {200, {65535, 40000, 7}, 0x7bff, 65535, {1, 2, 3, 4}},
                 {7, {10, 20, 30}, 0, 16384, {0, 0, 0, 0}}};
  f.atlas.codec = AtlasCodec::ZstdTiles;
  f.atlas.width = 512;
  f.atlas.height = 256;
  f.atlas.bytes = {1, 2, 3, 4, 5, 250};
  return f;
}

std::vector<Message> sampleMessages() {
  Hello hello{"s3cret token", kCapabilityZstdTiles | kCapabilityH264, 1920, 1080, true};
  Welcome welcome;
  welcome.sessionId = 0x0123456789abcdefull;
  welcome.sceneMin = {-10.0f, -1.0f, -5.5f};
  welcome.sceneMax = {10.0f, 4.0f, 5.5f};
  welcome.positionStep = positionGridStep(welcome.sceneMin, welcome.sceneMax, 20);
  welcome.atlasWidth = 4096;
  welcome.atlasHeight = 2048;
  welcome.codec = AtlasCodec::H264;
  welcome.patchCount = 250000;
  welcome.maxMessageBytes = 65536;
  welcome.maxPoseRate = 90;
  Pose pose;
  pose.sequence = 41;
  pose.clientTimeUs = 987654321;
  pose.camera = camera(0.0f);
  pose.predicted = camera(0.25f);
  pose.viewportWidth = 1280;
  pose.viewportHeight = 720;
  Frame zstd = sampleFrame();
  zstd.patchCodec = PatchCodec::Zstd;
  zstd.particleCodec = PatchCodec::Zstd;
  return {hello, welcome, pose, sampleFrame(), Close{CloseCode::BadToken, "wrong token"}, Frame{}, zstd};
}

using test::decode;
using test::expectError;

void setU32(std::vector<uint8_t>& bytes, size_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) bytes[at + i] = uint8_t(v >> (8 * i));
}

void setPayloadLength(std::vector<uint8_t>& bytes) { setU32(bytes, 8, uint32_t(bytes.size() - kMessageHeaderBytes)); }

} // namespace

TEST(StreamProtocol, EveryTypeRoundTrips) {
  for (const Message& message : sampleMessages()) {
    std::vector<uint8_t> bytes = encodeMessage(message);
    ASSERT_GE(bytes.size(), kMessageHeaderBytes);
    EXPECT_EQ(std::vector<uint8_t>(bytes.begin(), bytes.begin() + 4), std::vector<uint8_t>({'M', 'R', 'G', 'S'}));
    Result<Message> back = decode(bytes);
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(messageType(*back), messageType(message));
    EXPECT_TRUE(*back == message) << messageTypeName(messageType(message)) << " changed in the round trip";
    EXPECT_EQ(encodeMessage(*back), bytes);
  }
}

TEST(StreamProtocol, HeaderIsLittleEndianWithVersionTypeAndLength) {
  std::vector<uint8_t> bytes = encodeMessage(Close{CloseCode::Normal, "bye"});
  ASSERT_EQ(bytes.size(), kMessageHeaderBytes + 2 + 2 + 3);
  EXPECT_EQ(bytes[4] | (bytes[5] << 8), kProtocolVersion);
  EXPECT_EQ(bytes[6] | (bytes[7] << 8), int(MessageType::Close));
  EXPECT_EQ(bytes[8] | (bytes[9] << 8), 7);
  EXPECT_EQ(bytes[10] | bytes[11], 0);
}

TEST(StreamProtocol, EveryTruncationIsRejected) {
  for (const Message& message : sampleMessages()) {
    std::vector<uint8_t> bytes = encodeMessage(message);
    for (size_t n = 0; n < bytes.size(); ++n) {
      std::vector<uint8_t> prefix(bytes.begin(), bytes.begin() + ptrdiff_t(n));
      EXPECT_FALSE(decode(prefix).ok()) << messageTypeName(messageType(message)) << " cut to " << n << " bytes";
      // With the header's length made to match, the payload reader itself must find the cut.
      if (n >= kMessageHeaderBytes) {
        setPayloadLength(prefix);
        Result<Message> cut = decode(prefix);
        EXPECT_FALSE(cut.ok()) << messageTypeName(messageType(message)) << " payload cut to " << n << " bytes";
        if (!cut.ok()) {
          EXPECT_EQ(cut.error().message.find('\n'), std::string::npos);
        }
      }
    }
  }
}

TEST(StreamProtocol, TrailingBytesAreRejected) {
  std::vector<uint8_t> bytes = encodeMessage(sampleMessages()[2]);
  bytes.push_back(0);
  expectError(decode(bytes), "header length");
  setPayloadLength(bytes);
  expectError(decode(bytes), "Pose: 1 bytes after the last field");
}

TEST(StreamProtocol, HeaderChecks) {
  std::vector<uint8_t> bytes = encodeMessage(Close{});
  std::vector<uint8_t> badMagic = bytes;
  badMagic[0] = 'X';
  expectError(decode(badMagic), "magic");
  std::vector<uint8_t> badVersion = bytes;
  badVersion[4] = 1; // the float32 positions of version 1
  expectError(decode(badVersion), "protocol version 1, this build speaks version 3");
  std::vector<uint8_t> badType = bytes;
  badType[6] = 9;
  expectError(decode(badType), "unknown message type 9");
  badType[6] = 0;
  expectError(decode(badType), "unknown message type 0");
}

TEST(StreamProtocol, OversizedMessagesAndCountsAreRejected) {
  std::vector<uint8_t> frame = encodeMessage(sampleFrame());
  DecodeLimits small;
  small.maxMessageBytes = uint32_t(frame.size() - 1);
  expectError(decode(frame, small), "over the limit");

  // Counts in the patch section: docs/stream.md's patch section tests (patch_section_test.cpp) forge them.
  DecodeLimits fewPatches;
  fewPatches.maxPatchesPerFrame = 3;
  expectError(decode(frame, fewPatches), "Frame: updated count 8 over the limit of 3");
  DecodeLimits fewColours;
  fewColours.maxColoursPerFrame = 1;
  expectError(decode(frame, fewColours), "colours count 3 over the limit of 1");
  DecodeLimits fewRemoved;
  fewRemoved.maxRemovedPerFrame = 2;
  expectError(decode(frame, fewRemoved), "Frame: removed count 4 over the limit of 2");
  DecodeLimits shortToken;
  shortToken.maxTokenBytes = 4;
  expectError(decode(encodeMessage(sampleMessages()[0]), shortToken), "Hello: token length 12 over the limit of 4");
  DecodeLimits smallAtlas;
  smallAtlas.maxAtlasSide = 256;
  expectError(decode(frame, smallAtlas), "outside the atlas side 256");
}

TEST(StreamProtocol, FieldChecksNameTypeAndField) {
  Frame frame = sampleFrame();
  frame.updated[1].triangleCount = 0;
  expectError(decode(encodeMessage(frame)), "Frame: updated[1].triangleCount 0 not in 1..3");
  frame = sampleFrame();
  frame.updated[0].blockLog2 = 8;
  frame.updated[0].blockX = frame.updated[0].blockY = 0;
  expectError(decode(encodeMessage(frame)), "Frame: updated[0].blockLog2 8 not in 1..7");
  frame = sampleFrame();
  frame.atlas.bytes.clear();
  expectError(decode(encodeMessage(frame)), "Frame: atlas.byteCount 0");

  Pose pose = std::get<Pose>(sampleMessages()[2]);
  pose.predicted.fovY = 3.5f;
  expectError(decode(encodeMessage(pose)), "Pose: predicted.fovY");
  pose = std::get<Pose>(sampleMessages()[2]);
  pose.camera.eye.x = std::numeric_limits<float>::infinity();
  expectError(decode(encodeMessage(pose)), "Pose: camera.eye.x: not a finite number");
  pose = std::get<Pose>(sampleMessages()[2]);
  pose.viewportWidth = 0;
  expectError(decode(encodeMessage(pose)), "Pose: viewportWidth 0");

  Hello hello = std::get<Hello>(sampleMessages()[0]);
  hello.capabilities = 1u << 7;
  expectError(decode(encodeMessage(hello)), "Hello: capabilities has unknown bits");
  Welcome welcome = std::get<Welcome>(sampleMessages()[1]);
  welcome.codec = AtlasCodec::None;
  expectError(decode(encodeMessage(welcome)), "Welcome: codec 0");
  welcome = std::get<Welcome>(sampleMessages()[1]);
  welcome.positionStep = 0.0f;
  expectError(decode(encodeMessage(welcome)), "Welcome: positionStep 0.000000 not above 0");
  welcome.positionStep = std::numeric_limits<float>::quiet_NaN();
  expectError(decode(encodeMessage(welcome)), "Welcome: positionStep: not a finite number");
  welcome.positionStep = 20.0f / float(kPositionGridMax) * 0.99f; // 20 wide: the grid ends short of it
  expectError(decode(encodeMessage(welcome)), "the grid does not span the scene bounds");
  std::vector<uint8_t> close = encodeMessage(Close{CloseCode::Normal, ""});
  close[kMessageHeaderBytes] = 200;
  expectError(decode(close), "Close: code 200");
}

TEST(StreamProtocol, ClientOrder) {
  Hello hello{"t", kCapabilityZstdTiles, 64, 64, false};
  Pose pose = std::get<Pose>(sampleMessages()[2]);
  ClientMessageOrder order;
  pose.sequence = 5;
  EXPECT_FALSE(acceptClientMessage(order, pose, "c").ok()) << "Pose before Hello";
  ClientMessageOrder fresh;
  ASSERT_TRUE(acceptClientMessage(fresh, hello, "c").ok());
  Status second = acceptClientMessage(fresh, hello, "c");
  ASSERT_FALSE(second.ok());
  EXPECT_NE(second.error().message.find("second Hello"), std::string::npos);
  EXPECT_TRUE(acceptClientMessage(fresh, pose, "c").ok());
  Status same = acceptClientMessage(fresh, pose, "c");
  ASSERT_FALSE(same.ok());
  EXPECT_NE(same.error().message.find("Pose sequence 5 not above the previous 5"), std::string::npos);
  pose.sequence = 4;
  EXPECT_FALSE(acceptClientMessage(fresh, pose, "c").ok());
  pose.sequence = 6;
  EXPECT_TRUE(acceptClientMessage(fresh, pose, "c").ok());
  EXPECT_FALSE(acceptClientMessage(fresh, sampleFrame(), "c").ok()) << "a server message from a client";
  EXPECT_TRUE(acceptClientMessage(fresh, Close{}, "c").ok());
}
