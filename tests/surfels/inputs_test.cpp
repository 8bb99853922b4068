// Sampler inputs beyond a plain mesh: a scanner's point cloud (PLY without faces), depth peeling
// (a box inside a box: only --layers 2 reaches the inner box), base-colour textures in the
// capture, and the per-mesh 'SURF' chunks (version 2, version 1 still read).
#include <algorithm>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>

#include "gpu_test.h"
#include "mirage/asset/container.h"
#include "mirage/io/import.h"
#include "mirage/surfels/capture.h"
#include "mirage/surfels/gpu_sampler.h"
#include "mirage/surfels/point_cloud.h"
#include "mirage/surfels/reference.h"
#include "mirage/surfels/surfel_io.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::surfels;
using mirage::test::GpuTest;

namespace {

// A scanner-like PLY: random points on the unit sphere, outward normals, red above y = 0 and
// blue below (sRGB uchar).
void writeSpherePly(const std::string& path, uint32_t count) {
  std::ofstream f(path, std::ios::binary);
  f << "ply\nformat binary_little_endian 1.0\nelement vertex " << count << "\n";
  for (const char* p : {"x", "y", "z", "nx", "ny", "nz"}) f << "property float " << p << "\n";
  for (const char* p : {"red", "green", "blue"}) f << "property uchar " << p << "\n";
  f << "end_header\n";
  std::mt19937 rng(11);
  std::normal_distribution<float> g;
  for (uint32_t i = 0; i < count; ++i) {
    glm::vec3 p = glm::normalize(glm::vec3(g(rng), g(rng), g(rng)));
    float v[6] = {p.x, p.y, p.z, p.x, p.y, p.z};
    uint8_t c[3] = {uint8_t(p.y > 0 ? 255 : 0), 0, uint8_t(p.y > 0 ? 0 : 255)};
    f.write(reinterpret_cast<const char*>(v), sizeof(v));
    f.write(reinterpret_cast<const char*>(c), sizeof(c));
  }
}

// An axis-aligned cube of half-size h around the origin: 6 faces, outward normals, CCW from outside.
void addCube(Scene& s, float h, uint32_t material) {
  Mesh m;
  m.name = "cube";
  m.material = material;
  for (int axis = 0; axis < 3; ++axis)
    for (float sign : {-1.0f, 1.0f}) {
      glm::vec3 n(0.0f);
      n[axis] = sign;
      glm::vec3 u(0.0f), v(0.0f);
      u[(axis + 1) % 3] = 1.0f;
      v[(axis + 2) % 3] = 1.0f;
      if (sign < 0) std::swap(u, v);
      uint32_t base = uint32_t(m.positions.size());
      for (glm::vec2 c : {glm::vec2(-1, -1), glm::vec2(1, -1), glm::vec2(1, 1), glm::vec2(-1, 1)}) {
        m.positions.push_back(h * (n + c.x * u + c.y * v));
        m.normals.push_back(n);
        m.uv0.push_back(c * 0.5f + 0.5f);
      }
      for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) m.indices.push_back(base + i);
    }
  for (glm::vec3 p : m.positions) m.bounds.add(p);
  s.meshes.push_back(std::move(m));
  s.instances.push_back({uint32_t(s.meshes.size() - 1), glm::mat4(1.0f)});
}

Scene boxInBox() {
  Scene s;
  s.source = "box in box";
  s.materials.resize(1);
  addCube(s, 1.0f, 0);
  addCube(s, 0.4f, 0);
  return s;
}

bool onInnerBox(glm::vec3 p) {
  float m = std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  return std::abs(m - 0.4f) < 0.05f;
}

uint8_t channel(uint32_t rgba, int c) { return uint8_t(rgba >> (8 * c)); }

} // namespace

class SurfelInputs : public GpuTest {};

