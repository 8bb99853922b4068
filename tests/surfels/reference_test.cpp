// CPU reference sampler and metrics: an exact hand-made case, then invariants on a captured blob
// (ρ of the 1k and 10k prefixes, non-increasing radii, full coverage, determinism), and the PLY and
// .mrg round trips.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "gpu_test.h"
#include "mirage/io/generate.h"
#include "mirage/surfels/capture.h"
#include "mirage/surfels/reference.h"
#include "mirage/surfels/surfel_io.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::surfels;
using mirage::test::GpuTest;

namespace {

// Five texels on a line, x = 0..4, centred on x = 2.
GBufferTexels lineTexels() {
  GBufferTexels t;
  t.center = {2, 0, 0};
  t.sphereRadius = 2.0f;
  for (uint32_t i = 0; i < 5; ++i) {
    t.ids.push_back(i);
    t.positions.push_back({float(i), 0, 0});
    t.normals.push_back({0, 0, 1});
    t.colors.push_back(0xff000000u | i);
    t.areas.push_back(1.0f);
  }
  t.totalArea = 5.0;
  return t;
}

// The blob at 128² × 16 views, captured once per test process (~170k texels).
const GBufferTexels& blobTexels() {
  static GBufferTexels texels = [] {
    Scene scene = io::generateScene("blob", 1, 5).value();
    CaptureConfig config;
    config.resolution = 128;
    return captureGBuffer(mirage::test::gpuContext(), scene, config).value().texels;
  }();
  return texels;
}

} // namespace

TEST(SurfelReference, ExactOrderOnALine) {
  GBufferTexels t = lineTexels();
  SampleOrder o = farthestPointReference(t, 10);
  EXPECT_EQ(o.texels, (std::vector<uint32_t>{4, 0, 2, 3, 1})); // ties go to the larger index
  EXPECT_EQ(o.radii, (std::vector<float>{4.0f, 4.0f, 2.0f, 1.0f, 1.0f}));
  PrefixQuality q = measurePrefix(t, o, 3);
  EXPECT_DOUBLE_EQ(q.rMin, 1.0); // samples 4, 0, 2: nearest neighbours 2 apart
  EXPECT_DOUBLE_EQ(q.coverage, 1.0);
  EXPECT_EQ(farthestPointReference(t, 2).texels, (std::vector<uint32_t>{4, 0}));
}

class SurfelReferenceBlob : public GpuTest {};

TEST_F(SurfelReferenceBlob, PrefixesAreBlueNoise) {
  const GBufferTexels& t = blobTexels();
  ASSERT_GT(t.size(), 100000u);
  SampleOrder o = farthestPointReference(t, 10000);
  ASSERT_EQ(o.texels.size(), 10000u);
  for (size_t i = 1; i < o.radii.size(); ++i) ASSERT_LE(o.radii[i], o.radii[i - 1]) << i;
  for (uint32_t n : {1000u, 10000u}) {
    PrefixQuality q = measurePrefix(t, o, n);
    EXPECT_GE(q.rho, 0.65) << n;
    EXPECT_LE(q.rho, 1.0) << n;
    EXPECT_DOUBLE_EQ(q.coverage, 1.0) << n; // exact farthest-point: every texel within the prefix radius
    EXPECT_NEAR(q.rMin, 0.5 * q.radius, 1e-6 * q.radius) << n;
  }
  // Determinism: the same texels give the same order.
  SampleOrder again = farthestPointReference(t, 10000);
  EXPECT_EQ(again.texels, o.texels);
  EXPECT_EQ(again.radii, o.radii);
}

TEST_F(SurfelReferenceBlob, PlyAndMrgRoundTrips) {
  const GBufferTexels& t = blobTexels();
  SurfelCloud cloud = buildSurfelCloud(t, farthestPointReference(t, 2000));
  EXPECT_EQ(cloud.referenceCount, 1000u);
  EXPECT_GT(cloud.referenceMedianSpacing, 0.0f);
  auto dir = mirage::test::tempDir("surfels_io");
  std::string ply = (dir / "blob.ply").string();
  ASSERT_TRUE(writeSurfelPly(ply, cloud).ok());
  auto back = readSurfelPly(ply);
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->size(), cloud.size());
  EXPECT_EQ(back->radii, cloud.radii);
  EXPECT_EQ(back->referenceCount, cloud.referenceCount);
  for (size_t i = 0; i < cloud.size(); ++i) {
    ASSERT_EQ(back->surfels[i].posLo, cloud.surfels[i].posLo) << i;
    ASSERT_EQ(back->surfels[i].posHi, cloud.surfels[i].posHi) << i;
    ASSERT_EQ(back->surfels[i].color, cloud.surfels[i].color) << i;
    ASSERT_GT(glm::dot(surfelNormal(back->surfels[i]), surfelNormal(cloud.surfels[i])), 0.9999f) << i;
  }
  std::string mrg = (dir / "blob.mrg").string();
  ASSERT_TRUE(writeSurfelMrg(mrg, cloud).ok());
  auto m = readSurfelMrg(mrg);
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_EQ(*encodeSurfelChunk(*m), *encodeSurfelChunk(cloud));

  // A truncated PLY is a one-line error, not a crash.
  std::filesystem::resize_file(ply, std::filesystem::file_size(ply) - 10);
  auto bad = readSurfelPly(ply);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("truncated"), std::string::npos);
  EXPECT_FALSE(decodeSurfelChunk(std::vector<uint8_t>(20), "x.mrg").ok());
}
