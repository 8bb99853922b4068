// The thin client's renderer (render/atlas_client.h, docs/stream.md, "The client's renderer") on lavapipe: a patch's
// atlas block lands where and how the shared layout (shaderio/atlas.h) says, against a CPU ray cast
// and bilinear sample of the same atlas; colour-only patches, removal, MASK, BLEND over and behind
// opaque patches, thousands of patches set, updated and removed between frames, atlas regions
// queued in order, frames in flight, bad input. Validation stays silent.
#include <cmath>
#include <optional>

#include <gtest/gtest.h>

#include <glm/gtc/packing.hpp>

#include "gpu_test.h"
#include "mirage/core/color.h"
#include "mirage/render/atlas_client.h"
#include "mirage/render/camera.h"
#include "mirage/shaderio/atlas.h"

using namespace mirage;
using namespace mirage::render;
namespace sio = mirage::shaderio;

namespace {

constexpr uint32_t kClientViewSize = 64; // rendered image
constexpr uint32_t kAtlas = 64;          // atlas texels

Camera frontCamera(float distance = 3.0f) {
  Camera c;
  c.eye = {0.0f, 0.0f, distance};
  c.target = {0.0f, 0.0f, 0.0f};
  c.fovYDegrees = 60.0f;
  c.znear = 0.1f;
  c.zfar = 20.0f;
  return c;
}

AtlasClientSettings clientSettings(Camera camera = frontCamera()) {
  AtlasClientSettings s;
  s.width = s.height = kClientViewSize;
  s.camera = camera;
  return s;
}

std::unique_ptr<AtlasClientRenderer> makeClient(gpu::Context& ctx, uint32_t maxPatches = 64) {
  auto r = AtlasClientRenderer::create(ctx, {kAtlas, kAtlas, maxPatches});
  EXPECT_TRUE(r) << r.error().message;
  return r ? std::move(r).value() : nullptr;
}

uint32_t rgba(uint8_t r, uint8_t g, uint8_t b, uint8_t a = 255) {
  return uint32_t(r) | uint32_t(g) << 8 | uint32_t(b) << 16 | uint32_t(a) << 24;
}

// A quad in the plane z (a..d as shaderio/atlas.h draws them: a bottom left, d top right).
ClientPatch quad(float halfSize, float z, uint32_t color, PatchAlpha alpha = PatchAlpha::Opaque,
                 glm::vec2 center = glm::vec2(0.0f)) {
  ClientPatch p;
  p.triangleCount = 2;
  p.positions[MIRAGE_PATCH_A] = {center.x - halfSize, center.y - halfSize, z};
  p.positions[MIRAGE_PATCH_B] = {center.x + halfSize, center.y - halfSize, z};
  p.positions[MIRAGE_PATCH_C] = {center.x - halfSize, center.y + halfSize, z};
  p.positions[MIRAGE_PATCH_D] = {center.x + halfSize, center.y + halfSize, z};
  p.alpha = alpha;
  p.colorOnly = true;
  p.color = color;
  return p;
}

// The pixel's ray (through its centre) meets the plane z = 0 at this point.
glm::vec2 pixelOnPlane(const Camera& camera, uint32_t px, uint32_t py) {
  sio::ViewFrame f = viewFrame(camera, kClientViewSize, kClientViewSize);
  glm::vec2 ndc{(float(px) + 0.5f) / float(kClientViewSize) * 2.0f - 1.0f,
                (float(py) + 0.5f) / float(kClientViewSize) * 2.0f - 1.0f};
  glm::vec4 nearP = f.invViewProj * glm::vec4(ndc, 1.0f, 1.0f), farP = f.invViewProj * glm::vec4(ndc, 0.5f, 1.0f);
  glm::vec3 a = glm::vec3(nearP) / nearP.w, b = glm::vec3(farP) / farP.w;
  float t = a.z / (a.z - b.z);
  return glm::vec2(a + (b - a) * t);
}

// Where point q (in the patch's plane z = 0) samples the atlas: barycentric interpolation of the
// texel positions of the corners (atlasCornerTexel) of the patch's triangle holding q.
std::optional<glm::vec2> atlasPosition(const ClientPatch& p, glm::vec2 q) {
  for (uint32_t t = 0; t < p.triangleCount; ++t) {
    uint32_t v[3] = {sio::atlasTriangleVertex(t, 0), sio::atlasTriangleVertex(t, 1), sio::atlasTriangleVertex(t, 2)};
    glm::vec2 a = p.positions[v[0]], b = p.positions[v[1]], c = p.positions[v[2]];
    float area = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
    float wb = ((q.x - a.x) * (c.y - a.y) - (c.x - a.x) * (q.y - a.y)) / area;
    float wc = ((b.x - a.x) * (q.y - a.y) - (q.x - a.x) * (b.y - a.y)) / area;
    float wa = 1.0f - wb - wc;
    if (wa < -1e-5f || wb < -1e-5f || wc < -1e-5f) continue;
    glm::vec2 block(float(p.blockX), float(p.blockY));
    return block + wa * sio::atlasCornerTexel(v[0], p.blockLog2) + wb * sio::atlasCornerTexel(v[1], p.blockLog2) +
           wc * sio::atlasCornerTexel(v[2], p.blockLog2);
  }
  return std::nullopt;
}

// Bilinear sample of the sRGB atlas at texel position pos (texel centres at .5), filtered in linear.
glm::vec3 sampleAtlas(const ImageRGBA8& atlas, glm::vec2 pos) {
  glm::vec2 f = pos - 0.5f;
  glm::ivec2 i0 = glm::ivec2(glm::floor(f));
  glm::vec2 w = f - glm::vec2(i0);
  auto texel = [&](int x, int y) {
    x = std::clamp(x, 0, int(atlas.width) - 1), y = std::clamp(y, 0, int(atlas.height) - 1);
    const uint8_t* t = atlas.at(uint32_t(x), uint32_t(y));
    return glm::vec3(srgb8ToLinear(t[0]), srgb8ToLinear(t[1]), srgb8ToLinear(t[2]));
  };
  return glm::mix(glm::mix(texel(i0.x, i0.y), texel(i0.x + 1, i0.y), w.x),
                  glm::mix(texel(i0.x, i0.y + 1), texel(i0.x + 1, i0.y + 1), w.x), w.y);
}

// An atlas whose every texel differs from its neighbours (a bleed, shift or flip shows): red and
// green gradients along x and y, blue in a 4-texel checker.
ImageRGBA8 patternAtlas() {
  ImageRGBA8 img{kAtlas, kAtlas, std::vector<uint8_t>(kAtlas * kAtlas * 4)};
  for (uint32_t y = 0; y < kAtlas; ++y)
    for (uint32_t x = 0; x < kAtlas; ++x) {
      uint8_t* t = img.at(x, y);
      t[0] = uint8_t(x * 4);
      t[1] = uint8_t(y * 4);
      t[2] = uint8_t((x / 4 + y / 4) % 2 ? 230 : 30);
      t[3] = 255;
    }
  return img;
}

uint8_t channel(const RenderOutput& out, uint32_t x, uint32_t y, int c) { return out.srgb.at(x, y)[c]; }

void expectPixel(const RenderOutput& out, uint32_t x, uint32_t y, glm::vec3 linear, int tolerance = 1) {
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(int(channel(out, x, y, c)), int(linearToSrgb8(linear[c])), tolerance)
        << "pixel (" << x << ", " << y << ") channel " << c;
}

glm::vec3 decode(uint32_t color) {
  return {srgb8ToLinear(uint8_t(color)), srgb8ToLinear(uint8_t(color >> 8)), srgb8ToLinear(uint8_t(color >> 16))};
}

glm::vec3 background() { return glm::vec3(AtlasClientSettings{}.background); }

// Renders patch p (a block of patternAtlas in the plane z = 0) and compares every pixel well inside
// it with the CPU's ray cast + bilinear sample (PSNR over those pixels), and every pixel well
// outside with the background. Pixels within 2 pixels of its outline are left out (coverage).
void expectPatchMatchesCpu(gpu::Context& ctx, const ClientPatch& p) {
  auto client = makeClient(ctx);
  ASSERT_TRUE(client);
  ImageRGBA8 atlas = patternAtlas();
  ASSERT_TRUE(client->updateAtlas(atlas));
  ASSERT_TRUE(client->setPatch(7, p));
  Camera cam = frontCamera();
  auto out = client->render(clientSettings(cam));
  ASSERT_TRUE(out) << out.error().message;
  const float pixel =
      2.0f * 3.0f * std::tan(glm::radians(30.0f)) / float(kClientViewSize); // world size of a pixel at z = 0
  double squared = 0.0;
  uint32_t inside = 0, outside = 0;
  for (uint32_t y = 0; y < kClientViewSize; ++y)
    for (uint32_t x = 0; x < kClientViewSize; ++x) {
      glm::vec2 q = pixelOnPlane(cam, x, y);
      int hits = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) hits += atlasPosition(p, q + 2.0f * pixel * glm::vec2(dx, dy)).has_value();
      if (hits == 0) {
        expectPixel(*out, x, y, background());
        ++outside;
      } else if (hits == 9) {
        glm::vec3 expected = sampleAtlas(atlas, *atlasPosition(p, q));
        for (int c = 0; c < 3; ++c) {
          double e = double(channel(*out, x, y, c)) - double(linearToSrgb8(expected[c]));
          squared += e * e;
        }
        ++inside;
      }
    }
  ASSERT_GT(inside, 200u);
  ASSERT_GT(outside, 200u);
  double mse = squared / (3.0 * inside);
  double psnr = mse == 0.0 ? 99.0 : 10.0 * std::log10(255.0 * 255.0 / mse);
  EXPECT_GE(psnr, 40.0) << inside << " pixels compared";
}

} // namespace

