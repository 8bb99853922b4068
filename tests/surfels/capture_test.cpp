// G-buffer capture on the GPU: texels lie on the model, normals face their view, the deduplicated
// area matches the mesh's area, multiview and one-pass-per-view agree bit for bit, bad input fails.
#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/io/generate.h"
#include "mirage/surfels/capture.h"

using namespace mirage;
using namespace mirage::surfels;
using mirage::test::GpuTest;

namespace {

Scene blob(uint32_t subdivisions = 4) { return io::generateScene("blob", 1, subdivisions).value(); }

double meshArea(const Scene& s) {
  double a = 0.0;
  for (const Mesh& m : s.meshes)
    for (size_t i = 0; i < m.indices.size(); i += 3) {
      glm::vec3 p0 = m.positions[m.indices[i]], p1 = m.positions[m.indices[i + 1]], p2 = m.positions[m.indices[i + 2]];
      a += 0.5 * glm::length(glm::cross(p1 - p0, p2 - p0));
    }
  return a;
}

} // namespace

class SurfelCapture : public GpuTest {};

TEST_F(SurfelCapture, TexelsLieOnTheBlobAndFaceTheirView) {
  Scene scene = blob();
  CaptureConfig config;
  config.resolution = 64;
  auto g = captureGBuffer(context(), scene, config);
  ASSERT_TRUE(g.ok()) << g.error().message;
  const GBufferTexels& t = g->texels;
  ASSERT_GT(t.size(), 16u * 64 * 64 / 4); // the blob fills a good part of every view
  EXPECT_EQ(g->views.size(), 16u);
  Bounds b = scene.worldBounds();
  size_t facing = 0;
  for (size_t i = 0; i < t.size(); ++i) {
    glm::vec3 slack(t.texelSize);
    EXPECT_TRUE(glm::all(glm::greaterThanEqual(t.positions[i], b.min - slack)) &&
                glm::all(glm::lessThanEqual(t.positions[i], b.max + slack)));
    facing += glm::dot(t.normals[i], t.directions[t.ids[i] / (64 * 64)]) > 0.0f;
    EXPECT_GT(t.areas[i], 0.0f);
  }
  // Interpolated normals may point slightly away at silhouettes; a wrong front face flips them all.
  EXPECT_GT(double(facing) / double(t.size()), 0.97);
  // Concavities hidden from all 16 views make the captured area a little smaller than the mesh's.
  double ratio = t.totalArea / meshArea(scene);
  EXPECT_GT(ratio, 0.85);
  EXPECT_LT(ratio, 1.05);
}

TEST_F(SurfelCapture, MultiviewAndOnePassPerViewAgree) {
  Scene scene = blob(3);
  CaptureConfig a;
  a.resolution = 32;
  a.views = 6;
  CaptureConfig b = a;
  b.maxViewsPerPass = 1;
  auto ga = captureGBuffer(context(), scene, a);
  auto gb = captureGBuffer(context(), scene, b);
  ASSERT_TRUE(ga.ok() && gb.ok());
  EXPECT_EQ(gb->passes, 6u);
  EXPECT_LE(ga->passes, gb->passes);
  EXPECT_EQ(ga->texels.ids, gb->texels.ids);
  EXPECT_EQ(ga->texels.positions, gb->texels.positions);
  EXPECT_EQ(ga->texels.colors, gb->texels.colors);
}

TEST_F(SurfelCapture, BadInputsAreOneLineErrors) {
  Scene scene = blob(2);
  CaptureConfig tooLarge;
  tooLarge.resolution = context().properties().limits.maxImageDimension2D + 1;
  auto r = captureGBuffer(context(), scene, tooLarge);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("resolution"), std::string::npos);
  EXPECT_EQ(r.error().message.find('\n'), std::string::npos);
  CaptureConfig zeroViews;
  zeroViews.views = 0;
  EXPECT_FALSE(captureGBuffer(context(), scene, zeroViews).ok());
  Scene empty;
  empty.source = "empty.glb";
  empty.meshes.push_back(Mesh{});
  empty.instances.push_back(Instance{});
  auto e = captureGBuffer(context(), empty, CaptureConfig{});
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().message, "empty.glb: scene has no triangles to sample");
}