TEST_F(SurfelInputs, PointCloudPlySamplesWithBlueNoiseAndKeepsColours) {
  auto dir = mirage::test::tempDir("surfels_points");
  std::string path = (dir / "sphere.ply").string();
  writeSpherePly(path, 40000);
  io::ImportOptions options;
  options.allowPointClouds = true;
  auto scene = io::importPly(path, options);
  EXPECT_FALSE(io::importPly(path).ok()); // meshes only by default
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  ASSERT_TRUE(isPointCloud(*scene));
  auto texels = pointCloudTexels(*scene);
  ASSERT_TRUE(texels.ok()) << texels.error().message;
  ASSERT_EQ(texels->size(), 40000u);
  EXPECT_NEAR(texels->totalArea, 4.0 * 3.14159265, 0.03 * 4.0 * 3.14159265); // the unit sphere's area

  SampleOrder order = farthestPointReference(*texels, 3000);
  ASSERT_EQ(order.texels.size(), 3000u);
  for (uint32_t n : {100u, 1000u, 3000u}) {
    PrefixQuality q = measurePrefix(*texels, order, n);
    std::printf("point cloud prefix %4u: rho %.3f coverage %.4f (A %.3f)\n", n, q.rho, q.coverage, texels->totalArea);
    EXPECT_GE(q.rho, 0.65) << n;
    EXPECT_GE(q.coverage, 0.999) << n;
  }
  SurfelCloud cloud = buildSurfelCloud(*texels, order);
  size_t checked = 0;
  for (const Surfel& s : cloud.surfels) {
    glm::vec3 p = surfelPosition(cloud.box, s);
    EXPECT_NEAR(glm::length(p), 1.0f, 1e-3f);
    EXPECT_GT(glm::dot(surfelNormal(s), p), 0.99f);
    if (std::abs(p.y) < 0.05f) continue; // points near the equator may carry either colour
    EXPECT_EQ(channel(s.color, 0), p.y > 0 ? 255 : 0);
    EXPECT_EQ(channel(s.color, 2), p.y > 0 ? 0 : 255);
    ++checked;
  }
  EXPECT_GT(checked, 2500u);
}

// The GPU path for scans: the same sphere cloud splatted as discs into 96² × 16 views, then the
// GPU sampler; quality against the exact CPU path on the points themselves.
TEST_F(SurfelInputs, PointCloudGpuCaptureSamplesLikeTheExactPath) {
  auto dir = mirage::test::tempDir("surfels_points_gpu");
  std::string path = (dir / "sphere.ply").string();
  writeSpherePly(path, 40000);
  io::ImportOptions options;
  options.allowPointClouds = true;
  auto scene = io::importPly(path, options);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  auto points = scanPoints(*scene);
  ASSERT_TRUE(points.ok()) << points.error().message;
  CaptureConfig capture;
  capture.resolution = 96;
  auto gb = capturePointCloud(context(), *points, capture);
  ASSERT_TRUE(gb.ok()) << gb.error().message;
  const GBufferTexels& t = gb->texels;
  // Discs cover the sphere's projection in every view (π / texel² texels, a few more at the rim),
  // and the deduplicated area is the sphere's.
  double perView = 3.14159265 / (double(t.texelSize) * t.texelSize);
  std::printf("GPU point capture: %zu texels (%.3f of the sphere's projections), A %.3f, texel %.4f\n", t.size(),
              double(t.size()) / (16 * perView), t.totalArea, t.texelSize);
  EXPECT_GT(double(t.size()), 0.99 * 16 * perView);
  EXPECT_LT(double(t.size()), 1.05 * 16 * perView);
  EXPECT_NEAR(t.totalArea, 4.0 * 3.14159265, 0.05 * 4.0 * 3.14159265);
  for (size_t i = 0; i < t.size(); ++i) ASSERT_NEAR(glm::length(t.positions[i]), 1.0f, 0.25f * t.texelSize) << i;

  GpuSamplerConfig config;
  config.count = 3000;
  auto r = sampleOnGpu(context(), *gb, config);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const SampleOrder& o = r->order;
  ASSERT_EQ(o.texels.size(), 3000u);
  for (size_t i = 1; i < o.radii.size(); ++i) ASSERT_LE(o.radii[i], o.radii[i - 1]) << i;
  GBufferTexels exactTexels = pointCloudTexels(*points);
  SampleOrder exact = farthestPointReference(exactTexels, 3000);
  for (uint32_t n : {100u, 1000u, 3000u}) {
    PrefixQuality g = measurePrefix(t, o, n), c = measurePrefix(exactTexels, exact, n);
    std::printf("prefix %4u: gpu points rho %.3f coverage %.4f | exact CPU rho %.3f\n", n, g.rho, g.coverage, c.rho);
    EXPECT_GE(g.rho, 0.65) << n;
    EXPECT_GE(g.rho, 0.9 * c.rho) << n;
    EXPECT_GE(g.coverage, 0.99) << n;
  }
  SurfelCloud cloud = buildSurfelCloud(t, o);
  size_t checked = 0;
  for (const Surfel& s : cloud.surfels) {
    glm::vec3 p = surfelPosition(cloud.box, s);
    EXPECT_NEAR(glm::length(p), 1.0f, t.texelSize); // a disc's plane point, within a texel of the sphere
    EXPECT_GT(glm::dot(surfelNormal(s), glm::normalize(p)), 0.99f);
    if (std::abs(p.y) < 0.1f) continue; // discs near the equator may carry either colour
    EXPECT_EQ(channel(s.color, 0), p.y > 0 ? 255 : 0);
    EXPECT_EQ(channel(s.color, 2), p.y > 0 ? 0 : 255);
    ++checked;
  }
  EXPECT_GT(checked, 2400u);

  // Deterministic: a second capture and sampling give the same texels and the same order.
  auto gb2 = capturePointCloud(context(), *points, capture);
  ASSERT_TRUE(gb2.ok());
  EXPECT_EQ(gb2->texels.ids, t.ids);
  EXPECT_EQ(gb2->texels.positions, t.positions);
  auto r2 = sampleOnGpu(context(), *gb2, config);
  ASSERT_TRUE(r2.ok());
  EXPECT_EQ(r2->order.texels, o.texels);
  EXPECT_EQ(r2->order.radii, o.radii);

  // The same scan without normals: estimated from the neighbours (unoriented), discs two-sided,
  // each texel's normal turned towards its view: on a closed surface that is outwards.
  Scene bare = *scene;
  bare.meshes[0].normals.clear();
  auto estimated = scanPoints(bare);
  ASSERT_TRUE(estimated.ok());
  EXPECT_FALSE(estimated->hasNormals);
  auto gb3 = capturePointCloud(context(), *estimated, capture);
  ASSERT_TRUE(gb3.ok()) << gb3.error().message;
  const GBufferTexels& e = gb3->texels;
  size_t outwards = 0;
  for (size_t i = 0; i < e.size(); ++i) {
    ASSERT_NEAR(glm::length(e.positions[i]), 1.0f, 0.25f * e.texelSize) << i;
    outwards += glm::dot(e.normals[i], glm::normalize(e.positions[i])) > 0.95f;
  }
  std::printf("estimated normals: %zu texels, %.4f outwards, A %.3f\n", e.size(), double(outwards) / double(e.size()),
              e.totalArea);
  EXPECT_GT(double(outwards), 0.98 * double(e.size()));
  EXPECT_NEAR(e.totalArea, 4.0 * 3.14159265, 0.05 * 4.0 * 3.14159265);
}