class AtlasClientTest : public test::GpuTest {};

namespace {

TEST_F(AtlasClientTest, QuadBlockRendersItsTexelsInPlace) {
  ClientPatch p = quad(1.0f, 0.0f, 0);
  p.colorOnly = false;
  p.blockX = 16, p.blockY = 8, p.blockLog2 = 4; // 16 x 16 texels
  expectPatchMatchesCpu(context(), p);
}

TEST_F(AtlasClientTest, WideBlockOfThreeTrianglesRendersItsTexelsInPlace) {
  ClientPatch p = quad(0.7f, 0.0f, 0, PatchAlpha::Opaque, {-0.5f, 0.0f});
  p.triangleCount = 3;
  p.positions[MIRAGE_PATCH_E] = {1.6f, -0.7f, 0.0f}; // t2 = (b, e, d), a different shape than t0/t1
  p.colorOnly = false;
  p.blockX = 6, p.blockY = 40, p.blockLog2 = 3; // 16 x 8 texels
  expectPatchMatchesCpu(context(), p);
}

TEST_F(AtlasClientTest, ColorOnlyPatchesTakeTheirColourAndRemovalRemovesThem) {
  auto client = makeClient(context());
  ASSERT_TRUE(client);
  uint32_t red = rgba(220, 40, 90), masked = rgba(40, 200, 40, 0);
  ASSERT_TRUE(client->setPatch(1, quad(0.5f, 0.0f, red, PatchAlpha::Opaque, {-0.8f, 0.0f})));
  ASSERT_TRUE(client->setPatch(2, quad(0.5f, 0.0f, masked, PatchAlpha::Mask, {0.8f, 0.0f}))); // alpha 0: cut
  EXPECT_EQ(client->patchCount(), 2u);
  auto out = client->render(clientSettings());
  ASSERT_TRUE(out) << out.error().message;
  // x = -0.8 is about pixel 17, x = 0.8 pixel 46 (pixel 32 is x = 0), x = 0 the gap between them.
  expectPixel(*out, 17, 32, decode(red));
  expectPixel(*out, 46, 32, background());
  expectPixel(*out, 32, 32, background());
  EXPECT_EQ(out->stats.trianglesSubmitted, 4u);

  ASSERT_TRUE(client->setPatch(2, quad(0.5f, 0.0f, masked | 0xff000000u, PatchAlpha::Mask, {0.8f, 0.0f})));
  ASSERT_TRUE(client->removePatch(1));
  EXPECT_EQ(client->patchCount(), 1u);
  out = client->render(clientSettings());
  ASSERT_TRUE(out) << out.error().message;
  expectPixel(*out, 17, 32, background());
  expectPixel(*out, 46, 32, decode(masked));
  EXPECT_FALSE(client->removePatch(1)); // already gone
}

TEST_F(AtlasClientTest, BlendPatchCompositesOverOpaqueInFrontAndIsHiddenBehind) {
  auto client = makeClient(context());
  ASSERT_TRUE(client);
  uint32_t green = rgba(30, 200, 60), glass = rgba(230, 30, 20, 128);
  float a = 128.0f / 255.0f;
  ASSERT_TRUE(client->setPatch(10, quad(0.6f, 0.0f, green)));
  ASSERT_TRUE(client->setPatch(11, quad(1.3f, 0.5f, glass, PatchAlpha::Blend))); // in front, wider
  auto out = client->render(clientSettings());
  ASSERT_TRUE(out) << out.error().message;
  expectPixel(*out, 32, 32, glm::mix(decode(green), decode(glass), a), 2);
  expectPixel(*out, 32, 14, glm::mix(background(), decode(glass), a), 2); // beyond the opaque quad
  EXPECT_GT(out->stats.oit.fragments, 0u);

  ASSERT_TRUE(client->setPatch(11, quad(1.3f, -0.5f, glass, PatchAlpha::Blend))); // now behind it
  out = client->render(clientSettings());
  ASSERT_TRUE(out) << out.error().message;
  expectPixel(*out, 32, 32, decode(green));
  // Beyond the opaque quad the glass still shows (wider than it, and farther: 3.5 vs 3 away).
  glm::vec2 q = pixelOnPlane(frontCamera(3.5f), 32, 14);
  ASSERT_LT(std::abs(q.y), 1.3f - 0.1f);
  expectPixel(*out, 32, 14, glm::mix(background(), decode(glass), a), 2);
}

// 4096 patches tiling [-1, 1]^2 (64 x 64 cells, one colour each) set, all recoloured, half removed
// and the freed slots refilled under new ids, one frame after each batch.
TEST_F(AtlasClientTest, ThousandsOfPatchesUpdateBetweenFrames) {
  constexpr uint32_t kCells = 64;
  auto client = makeClient(context(), kCells * kCells);
  ASSERT_TRUE(client);
  auto cellQuad = [&](uint32_t i, uint32_t color) {
    float half = 1.0f / float(kCells);
    glm::vec2 c{-1.0f + (2.0f * float(i % kCells) + 1.0f) * half, -1.0f + (2.0f * float(i / kCells) + 1.0f) * half};
    return quad(half, 0.0f, color, PatchAlpha::Opaque, c);
  };
  auto colorOf = [](uint32_t i, uint32_t round) {
    return rgba(uint8_t(i * 4 + round * 50), uint8_t((i / kCells) * 4), uint8_t(round * 100 + 20));
  };
  Camera cam = frontCamera(2.5f);
  // The frame's pixels well inside one cell: that cell's colour, or the background when absent.
  auto check = [&](const std::function<std::optional<uint32_t>(uint32_t)>& expected) {
    auto out = client->render(clientSettings(cam));
    ASSERT_TRUE(out) << out.error().message;
    uint32_t checked = 0;
    for (uint32_t y = 0; y < kClientViewSize; ++y)
      for (uint32_t x = 0; x < kClientViewSize; ++x) {
        glm::vec2 q = (pixelOnPlane(cam, x, y) + 1.0f) * 0.5f * float(kCells);
        glm::vec2 f = glm::fract(q);
        if (q.x < 0.0f || q.y < 0.0f || q.x >= kCells || q.y >= kCells || glm::any(glm::lessThan(f, glm::vec2(0.3f))) ||
            glm::any(glm::greaterThan(f, glm::vec2(0.7f))))
          continue;
        std::optional<uint32_t> color = expected(uint32_t(q.y) * kCells + uint32_t(q.x));
        expectPixel(*out, x, y, color ? decode(*color) : background());
        ++checked;
      }
    EXPECT_GT(checked, 150u);
  };
  for (uint32_t i = 0; i < kCells * kCells; ++i) ASSERT_TRUE(client->setPatch(1000 + i, cellQuad(i, colorOf(i, 0))));
  check([&](uint32_t i) { return colorOf(i, 0); });
  EXPECT_FALSE(client->setPatch(1, cellQuad(0, 0))) << "every slot is in use";
  for (uint32_t i = 0; i < kCells * kCells; ++i) ASSERT_TRUE(client->setPatch(1000 + i, cellQuad(i, colorOf(i, 1))));
  for (uint32_t i = 1; i < kCells * kCells; i += 2) ASSERT_TRUE(client->removePatch(1000 + i));
  check([&](uint32_t i) { return i % 2 ? std::nullopt : std::optional(colorOf(i, 1)); });
  for (uint32_t i = 1; i < kCells * kCells; i += 4)
    ASSERT_TRUE(client->setPatch(90000 + i, cellQuad(i, colorOf(i, 2))));
  check([&](uint32_t i) {
    return i % 4 == 1 ? std::optional(colorOf(i, 2)) : i % 2 ? std::nullopt : std::optional(colorOf(i, 1));
  });
  EXPECT_EQ(client->patchCount(), kCells * kCells / 2 + kCells * kCells / 4);
}

// Regions queued before one frame apply in order: the later one wins where they overlap.
TEST_F(AtlasClientTest, AtlasRegionsApplyInOrder) {
  auto client = makeClient(context());
  ASSERT_TRUE(client);
  ClientPatch p = quad(1.0f, 0.0f, 0);
  p.colorOnly = false;
  p.blockX = 32, p.blockY = 32, p.blockLog2 = 3; // 8 x 8
  ASSERT_TRUE(client->setPatch(3, p));
  auto solid = [](uint32_t w, uint32_t h, uint32_t color) {
    std::vector<uint8_t> t(size_t(w) * h * 4);
    for (size_t i = 0; i < t.size(); i += 4) std::memcpy(&t[i], &color, 4);
    return t;
  };
  uint32_t blue = rgba(20, 40, 220), yellow = rgba(240, 220, 30);
  std::vector<uint8_t> all = solid(8, 8, blue), corner = solid(4, 4, yellow);
  ASSERT_TRUE(client->updateAtlasRegion(32, 32, 8, 8, all.data()));
  ASSERT_TRUE(client->updateAtlasRegion(32, 32, 4, 4, corner.data())); // texels (0..3, 0..3): around vertex a
  auto out = client->render(clientSettings());
  ASSERT_TRUE(out) << out.error().message;
  // Vertex a is the bottom left on screen (world -1, -1); d the top right.
  expectPixel(*out, 17, 46, decode(yellow));
  expectPixel(*out, 46, 17, decode(blue));
  // An untouched atlas is black: a patch on a block never uploaded.
  p.blockX = 0, p.blockY = 0;
  ASSERT_TRUE(client->setPatch(3, p));
  out = client->render(clientSettings());
  ASSERT_TRUE(out) << out.error().message;
  expectPixel(*out, 32, 32, glm::vec3(0.0f));
}

// Three frames recorded before any completes (the first gated until all were submitted: a record
// that waited for the device would hang), each after a change of the patch: each frame shows its own.
TEST_F(AtlasClientTest, FramesInFlightEachShowTheirPatches) {
  auto client = makeClient(context());
  ASSERT_TRUE(client);
  const uint32_t colors[3] = {rgba(200, 30, 30), rgba(30, 200, 30), rgba(30, 30, 200)};
  const VkExtent2D sizes[3] = {
      {kClientViewSize, kClientViewSize}, {kClientViewSize, kClientViewSize}, {kClientViewSize, kClientViewSize}};
  auto pixels = test::recordFramesInFlight(
      context(), sizes,
      [&](VkCommandBuffer cmd, uint32_t slot, const gpu::Image*& color) -> Status {
        if (Status st = client->setPatch(5, quad(0.5f, 0.0f, colors[slot])); !st) return st;
        if (Status st = client->record(cmd, clientSettings(), slot); !st) return st;
        color = &client->colorTarget();
        return Ok{};
      },
      /*gateFirstFrame=*/true);
  ASSERT_EQ(pixels.size(), 3u);
  for (uint32_t slot = 0; slot < 3; ++slot) {
    const uint16_t* px = &pixels[slot][(size_t(32) * kClientViewSize + 32) * 4];
    glm::vec3 expected = decode(colors[slot]);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(glm::unpackHalf1x16(px[c]), expected[c], 0.01f) << "slot " << slot;
    auto stats = client->collect(slot);
    EXPECT_TRUE(stats) << stats.error().message;
  }
  EXPECT_FALSE(client->collect(0)) << "collected twice";
}

TEST_F(AtlasClientTest, BadInputIsAnErrorThatChangesNothing) {
  EXPECT_FALSE(AtlasClientRenderer::create(context(), {0, 64, 16}));
  EXPECT_FALSE(AtlasClientRenderer::create(context(), {64, 64, 0}));
  auto client = makeClient(context(), 2);
  ASSERT_TRUE(client);
  ClientPatch p = quad(1.0f, 0.0f, 0);
  p.colorOnly = false;
  p.blockLog2 = 3;
  p.triangleCount = 0;
  auto err = client->setPatch(1, p);
  ASSERT_FALSE(err);
  EXPECT_NE(err.error().message.find("patch 1"), std::string::npos) << err.error().message;
  p.triangleCount = 4;
  EXPECT_FALSE(client->setPatch(1, p));
  p.triangleCount = 3; // 16 x 8 at x = 56: past the 64-texel atlas
  p.blockX = 56;
  EXPECT_FALSE(client->setPatch(1, p));
  p.triangleCount = 2, p.blockX = 0, p.blockLog2 = 0;
  EXPECT_FALSE(client->setPatch(1, p));
  p.blockLog2 = 3, p.positions[MIRAGE_PATCH_B].x = NAN;
  EXPECT_FALSE(client->setPatch(1, p));
  EXPECT_EQ(client->patchCount(), 0u);
  EXPECT_FALSE(client->removePatch(1));
  EXPECT_FALSE(client->updateAtlas(ImageRGBA8{32, 32, std::vector<uint8_t>(32 * 32 * 4)}));
  std::vector<uint8_t> texels(16 * 16 * 4);
  EXPECT_FALSE(client->updateAtlasRegion(60, 0, 16, 16, texels.data()));
  EXPECT_FALSE(client->updateAtlasRegion(0, 0, 0, 16, texels.data()));
  AtlasClientSettings s = clientSettings();
  s.width = 0;
  EXPECT_FALSE(client->render(s));
  EXPECT_FALSE(client->collect(0));
  auto out = client->render(clientSettings()); // nothing was set: the background only
  ASSERT_TRUE(out) << out.error().message;
  expectPixel(*out, 32, 32, background());
}

} // namespace
