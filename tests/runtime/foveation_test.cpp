// Foveation on the GPU (--fovea, RenderConfig::foveation): tau grows away from the gaze, so fewer
// triangles are drawn, while the image inside the fovea stays as without it; the LOD BVH traversal
// selects the same cut as the flat pass (the node test stays conservative).
#include <cmath>

#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/core/image_metrics.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/runtime/scene.h"
#include "test_support.h"

using namespace mirage;

namespace {

constexpr uint32_t kFoveationWidth = 160, kFoveationHeight = 120;

const std::string& gridMrg() {
  static const std::string path = [] {
    auto asset = lod::bakeLodAsset(io::generateScene("blob", 1, 4).value(), {}).value();
    auto p = (test::tempDir("runtime_fovea") / "blob.mrg").string();
    if (!lod::saveLodAsset(p, asset).ok()) std::abort();
    return p;
  }();
  return path;
}

// The pixels within `degrees` of the screen centre (the gaze), as one row.
ImageRGBA8 foveaPixels(const ImageRGBA8& image, float fovYDegrees, float degrees) {
  ImageRGBA8 out{0, 1, {}};
  float focal = 0.5f * float(image.height) / std::tan(0.5f * glm::radians(fovYDegrees));
  for (uint32_t y = 0; y < image.height; ++y)
    for (uint32_t x = 0; x < image.width; ++x) {
      float dx = float(x) + 0.5f - 0.5f * float(image.width), dy = float(y) + 0.5f - 0.5f * float(image.height);
      if (std::atan(std::sqrt(dx * dx + dy * dy) / focal) > glm::radians(degrees)) continue;
      out.pixels.insert(out.pixels.end(), image.at(x, y), image.at(x, y) + 4);
      ++out.width;
    }
  return out;
}

} // namespace

class RuntimeFoveation : public test::GpuTest {};

namespace {

TEST_F(RuntimeFoveation, FewerTrianglesSameFovea) {
  auto opened = runtime::Scene::open(test::gpuContext(), {.input = gridMrg(), .grid = 4});
  ASSERT_TRUE(opened.ok()) << opened.error().message;
  runtime::Scene& scene = **opened;
  runtime::View view;
  view.width = kFoveationWidth;
  view.height = kFoveationHeight;
  view.camera = render::autoCamera(scene.bounds(), float(kFoveationWidth) / float(kFoveationHeight));
  view.config.tauPixels = 2.0f;
  view.config.selection = render::SelectionMode::Flat;
  auto full = scene.render(view);
  ASSERT_TRUE(full.ok()) << full.error().message;
  view.config.foveation = true;
  view.config.foveaGaze = {0.5f, 0.5f};
  view.config.foveaRadiusDegrees = 5.0f;
  auto fov = scene.render(view);
  ASSERT_TRUE(fov.ok()) << fov.error().message;
  EXPECT_LT(fov->trianglesDrawn, full->trianglesDrawn * 3 / 4) << "foveation saved too little";
  ImageRGBA8 a = foveaPixels(full->srgb, view.camera.fovYDegrees, 5.0f);
  ImageRGBA8 b = foveaPixels(fov->srgb, view.camera.fovYDegrees, 5.0f);
  ASSERT_GT(a.width, 100u);
  double p = psnr(a, b);
  EXPECT_TRUE(std::isinf(p) || p >= 40.0) << p << " dB inside the fovea";
  std::printf("foveation: %llu -> %llu triangles (%.1f %% saved), fovea PSNR %.2f dB over %u pixels\n",
              (unsigned long long)full->trianglesDrawn, (unsigned long long)fov->trianglesDrawn,
              100.0 * (1.0 - double(fov->trianglesDrawn) / double(full->trianglesDrawn)), p, a.width);
  // The hierarchical traversals take the same cut as the flat pass.
  for (auto mode : {render::SelectionMode::Hierarchy, render::SelectionMode::Dag}) {
    view.config.selection = mode;
    auto h = scene.render(view);
    ASSERT_TRUE(h.ok()) << h.error().message;
    EXPECT_EQ(h->trianglesDrawn, fov->trianglesDrawn) << render::toString(mode);
    EXPECT_EQ(h->clustersDrawn, fov->clustersDrawn) << render::toString(mode);
  }
}

TEST_F(RuntimeFoveation, BadFoveaIsRefused) {
  runtime::RenderConfig c;
  c.foveation = true;
  c.foveaGaze = {1.5f, 0.5f};
  EXPECT_FALSE(runtime::validate(c));
  c.foveaGaze = {0.5f, 0.5f};
  c.foveaRadiusDegrees = -1.0f;
  EXPECT_FALSE(runtime::validate(c));
  c.foveaRadiusDegrees = 5.0f;
  EXPECT_TRUE(runtime::validate(c));
}

} // namespace