// A scan of a room from inside: points on the inner faces of a cube with normals pointing in (towards
// the scanner). Views from outside skip the discs facing away (the near walls), so every view sees
// the far walls' insides: all six faces are captured without depth peeling.
TEST_F(SurfelInputs, PointCloudGpuCaptureSeesARoomFromOutside) {
  ScanPoints room;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int face = 0; face < 6; ++face)
    for (int i = 0; i < 3000; ++i) {
      int axis = face / 2;
      float sign = face % 2 ? 1.0f : -1.0f;
      glm::vec3 p(u(rng), u(rng), u(rng)), n(0.0f);
      p[axis] = sign;
      n[axis] = -sign; // inwards
      room.positions.push_back(p);
      room.normals.push_back(n);
      room.colors.push_back(0xff000000u | uint32_t(40 * face));
    }
  room.hasNormals = true;
  room.spacing.assign(room.size(), 0.0f);
  // The spacing pass of scanPoints, on a scene holding these points.
  Scene scene;
  scene.meshes.resize(1);
  scene.meshes[0].positions = room.positions;
  scene.meshes[0].normals = room.normals;
  scene.instances.push_back({0, glm::mat4(1.0f)});
  auto scanned = scanPoints(scene);
  ASSERT_TRUE(scanned.ok()) << scanned.error().message;
  room.spacing = scanned->spacing;

  CaptureConfig capture;
  capture.resolution = 64;
  auto gb = capturePointCloud(context(), room, capture);
  ASSERT_TRUE(gb.ok()) << gb.error().message;
  const GBufferTexels& t = gb->texels;
  // The largest disc radius the capture may splat (a point's spacing; clamps only lower it).
  const float largestDisc = *std::max_element(room.spacing.begin(), room.spacing.end());
  size_t perFace[6] = {};
  for (size_t i = 0; i < t.size(); ++i) {
    glm::vec3 p = t.positions[i];
    // The wall a texel lies on: the coordinate at ±1 (discs near an edge overhang it a little, in
    // their wall's plane).
    glm::vec3 gap = glm::abs(glm::abs(p) - 1.0f);
    int axis = gap.x <= gap.y && gap.x <= gap.z ? 0 : gap.y <= gap.z ? 1 : 2;
    int face = 2 * axis + (p[axis] > 0 ? 1 : 0);
    ++perFace[face];
    ASSERT_NEAR(std::abs(p[axis]), 1.0f, 1e-3f) << i; // flat walls: the discs' planes are the walls
    ASSERT_LT(glm::length(glm::max(glm::abs(p) - 1.0f, 0.0f)), largestDisc) << i; // overhang < a disc radius
    ASSERT_LT(glm::dot(t.normals[i], p), 0.0f) << i;                              // every normal points into the room
  }
  std::printf("room from inside: %zu texels, faces %zu %zu %zu %zu %zu %zu, A %.3f (24)\n", t.size(), perFace[0],
              perFace[1], perFace[2], perFace[3], perFace[4], perFace[5], t.totalArea);
  for (size_t n : perFace) EXPECT_GT(n, t.size() / 12);
  EXPECT_NEAR(t.totalArea, 24.0, 2.4);
  GpuSamplerConfig config;
  config.count = 500;
  auto r = sampleOnGpu(context(), *gb, config);
  ASSERT_TRUE(r.ok()) << r.error().message;
  for (uint32_t n : {100u, 500u}) {
    PrefixQuality q = measurePrefix(t, r->order, n);
    std::printf("room prefix %u: rho %.3f coverage %.4f\n", n, q.rho, q.coverage);
    EXPECT_GE(q.rho, 0.6) << n;
  }
}

