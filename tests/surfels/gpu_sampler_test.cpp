// The GPU progressive sampler against the CPU reference on a small blob: prefixes keep ρ >= 0.65
// and >= 90% of the reference's ρ, radii never grow, every sample is a distinct texel, and two runs
// give the same order.
#include <algorithm>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <set>

#include "mirage/gpu/commands.h"
#include "gpu_test.h"
#include "mirage/io/generate.h"
#include "mirage/surfels/gpu_sampler.h"
#include "mirage/surfels/reference.h"

using namespace mirage;
using namespace mirage::surfels;
using mirage::test::GpuTest;

class SurfelGpuSampler : public GpuTest {};

TEST_F(SurfelGpuSampler, MatchesTheReferenceQuality) {
  Scene scene = io::generateScene("blob", 1, 5).value();
  CaptureConfig capture;
  capture.resolution = 96;
  auto gb = captureGBuffer(context(), scene, capture);
  ASSERT_TRUE(gb.ok()) << gb.error().message;
  const GBufferTexels& t = gb->texels;
  GpuSamplerConfig config;
  config.count = 5000;
  auto r = sampleOnGpu(context(), *gb, config);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const SampleOrder& o = r->order;
  ASSERT_EQ(o.texels.size(), 5000u);
  EXPECT_EQ(std::set<uint32_t>(o.texels.begin(), o.texels.end()).size(), o.texels.size());
  for (size_t i = 1; i < o.radii.size(); ++i) ASSERT_LE(o.radii[i], o.radii[i - 1]) << i;
  EXPECT_EQ(o.texels[0], farthestPointReference(t, 1).texels[0]); // the same deterministic first sample

  SampleOrder ref = farthestPointReference(t, 5000);
  for (uint32_t n : {100u, 1000u, 5000u}) {
    PrefixQuality g = measurePrefix(t, o, n), c = measurePrefix(t, ref, n);
    std::printf("prefix %5u: gpu rho %.3f coverage %.4f | reference rho %.3f coverage %.4f\n", n, g.rho, g.coverage,
                c.rho, c.coverage);
    EXPECT_GE(g.rho, 0.65) << n;
    EXPECT_GE(g.rho, 0.9 * c.rho) << n;
    EXPECT_GE(g.coverage, 0.99) << n;
  }
  std::printf("%u rounds, %.3f s\n", r->rounds, r->seconds);

  // The same run with a progress callback (what `mirage surfels` draws its bar from): once per round,
  // samples never decreasing, ending at the count; the order is unchanged.
  std::vector<uint32_t> reported;
  config.progress = [&](uint32_t samples, uint32_t count, uint32_t rounds) {
    EXPECT_EQ(count, 5000u);
    EXPECT_EQ(rounds, reported.size() + 1);
    reported.push_back(samples);
  };
  auto again = sampleOnGpu(context(), *gb, config);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(reported.size(), again->rounds);
  EXPECT_TRUE(std::is_sorted(reported.begin(), reported.end()));
  ASSERT_FALSE(reported.empty());
  EXPECT_EQ(reported.back(), 5000u);
  EXPECT_EQ(again->order.texels, o.texels);
  EXPECT_EQ(again->order.radii, o.radii);
}

TEST_F(SurfelGpuSampler, StopsWhenTexelsRunOut) {
  Scene scene = io::generateScene("blob", 2, 2).value();
  CaptureConfig capture;
  capture.resolution = 8;
  capture.views = 3;
  auto gb = captureGBuffer(context(), scene, capture);
  ASSERT_TRUE(gb.ok());
  GpuSamplerConfig config;
  config.count = 1000000;
  auto r = sampleOnGpu(context(), *gb, config);
  ASSERT_TRUE(r.ok());
  // Every texel ends up a sample except texels that coincide with one (distance 0).
  EXPECT_LE(r->order.texels.size(), gb->texels.size());
  EXPECT_GT(r->order.texels.size(), gb->texels.size() * 9 / 10);
  config.count = 0;
  EXPECT_FALSE(sampleOnGpu(context(), *gb, config).ok());
}

