// The GPU progressive sampler against the CPU reference on a small blob: prefixes keep ρ >= 0.65
// and >= 90% of the reference's ρ, radii never grow, every sample is a distinct texel, and two runs
// give the same order.
#include <gtest/gtest.h>

#include <cstdio>
#include <set>

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

  auto again = sampleOnGpu(context(), *gb, config);
  ASSERT_TRUE(again.ok());
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

TEST(SurfelDiscRaster, ParsesTheChoices) {
  for (DiscRaster r : {DiscRaster::Compute, DiscRaster::Mesh, DiscRaster::Geometry, DiscRaster::MeshDepth})
    EXPECT_EQ(parseDiscRaster(toString(r)).value(), r);
  auto bad = parseDiscRaster("depth");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("expected compute, mesh, geometry or mesh-depth"), std::string::npos);
}
