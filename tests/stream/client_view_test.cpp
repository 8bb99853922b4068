// The client's patch state (StreamView; docs/stream.md, "Patch section"): positions on the grid,
// block-only entries for held and kept patches, the keep window, and the errors of a frame that
// refers to geometry the client does not have.
#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/core/image_metrics.h"
#include "mirage/stream/client_view.h"

namespace mirage::stream {
namespace {

Welcome testWelcome() {
  Welcome w;
  w.sceneMin = {-1.0f, -1.0f, -1.0f};
  w.sceneMax = {1.0f, 1.0f, 1.0f};
  w.positionStep = positionGridStep(w.sceneMin, w.sceneMax, 16);
  w.atlasWidth = w.atlasHeight = 128;
  w.codec = AtlasCodec::ZstdTiles;
  w.patchCount = 100;
  return w;
}

// A quad facing +z at depth z, `id`, 2 triangles, at block (blockX, 0) of log2 5 (or colour-only).
PatchUpdate quad(const Welcome& w, uint32_t id, float x, float z, uint8_t log2, uint16_t blockX) {
  PatchUpdate p;
  p.id = id;
  p.triangleCount = 2;
  glm::vec3 corners[4] = {{x, -0.4f, z}, {x + 0.8f, -0.4f, z}, {x, 0.4f, z}, {x + 0.8f, 0.4f, z}};
  for (int v = 0; v < 4; ++v) p.positions[v] = quantizePosition(corners[v], w.sceneMin, w.positionStep);
  p.blockLog2 = log2;
  p.blockX = log2 == kColourOnlyBlock ? 0 : blockX;
  return p;
}

PatchUpdate blockOnlyOf(PatchUpdate p, uint8_t log2, uint16_t blockX) {
  p.geometry = false;
  p.positions = {};
  p.alpha = stream::AlphaMode::Opaque;
  p.blockLog2 = log2;
  p.blockX = log2 == kColourOnlyBlock ? 0 : blockX;
  p.blockY = 0;
  return p;
}

Frame frameOf(std::vector<uint32_t> removed, std::vector<PatchUpdate> updated, std::vector<PatchColour> colours = {}) {
  static uint32_t sequence = 0;
  Frame f;
  f.sequence = ++sequence;
  f.removed = std::move(removed);
  f.updated = std::move(updated);
  f.colours = std::move(colours);
  return f;
}

// A 128 x 128 atlas: block (0, 0) red, block (32, 0) green, the rest blue.
ImageRGBA8 testAtlas() {
  ImageRGBA8 atlas{128, 128, std::vector<uint8_t>(128 * 128 * 4, 0)};
  for (uint32_t y = 0; y < 128; ++y)
    for (uint32_t x = 0; x < 128; ++x) {
      uint8_t* t = atlas.at(x, y);
      t[0] = x < 32 && y < 32 ? 255 : 0;
      t[1] = x >= 32 && x < 64 && y < 32 ? 255 : 0;
      t[2] = t[0] == 0 && t[1] == 0 ? 255 : 0;
      t[3] = 255;
    }
  return atlas;
}

ImageRGBA8 draw(StreamView& view) {
  render::Camera camera;
  camera.eye = {0.0f, 0.0f, 3.0f};
  camera.target = {0.0f, 0.0f, 0.0f};
  camera.fovYDegrees = 60.0f;
  auto out = view.render(camera, 96, 64);
  EXPECT_TRUE(out) << out.error().message;
  return out ? out->srgb : ImageRGBA8{};
}

} // namespace

class StreamViewState : public test::GpuTest {};

namespace {

TEST_F(StreamViewState, BlockOnlyEntriesReuseHeldAndKeptGeometry) {
  Welcome w = testWelcome();
  PatchUpdate a = quad(w, 1, -0.9f, 0.0f, 5, 0), b = quad(w, 2, 0.1f, 0.2f, kColourOnlyBlock, 0);
  // Directly: a at the green block, b colour-only in yellow.
  auto direct = StreamView::create(context(), w);
  ASSERT_TRUE(direct) << direct.error().message;
  ASSERT_TRUE((*direct)->renderer().updateAtlas(testAtlas()));
  PatchUpdate aGreen = a;
  aGreen.blockX = 32;
  ASSERT_TRUE((*direct)->apply(frameOf({}, {aGreen, b}, {{2, {255, 255, 0, 255}}})));
  ImageRGBA8 expected = draw(**direct);

  // Through the state: a red, then moved to green (held); b removed, then back within the window (kept).
  auto view = StreamView::create(context(), w);
  ASSERT_TRUE(view) << view.error().message;
  ASSERT_TRUE((*view)->renderer().updateAtlas(testAtlas()));
  ASSERT_TRUE((*view)->apply(frameOf({}, {a, b}, {{2, {255, 0, 255, 255}}})));
  ImageRGBA8 first = draw(**view);
  EXPECT_LT(psnr(first, expected), 30.0) << "red and magenta differ from green and yellow";
  ASSERT_TRUE((*view)->apply(frameOf({2}, {blockOnlyOf(a, 5, 32)})));
  EXPECT_EQ((*view)->patchCount(), 1u);
  EXPECT_EQ((*view)->keptCount(), 1u);
  for (int i = 0; i < 10; ++i) ASSERT_TRUE((*view)->apply(frameOf({}, {})));
  ASSERT_TRUE((*view)->apply(frameOf({}, {blockOnlyOf(b, kColourOnlyBlock, 0)}, {{2, {255, 255, 0, 255}}})));
  EXPECT_EQ((*view)->patchCount(), 2u);
  EXPECT_EQ((*view)->keptCount(), 0u);
  ImageRGBA8 state = draw(**view);
  EXPECT_GE(psnr(state, expected), 99.0) << "the same patches, blocks and colours as sent directly";
}

TEST_F(StreamViewState, FramesReferringToMissingGeometryAreErrors) {
  Welcome w = testWelcome();
  PatchUpdate a = quad(w, 1, -0.9f, 0.0f, 5, 0);
  auto fresh = [&] {
    auto v = StreamView::create(context(), w);
    EXPECT_TRUE(v) << v.error().message;
    return std::move(*v);
  };
  auto expectError = [](const Status& s, const std::string& part) {
    ASSERT_FALSE(s) << "accepted, expected an error with '" << part << "'";
    EXPECT_NE(s.error().message.find(part), std::string::npos) << s.error().message;
  };
  auto v = fresh();
  expectError(v->apply(frameOf({}, {blockOnlyOf(a, 5, 32)})),
              "block-only entry for patch 1, whose geometry the client does not have");
  v = fresh();
  ASSERT_TRUE(v->apply(frameOf({}, {a})));
  expectError(v->apply(frameOf({}, {a})), "sends the positions of patch 1, which the client holds");
  v = fresh();
  ASSERT_TRUE(v->apply(frameOf({}, {a})));
  PatchUpdate wrong = blockOnlyOf(a, 5, 32);
  wrong.triangleCount = 3;
  expectError(v->apply(frameOf({}, {wrong})), "patch 1 has 2 triangles, the entry says 3");
  expectError(v->apply(frameOf({7}, {})), "removes patch 7, which the client does not hold");
  PatchUpdate far = a;
  far.id = 100;
  expectError(v->apply(frameOf({}, {far})), "patch 100 is past the scene's 100 patches");
  expectError(v->apply(frameOf({}, {}, {{1, {1, 2, 3, 4}}})), "colour for patch 1");

  // The keep window: a removal in frame n answers block-only entries through frame n + K - 1.
  for (uint32_t lastFrame : {kKeptGeometryFrames - 1, kKeptGeometryFrames}) {
    v = fresh();
    ASSERT_TRUE(v->apply(frameOf({}, {a})));
    ASSERT_TRUE(v->apply(frameOf({1}, {}))); // frame 2
    for (uint32_t f = 3; f < 2 + lastFrame; ++f) ASSERT_TRUE(v->apply(frameOf({}, {})));
    Status back = v->apply(frameOf({}, {blockOnlyOf(a, 5, 0)})); // frame 2 + lastFrame
    if (lastFrame < kKeptGeometryFrames)
      EXPECT_TRUE(back) << back.error().message;
    else
      expectError(back, "block-only entry for patch 1");
  }
}

} // namespace
} // namespace mirage::stream
