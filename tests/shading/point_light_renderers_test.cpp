// One point light through every renderer: the lit plane of material_render_test, shaded by the
// cluster-LOD resolve and the surfel resolve through the same include as the forward renderer,
// equals the forward image (cluster: exactly; surfels: within a PSNR bound, as each pixel shows a
// surfel near its ray) and docs/shading.md's falloff at every covered pixel (both).
#include <cstdio>

#include <gtest/gtest.h>

#include "gpu_test.h"
#include "lit_plane.h"
#include "mirage/core/image_metrics.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/cluster_renderer.h"
#include "mirage/render/surfel_renderer.h"
#include "mirage/surfels/surfel.h"

using namespace mirage;
using namespace mirage::render;
using namespace mirage::test;

namespace {

const glm::vec3 kLight{0.5f, 0.0f, 1.5f}, kColor{1.0f, 0.5f, 0.25f};
constexpr float kIntensity = 6.0f, kRadius = 4.0f;

// White matte plane, key light off: the point light alone.
Plane litPlane() {
  Plane p(2.0f);
  p.settings.lightIntensity = 0.0f;
  applyToml(p.scene, R"([[material]]
name = "matte"
model = "blinn-phong"
albedo = [1, 1, 1]
specular = [0, 0, 0]
[[assign]]
mesh = "plane"
use = "matte"
[[light]]
position = [0.5, 0, 1.5]
color = [1, 0.5, 0.25]
intensity = 6
radius = 4
)");
  return p;
}

glm::vec3 expected(glm::vec3 q) { return matteUnderPointLight(q, kLight, kColor * kIntensity, kRadius); }

// A white surfel on the plane every `spacing` over its extent, facing +Z.
surfels::SurfelCloud planeCloud(float half, float spacing) {
  surfels::SurfelCloud c;
  c.box = Bounds{{-half, -half, -0.01f}, {half, half, 0.01f}};
  auto n = uint32_t(2.0f * half / spacing);
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x) {
      glm::vec3 p{-half + (float(x) + 0.5f) * spacing, -half + (float(y) + 0.5f) * spacing, 0.0f};
      c.surfels.push_back(surfels::packSurfel(c.box, p, {0, 0, 1}, 0xffffffffu));
    }
  c.radii.assign(c.surfels.size(), 0.5f * spacing);
  c.referenceCount = std::min<uint32_t>(1000, uint32_t(c.surfels.size()));
  c.referenceMeanSpacing = c.referenceMedianSpacing = spacing;
  return c;
}

} // namespace

class PointLightRenderers : public GpuTest {};

TEST_F(PointLightRenderers, ClusterLodMatchesForwardAndFalloff) {
  Plane p = litPlane();
  ASSERT_EQ(p.scene.lights.size(), 1u);
  auto baked = lod::bakeLodAsset(p.scene, lod::BuildConfig{});
  ASSERT_TRUE(baked.ok()) << baked.error().message;
  auto forward = ForwardRenderer::create(context(), lod::levelZeroScene(*baked));
  ASSERT_TRUE(forward.ok());
  auto a = (*forward)->render(p.settings);
  ASSERT_TRUE(a.ok());
  auto cluster = ClusterRenderer::create(context(), *baked);
  ASSERT_TRUE(cluster.ok()) << cluster.error().message;
  ClusterRenderSettings s;
  s.base = p.settings;
  s.tauPixels = 0.001f;
  auto b = cluster.value()->render(s);
  ASSERT_TRUE(b.ok()) << b.error().message;
  double db = psnr(a->srgb, b->image.srgb);
  std::printf("forward vs cluster LOD, one point light: PSNR %.2f dB\n", db);
  EXPECT_GE(db, 50.0);
  EXPECT_GT(expectPlane(p, b->image.linear, expected), 300u);
  // The light is what lights it: the pixel under the light is far brighter than a corner's.
  EXPECT_GT(rgbAt(b->image.linear, kWidth / 2 + 6, kHeight / 2).r, 4.0f * rgbAt(b->image.linear, 2, 2).r);
}

TEST_F(PointLightRenderers, SurfelsMatchFalloff) {
  Plane p = litPlane();
  surfels::SurfelCloud cloud = planeCloud(p.half, 0.02f);
  SurfelScene scene;
  scene.clouds.push_back({&cloud, p.scene.materials[p.scene.meshes[0].material]});
  scene.instances.push_back({0, glm::mat4(1.0f)});
  scene.lights = p.scene.lights;
  auto r = SurfelRenderer::create(context(), scene);
  ASSERT_TRUE(r.ok()) << r.error().message;
  SurfelRenderSettings s;
  s.base = p.settings;
  s.base.background = {1, 0, 1, 1}; // no lit white surface gives magenta
  s.allSurfels = true;
  s.surfelSize = 0.5f; // the smallest discs: a pixel shows a surfel near its ray
  auto out = r.value()->render(s);
  ASSERT_TRUE(out.ok()) << out.error().message;
  const ImageF32& img = out->image.linear;
  // A pixel shows a surfel within a pixel of its ray, shaded at the surfel's centre: its value lies
  // between the formula's extremes over the neighbouring pixels' ray points.
  shaderio::ViewFrame v = p.view();
  size_t n = 0, bad = 0;
  for (uint32_t y = 1; y + 1 < kHeight; ++y)
    for (uint32_t x = 1; x + 1 < kWidth; ++x) {
      glm::vec3 q = planePoint(v, x, y), got = rgbAt(img, x, y);
      if (std::abs(q.x) > p.half - 0.1f || std::abs(q.y) > p.half - 0.1f) continue;
      glm::vec3 lo(1e9f), hi(0.0f);
      for (uint32_t dy = y - 1; dy <= y + 1; ++dy)
        for (uint32_t dx = x - 1; dx <= x + 1; ++dx) {
          glm::vec3 e = expected(planePoint(v, dx, dy));
          lo = glm::min(lo, e), hi = glm::max(hi, e);
        }
      for (int c = 0; c < 3; ++c)
        if ((got[c] < lo[c] * 0.99f - 1e-3f || got[c] > hi[c] * 1.01f + 1e-3f) && bad++ < 5)
          ADD_FAILURE() << "pixel " << x << "," << y << " channel " << c << ": got " << got[c] << ", expected " << lo[c]
                        << ".." << hi[c];
      ++n;
    }
  EXPECT_EQ(bad, 0u);
  EXPECT_GT(n, 300u);
  // And the whole image is the forward renderer's up to those sub-pixel shifts.
  auto forward = ForwardRenderer::create(context(), p.scene);
  ASSERT_TRUE(forward.ok());
  RenderSettings fs = p.settings;
  fs.background = s.base.background;
  auto f = forward.value()->render(fs);
  ASSERT_TRUE(f.ok());
  double db = psnr(f->srgb, out->image.srgb);
  std::printf("forward vs surfels, one point light: PSNR %.2f dB\n", db);
  EXPECT_GE(db, 40.0);
}