// The raster splatters (mesh shader, geometry shader) apply the compute splatter's atomics on the
// same keys to the same texels: the whole order and every radius are bit-identical.
TEST_F(SurfelGpuSampler, DiscRastersGiveTheComputeOrder) {
  Scene scene = io::generateScene("blob", 1, 7).value();
  CaptureConfig capture;
  capture.resolution = 64;
  capture.views = 6;
  auto gb = captureGBuffer(context(), scene, capture);
  ASSERT_TRUE(gb.ok()) << gb.error().message;
  GpuSamplerConfig config;
  config.count = 3000;
  auto compute = sampleOnGpu(context(), *gb, config);
  ASSERT_TRUE(compute.ok()) << compute.error().message;
  ASSERT_EQ(compute->order.texels.size(), 3000u);
  for (DiscRaster raster : {DiscRaster::Mesh, DiscRaster::Geometry, DiscRaster::MeshDepth}) {
    SCOPED_TRACE(toString(raster));
    config.discRaster = raster;
    if (std::string why = discRasterUnsupported(context(), raster); !why.empty()) {
      EXPECT_FALSE(sampleOnGpu(context(), *gb, config).ok()); // refused with the reason, not run
      continue;
    }
    auto r = sampleOnGpu(context(), *gb, config);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->rounds, compute->rounds);
    EXPECT_EQ(r->order.texels, compute->order.texels);
    EXPECT_EQ(r->order.radii, compute->order.radii);
  }
}

// A hand-made G-buffer full of exact distance ties: two views of the same 32 × 32 grid of integer
// points (+0.5) on z = 0, the second mirrored, so every point is two texels at distance 0 and
// symmetric points are exactly equidistant; a hole of empty texels (w = 0) in the first view. Every
// splatter must break every tie as compute's atomics do (the depth test by primitive order).
GpuGBuffer tiedGrid(gpu::Context& ctx) {
  const uint32_t res = 32;
  const float half = 16.0f; // world [-16, 16]², texel size 1
  GpuGBuffer gb;
  GBufferTexels& t = gb.texels;
  t.resolution = res;
  t.viewCount = 2;
  t.texelSize = 2.0f * half / float(res);
  t.sphereRadius = half * std::sqrt(2.0f);
  std::vector<glm::vec4> positions(size_t(2) * res * res, glm::vec4(0.0f));
  for (uint32_t view = 0; view < 2; ++view) {
    shaderio::SurfelView v{};
    v.viewProj = glm::mat4(1.0f);
    v.viewProj[0][0] = (view == 0 ? 1.0f : -1.0f) / half; // view 1 sees the grid mirrored in x
    v.viewProj[1][1] = 1.0f / half;
    v.viewProj[2][2] = 0.0f;
    v.viewProj[3][2] = 0.5f;
    v.direction = glm::vec4(0.0f, 0.0f, view == 0 ? 1.0f : -1.0f, 0.0f);
    gb.views.push_back(v);
    t.directions.push_back(glm::vec3(v.direction));
    for (uint32_t y = 0; y < res; ++y)
      for (uint32_t x = 0; x < res; ++x) {
        float px = float(x) + 0.5f - half, py = float(y) + 0.5f - half;
        if (view == 0 && px * px + py * py < 16.0f) continue; // the hole
        uint32_t id = (view * res + y) * res + x;
        glm::vec3 p(view == 0 ? px : -px, py, 0.0f);
        positions[id] = glm::vec4(p, 1.0f);
        t.ids.push_back(id);
        t.positions.push_back(p);
        t.normals.push_back(glm::vec3(0.0f, 0.0f, 1.0f));
        t.colors.push_back(~0u);
        t.areas.push_back(0.5f);
      }
  }
  t.totalArea = 0.5 * double(t.size());
  gb.positions =
      gpu::createBufferWithData<glm::vec4>(ctx, positions, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "tied grid positions");
  return gb;
}