// Depth peeling of discs: a scan of a box (half-size 1) around a box (0.4), outward normals: one
// layer sees the outer box only, two reach the inner one (as DepthPeelingReachesTheInnerBox for meshes).
TEST_F(SurfelInputs, PointCloudGpuDepthPeelingReachesTheInnerBox) {
  Scene scene;
  scene.meshes.resize(1);
  Mesh& m = scene.meshes[0];
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (float half : {1.0f, 0.4f})
    for (int face = 0; face < 6; ++face)
      for (int i = 0; i < int(2000 * half * half); ++i) { // the same density on both boxes
        int axis = face / 2;
        float sign = face % 2 ? 1.0f : -1.0f;
        glm::vec3 p(u(rng), u(rng), u(rng)), n(0.0f);
        p[axis] = sign;
        n[axis] = sign; // outwards
        m.positions.push_back(half * p);
        m.normals.push_back(n);
      }
  scene.instances.push_back({0, glm::mat4(1.0f)});
  auto points = scanPoints(scene);
  ASSERT_TRUE(points.ok()) << points.error().message;
  CaptureConfig config;
  config.resolution = 48;
  config.views = 8;
  auto one = capturePointCloud(context(), *points, config);
  ASSERT_TRUE(one.ok()) << one.error().message;
  config.layers = 2;
  auto two = capturePointCloud(context(), *points, config);
  ASSERT_TRUE(two.ok()) << two.error().message;
  EXPECT_EQ(two->texels.viewCount, 16u);
  EXPECT_EQ(two->views.size(), 16u);
  auto inner = [](const GBufferTexels& t) {
    size_t n = 0;
    for (glm::vec3 p : t.positions) n += onInnerBox(p);
    return n;
  };
  std::printf("box in box (points): 1 layer %zu texels (%zu inner), A %.3f; 2 layers %zu texels (%zu inner), A %.3f\n",
              one->texels.size(), inner(one->texels), one->texels.totalArea, two->texels.size(), inner(two->texels),
              two->texels.totalArea);
  EXPECT_EQ(inner(one->texels), 0u);
  EXPECT_GT(inner(two->texels), 1000u);
  EXPECT_NEAR(one->texels.totalArea, 24.0, 2.4);
  EXPECT_NEAR(two->texels.totalArea, 27.84, 2.784);
  GpuSamplerConfig sampler;
  sampler.count = 400;
  auto r = sampleOnGpu(context(), *two, sampler);
  ASSERT_TRUE(r.ok()) << r.error().message;
  size_t innerSurfels = 0;
  for (uint32_t i : r->order.texels) innerSurfels += onInnerBox(two->texels.positions[i]);
  PrefixQuality q = measurePrefix(two->texels, r->order, 400);
  std::printf("2 layers: %zu of 400 surfels on the inner box, rho %.3f\n", innerSurfels, q.rho);
  EXPECT_GT(innerSurfels, 30u);
  EXPECT_GE(q.rho, 0.6);

  // Unoriented (estimated) normals cannot be peeled: an error, not a capture of every inside.
  Scene bare = scene;
  bare.meshes[0].normals.clear();
  auto estimated = scanPoints(bare);
  ASSERT_TRUE(estimated.ok());
  EXPECT_FALSE(capturePointCloud(context(), *estimated, config).ok());
}

TEST_F(SurfelInputs, DepthPeelingReachesTheInnerBox) {
  Scene scene = boxInBox();
  CaptureConfig config;
  config.resolution = 48;
  config.views = 8;
  auto one = captureGBuffer(context(), scene, config);
  ASSERT_TRUE(one.ok()) << one.error().message;
  config.layers = 2;
  auto two = captureGBuffer(context(), scene, config);
  ASSERT_TRUE(two.ok()) << two.error().message;
  EXPECT_EQ(two->texels.viewCount, 16u);
  EXPECT_EQ(two->views.size(), 16u);
  auto inner = [](const GBufferTexels& t) {
    size_t n = 0;
    for (glm::vec3 p : t.positions) n += onInnerBox(p);
    return n;
  };
  EXPECT_EQ(inner(one->texels), 0u);
  EXPECT_GT(inner(two->texels), 1000u);
  // Deduplicated areas: the outer box (24) alone, then both boxes (24 + 3.84), within 10%.
  EXPECT_NEAR(one->texels.totalArea, 24.0, 2.4);
  EXPECT_NEAR(two->texels.totalArea, 27.84, 2.8);

  GpuSamplerConfig sampler;
  sampler.count = 400;
  for (const auto* gb : {&*one, &*two}) {
    auto r = sampleOnGpu(context(), *gb, sampler);
    ASSERT_TRUE(r.ok()) << r.error().message;
    size_t onInner = 0;
    for (uint32_t i : r->order.texels) onInner += onInnerBox(gb->texels.positions[i]);
    // The inner box is 14% of the area with two layers, unseen with one.
    if (gb == &*one) {
      EXPECT_EQ(onInner, 0u);
    } else {
      EXPECT_GT(onInner, 30u);
    }
    EXPECT_GE(measurePrefix(gb->texels, r->order, 400).rho, 0.6);
  }
}

TEST_F(SurfelInputs, CaptureSamplesTheBaseColourTexture) {
  // A cube with a 64² texture: left half red, right half green (u < 0.5 / u >= 0.5), base colour
  // factor halving blue only (not visible: the texture has no blue).
  Scene scene;
  scene.materials.resize(1);
  Texture tex;
  tex.name = "halves";
  tex.width = tex.height = 64;
  for (uint32_t y = 0; y < 64; ++y)
    for (uint32_t x = 0; x < 64; ++x) {
      uint8_t px[4] = {uint8_t(x < 32 ? 255 : 0), uint8_t(x < 32 ? 0 : 255), 0, 255};
      tex.rgba8.insert(tex.rgba8.end(), px, px + 4);
    }
  scene.textures.push_back(tex);
  scene.materials[0].baseColorTexture = 0;
  scene.materials[0].baseColorFactor = glm::vec4(1.0f, 1.0f, 0.5f, 1.0f);
  addCube(scene, 1.0f, 0);
  CaptureConfig config;
  config.resolution = 64;
  config.views = 6;
  auto g = captureGBuffer(context(), scene, config);
  ASSERT_TRUE(g.ok()) << g.error().message;
  const GBufferTexels& t = g->texels;
  const Mesh& m = scene.meshes[0];
  size_t checked = 0;
  for (size_t i = 0; i < t.size(); ++i) {
    // The face the texel is on, and its u from the face's corner 0 -> 1 edge.
    glm::vec3 p = t.positions[i];
    for (size_t f = 0; f < 6; ++f) {
      glm::vec3 n = m.normals[4 * f];
      if (glm::dot(p, n) < 0.999f) continue;
      glm::vec3 e = m.positions[4 * f + 1] - m.positions[4 * f];
      glm::vec3 e2 = m.positions[4 * f + 3] - m.positions[4 * f];
      float u = glm::dot(p - m.positions[4 * f], e) / glm::dot(e, e);
      float v = glm::dot(p - m.positions[4 * f], e2) / glm::dot(e2, e2);
      // Filtering blends near the split; grazing views and 2x2 quads across a cube edge (wild UV
      // derivatives) read coarse mips: check the rest.
      if (std::abs(u - 0.5f) < 0.15f || std::abs(u - 0.5f) > 0.4f || std::abs(v - 0.5f) > 0.4f ||
          std::abs(glm::dot(n, t.directions[t.ids[i] / (64 * 64)])) < 0.7f)
        break;
      bool red = u < 0.5f;
      EXPECT_GE(channel(t.colors[i], 0), red ? 250 : 0) << i;
      EXPECT_LE(channel(t.colors[i], 0), red ? 255 : 5) << i;
      EXPECT_GE(channel(t.colors[i], 1), red ? 0 : 250) << i;
      EXPECT_LE(channel(t.colors[i], 1), red ? 5 : 255) << i;
      ++checked;
      break;
    }
  }
  EXPECT_GT(checked, 1000u); // of about 12 000 texels
}