TEST_F(SurfelGpuSampler, DiscRastersBreakExactTiesAsCompute) {
  GpuGBuffer gb = tiedGrid(context());
  GpuSamplerConfig config;
  config.count = 800;
  auto compute = sampleOnGpu(context(), gb, config);
  ASSERT_TRUE(compute.ok()) << compute.error().message;
  ASSERT_EQ(compute->order.texels.size(), 800u);
  for (DiscRaster raster : {DiscRaster::Mesh, DiscRaster::Geometry, DiscRaster::MeshDepth}) {
    if (!discRasterUnsupported(context(), raster).empty()) continue;
    SCOPED_TRACE(toString(raster));
    config.discRaster = raster;
    auto r = sampleOnGpu(context(), gb, config);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->order.texels, compute->order.texels);
    EXPECT_EQ(r->order.radii, compute->order.radii);
  }
}

TEST(SurfelDiscRaster, ParsesTheChoices) {
  for (DiscRaster r : {DiscRaster::Compute, DiscRaster::Mesh, DiscRaster::Geometry, DiscRaster::MeshDepth})
    EXPECT_EQ(parseDiscRaster(toString(r)).value(), r);
  auto bad = parseDiscRaster("depth");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("expected compute, mesh, geometry or mesh-depth"), std::string::npos);
}

// Non-finite texel positions (a NaN coordinate that reached the capture) are refused before any
// GPU round: their distances compare false both ways and the rounds would never end.
TEST_F(SurfelGpuSampler, RefusesNonFiniteTexels) {
  Scene scene = io::generateScene("blob", 2, 2).value();
  CaptureConfig capture;
  capture.resolution = 16;
  capture.views = 3;
  auto gb = captureGBuffer(context(), scene, capture);
  ASSERT_TRUE(gb.ok()) << gb.error().message;
  ASSERT_GT(gb->texels.size(), 10u);
  GpuSamplerConfig config;
  config.count = 50;
  gb->texels.positions[7].y = std::numeric_limits<float>::quiet_NaN();
  auto r = sampleOnGpu(context(), *gb, config);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("non-finite"), std::string::npos) << r.error().message;
  gb->texels.positions[7].y = 0.0f;
  gb->texels.sphereRadius = std::numeric_limits<float>::infinity();
  EXPECT_FALSE(sampleOnGpu(context(), *gb, config).ok());
}

// The rounds' bound on its own: the G-buffer's GPU positions turned into NaN behind the host
// texels' back (so the up-front check passes) make every distance incomparable; the sampler must
// stop with an error instead of resubmitting rounds forever.
TEST_F(SurfelGpuSampler, RoundsAreBounded) {
  Scene scene = io::generateScene("blob", 2, 2).value();
  CaptureConfig capture;
  capture.resolution = 16;
  capture.views = 3;
  auto gb = captureGBuffer(context(), scene, capture);
  ASSERT_TRUE(gb.ok()) << gb.error().message;
  std::vector<uint8_t> bytes = gpu::readbackBuffer(context(), gb->positions, gb->positions.size());
  std::vector<float> positions(bytes.size() / 4);
  std::memcpy(positions.data(), bytes.data(), bytes.size());
  for (size_t i = 0; i + 3 < positions.size(); i += 4)
    if (positions[i + 3] >= 0.5f) positions[i] = std::numeric_limits<float>::quiet_NaN(); // valid texels' x
  gpu::uploadBuffer(context(), gb->positions, positions.data(), bytes.size());
  GpuSamplerConfig config;
  config.count = 50;
  auto r = sampleOnGpu(context(), *gb, config);
  ASSERT_FALSE(r.ok()) << r->order.texels.size() << " samples in " << r->rounds << " rounds";
  EXPECT_NE(r.error().message.find("appended none"), std::string::npos) << r.error().message;
}