TEST(SurfelChunks, PerMeshChunksRoundTripAndVersion1StillReads) {
  SurfelCloud a, b;
  a.box.add(glm::vec3(0.0f));
  a.box.add(glm::vec3(1.0f));
  b.box = a.box;
  a.surfels = {packSurfel(a.box, glm::vec3(0.5f), {0, 0, 1}, 0xff0000ffu)};
  a.radii = {0.25f};
  b.surfels = {packSurfel(b.box, glm::vec3(0.1f), {0, 1, 0}, 0xff00ff00u),
               packSurfel(b.box, glm::vec3(0.9f), {1, 0, 0}, 7)};
  b.radii = {1.0f, 0.5f};
  auto dir = mirage::test::tempDir("surfels_chunks");
  std::string path = (dir / "two.mrg").string();
  std::vector<MeshSurfels> clouds = {{3, a}, {7, b}};
  ASSERT_TRUE(writeSurfelMrg(path, clouds).ok());
  auto all = readSurfelMrgAll(path);
  ASSERT_TRUE(all.ok()) << all.error().message;
  ASSERT_EQ(all->size(), 2u);
  EXPECT_EQ((*all)[0].mesh, 3u);
  EXPECT_EQ((*all)[1].mesh, 7u);
  EXPECT_EQ((*all)[1].cloud.radii, b.radii);
  EXPECT_EQ(std::memcmp((*all)[1].cloud.surfels.data(), b.surfels.data(), 2 * sizeof(Surfel)), 0);
  auto single = readSurfelMrg(path); // ambiguous: the error names the count
  ASSERT_FALSE(single.ok());
  EXPECT_NE(single.error().message.find("2 surfel clouds"), std::string::npos) << single.error().message;

  // A whole-scene cloud still reads through the single-cloud API, with mesh = kWholeScene.
  std::string one = (dir / "one.mrg").string();
  ASSERT_TRUE(writeSurfelMrg(one, a).ok());
  auto back = readSurfelMrg(one);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->radii, a.radii);
  EXPECT_EQ(readSurfelMrgAll(one)->front().mesh, kWholeScene);

  // Version 1 (what earlier builds wrote): the header, then surfels and radii, no mesh word.
  std::vector<uint8_t> v2 = encodeSurfelChunkFlat(b, 5);
  std::vector<uint8_t> v1(v2.begin(), v2.begin() + 48);
  v1.insert(v1.end(), v2.begin() + 56, v2.end());
  uint32_t version = 1;
  std::memcpy(v1.data(), &version, 4);
  auto decoded = decodeSurfelChunkWithMesh(v1, "v1");
  ASSERT_TRUE(decoded.ok()) << decoded.error().message;
  EXPECT_EQ(decoded->mesh, kWholeScene);
  EXPECT_EQ(decoded->cloud.radii, b.radii);
  EXPECT_FALSE(decodeSurfelChunk(std::span(v1).first(v1.size() - 1), "short").ok());
}
